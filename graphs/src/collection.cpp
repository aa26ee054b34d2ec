#include "holoflow/graphs/collection.h"

#include <algorithm>
#include <exception>
#include <optional>

#include <tbb/global_control.h>

#include "holoflow/engine/status.h"

namespace holoflow::graphs {
namespace {

// Whether a model hit the memory limit: refused, or a refinement try refused.
bool over_memory_limit(const ModelRun& run) {
    return run.outcome.status.kind == "resource_limit" ||
           (run.report.is_object() && run.report.value("tries_over_memory_limit", 0) > 0);
}

}  // namespace

CollectionRun run_collection(const std::vector<engine::ModelTask>& tasks, const CollectionOptions& options,
                             engine::BatchProgress& progress, std::ostream& log, engine::FactorizationCache* cache) {
    const unsigned threads = std::max(1u, options.threads);
    const tbb::global_control parallelism(tbb::global_control::max_allowed_parallelism, threads);

    CollectionRun result;
    result.outcomes.resize(tasks.size());
    std::vector<engine::ModelTask> todo;
    std::vector<std::size_t> todo_index;
    for (std::size_t i = 0; i < tasks.size(); ++i) {
        std::optional<engine::ModelOutcome> done =
            options.force ? std::nullopt : engine::finished_model(tasks[i], options.settings);
        if (done) {
            result.outcomes[i] = std::move(*done);
            progress.model_finished(false, true);
            continue;
        }
        engine::ModelTask task = tasks[i];
        task.id = todo.size();
        todo.push_back(std::move(task));
        todo_index.push_back(i);
    }
    result.reused = tasks.size() - todo.size();

    // The models computed side by side share the memory limit; alone, one has all of it.
    const SegmentationGraphOptions& alone = options.graph;
    SegmentationGraphOptions shared = alone;
    const std::size_t concurrent =
        options.serial ? 1 : std::max<std::size_t>(1, std::min({std::size_t{threads}, alone.max_in_flight, todo.size()}));
    std::size_t& share = shared.segment.conformal.max_solver_bytes;
    share /= concurrent;
    const bool split = share != alone.segment.conformal.max_solver_bytes;
    shared.segment.stop_at_memory_limit = split;  // it is computed again alone anyway

    std::vector<std::size_t> deferred;  // ids in todo
    const auto finish = [&](ModelRun& run) {
        try {
            engine::write_model_result(run.outcome, options.settings);
        } catch (...) {
            run.outcome.status = engine::status_from_exception(std::current_exception(), "result");
        }
        progress.model_finished(!run.outcome.status.ok(), false);
    };
    const auto run_graph = [&](const SegmentationGraph& graph, const std::vector<engine::ModelTask>& list,
                               const ModelCallback& on_done) {
        return options.serial ? graph.run_serial(list, on_done) : graph.run(list, on_done);
    };
    std::vector<ModelRun> runs = run_graph(SegmentationGraph(shared, cache), todo, [&](ModelRun& run) {
        if (split && over_memory_limit(run)) deferred.push_back(run.outcome.task.id);
        else finish(run);
    });
    if (!deferred.empty()) {
        std::sort(deferred.begin(), deferred.end());
        std::vector<engine::ModelTask> again;
        for (std::size_t id : deferred) {
            engine::ModelTask task = todo[id];
            task.id = again.size();
            result.recomputed_alone.push_back(task.name);
            again.push_back(std::move(task));
        }
        log << "holoflow: " << deferred.size() << " model(s) over their share of the memory limit (" << (share >> 20)
            << " MiB), computed again one at a time with " << (alone.segment.conformal.max_solver_bytes >> 20)
            << " MiB:";
        for (const std::string& name : result.recomputed_alone) log << ' ' << name;
        log << std::endl;
        SegmentationGraphOptions one_at_a_time = alone;
        one_at_a_time.max_in_flight = 1;
        std::vector<ModelRun> rerun = run_graph(SegmentationGraph(one_at_a_time, cache), again, finish);
        for (std::size_t k = 0; k < deferred.size(); ++k) runs[deferred[k]] = std::move(rerun[k]);
    }
    for (std::size_t k = 0; k < runs.size(); ++k) {
        result.outcomes[todo_index[k]] = std::move(runs[k].outcome);
        result.outcomes[todo_index[k]].task = tasks[todo_index[k]];
    }
    return result;
}

}  // namespace holoflow::graphs
