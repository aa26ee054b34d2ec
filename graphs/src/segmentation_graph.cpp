#include "holoflow/graphs/segmentation_graph.h"

#include <atomic>
#include <exception>
#include <tuple>

#include "holoflow/engine/flow_graph.h"
#include "holoflow/engine/output.h"

namespace holoflow::graphs {
namespace {

using engine::ConformalWork;
using engine::Item;
using engine::StageClock;
namespace conformal_stage = engine::conformal_stage;
namespace segment_stage = engine::segment_stage;
using Clock = std::chrono::steady_clock;

//! One model on its way through the stages.
struct ModelState {
    engine::ModelTask task;
    Clock::time_point deadline = Clock::time_point::max();
    engine::Status status;
    engine::StageTimes load_times, write_times;  // around the pipeline's own stage times
    engine::PolygonSoup soup;
    std::shared_ptr<const MeshView> mesh;
    engine::SegmentationWork work;
    std::atomic<int> blocks_left{0};
    std::vector<std::exception_ptr> block_errors;  // one slot per solve block
    ModelRun run;

    //! Drops the heavy data of a failed (or written) model; the outcome fields stay.
    void release() {
        soup = {};
        work = {};
    }
};

using ModelItem = Item<ModelState>;

//! One solve block of one model.
struct SolveBlock {
    ModelItem model;
    int block = 0;
};

// The stages, shared by the graph's nodes and the serial twin.
struct Stages {
    const SegmentationGraphOptions& options;
    engine::FactorizationCache* cache;

    void read(ModelState& s) const {
        if (options.timeout.count() > 0) s.deadline = Clock::now() + options.timeout;
        StageClock clock(s.load_times);
        s.soup = engine::read_polygon_soup(s.task.path);
        clock.lap("read");
    }
    void validate(ModelState& s) const {
        StageClock clock(s.load_times);
        engine::LoadedMesh loaded = engine::mesh_from_soup(s.soup, options.load);
        s.soup = {};
        s.mesh = std::move(loaded.mesh);
        s.run.outcome.vertices = static_cast<std::size_t>(s.mesh->n_vertices());
        s.run.outcome.faces = static_cast<std::size_t>(s.mesh->n_faces());
        clock.lap("validate");
    }
    void prepare(ModelState& s) const {
        s.work = segment_stage::prepare(s.mesh, options.segment);
        s.run.outcome.genus = s.work.result.input_genus;
    }
    void factorise(ModelState& s) const { conformal_stage::factorise(s.work.conformal, cache); }
    //! Sizes the block slots; returns the number of blocks.
    int begin_solves(ModelState& s) const {
        const int blocks = conformal_stage::begin_solves(s.work.conformal);
        s.block_errors.assign(blocks, nullptr);
        s.blocks_left.store(blocks);
        return blocks;
    }
    //! Solves one block into its own slot; never throws (the error waits in its slot).
    void solve(ModelState& s, int block) const {
        try {
            s.work.conformal.potential_blocks[block] = conformal_stage::solve_block(s.work.conformal, block);
        } catch (...) {
            s.block_errors[block] = std::current_exception();
        }
    }
    //! After the last block: the first failed block (by index) fails the model.
    void end_solves(ModelState& s) const {
        for (const std::exception_ptr& e : s.block_errors)
            if (e) std::rethrow_exception(e);
        s.block_errors.clear();
        conformal_stage::end_solves(s.work.conformal);
    }
    void write(ModelState& s) const {
        StageClock clock(s.write_times);
        const engine::SegmentationResult& r = s.work.result;
        s.run.outcome.working_genus = r.conformal.basis.genus;
        s.run.outcome.zeros = r.zeros.total_order;
        s.run.outcome.patches = static_cast<std::int64_t>(r.patches.info.size());
        if (!s.task.out_dir.empty()) {
            engine::prepare_output_folder(s.task.out_dir);
            engine::remove_stale_temporaries(s.task.out_dir, engine::kSegmentationFiles);  // a killed run's
            s.run.report = engine::write_segmentation_folder(s.task.out_dir, s.task.path, r);
        } else {
            s.run.report = engine::segmentation_report(r);
            s.run.report["file"] = s.task.path;
        }
        if (options.keep_results)
            s.run.result = std::make_shared<const engine::SegmentationResult>(std::move(s.work.result));
        s.release();
        clock.lap("write");
    }
};

std::shared_ptr<ModelState> new_state(const engine::ModelTask& task) {
    auto s = std::make_shared<ModelState>();
    s->task = task;
    s->run.outcome.task = task;
    return s;
}

// The outcome as the collector hands it out: status and all stage times in order.
ModelRun finish(ModelState& s) {
    s.release();
    s.mesh.reset();
    engine::ModelOutcome& o = s.run.outcome;
    o.status = s.status;
    o.timings_ms.clear();
    double load = 0;
    for (const auto& [stage, ms] : s.load_times) load += ms;
    if (!s.load_times.empty()) o.timings_ms.emplace_back("load", load);
    if (s.run.report.contains("timings_ms"))
        for (const auto& [stage, ms] : s.run.report["timings_ms"].items())
            if (stage != "total") o.timings_ms.emplace_back(stage, ms.get<double>());
    for (const auto& t : s.write_times) o.timings_ms.push_back(t);
    if (!o.status.ok()) s.run.report = nullptr;
    return std::move(s.run);
}

// Builds the whole graph into `g`; `runs` receives each model's result at its id.
void build(engine::Graph& g, const Stages& stages, const SegmentationGraphOptions& options,
           const std::vector<engine::ModelTask>& tasks, std::vector<ModelRun>& runs,
           const ModelCallback& on_done) {
    using namespace tbb::flow;
    using engine::add_stage_node;
    using SplitNode = multifunction_node<ModelItem, std::tuple<SolveBlock, ModelItem>>;
    using SolveNode = multifunction_node<SolveBlock, std::tuple<ModelItem>>;

    auto next = std::make_shared<std::size_t>(0);
    auto& source = g.add<input_node<ModelItem>>("models", [&tasks, next](tbb::flow_control& control) {
        if (*next == tasks.size()) {
            control.stop();
            return ModelItem{};
        }
        const engine::ModelTask& task = tasks[(*next)++];
        return ModelItem{task.id, new_state(task)};
    });
    auto& in_flight = g.add<limiter_node<ModelItem>>("in_flight", std::max<std::size_t>(1, options.max_in_flight));
    auto& read = add_stage_node<ModelState>(g, "read", [&](ModelState& s) { stages.read(s); });
    auto& validate = add_stage_node<ModelState>(g, "validate", [&](ModelState& s) { stages.validate(s); });
    auto& prepare = add_stage_node<ModelState>(g, "prepare", [&](ModelState& s) { stages.prepare(s); });
    auto& homology = add_stage_node<ModelState>(
        g, "homology", [](ModelState& s) { conformal_stage::homology(s.work.conformal); });
    auto& laplacian = add_stage_node<ModelState>(
        g, "laplacian", [](ModelState& s) { conformal_stage::laplacian(s.work.conformal); });
    auto& factorise = add_stage_node<ModelState>(g, "factorise", [&](ModelState& s) { stages.factorise(s); });
    auto& split_solves = g.add<SplitNode>(
        "split_solves", unlimited, [&](const ModelItem& item, SplitNode::output_ports_type& ports) {
            int blocks = 0;
            engine::run_stage(*item.state, "solves", [&](ModelState& s) { blocks = stages.begin_solves(s); });
            if (blocks == 0) std::get<1>(ports).try_put(item);  // failed: straight on
            for (int b = 0; b < blocks; ++b) std::get<0>(ports).try_put(SolveBlock{item, b});
        });
    auto& solve = g.add<SolveNode>("solve", unlimited, [&](const SolveBlock& block, SolveNode::output_ports_type& ports) {
        ModelState& s = *block.model.state;
        stages.solve(s, block.block);
        // The last block to finish passes the model on (acq_rel: it sees every block's slot).
        if (s.blocks_left.fetch_sub(1, std::memory_order_acq_rel) == 1) std::get<0>(ports).try_put(block.model);
    });
    auto& end_solves = add_stage_node<ModelState>(g, "end_solves", [&](ModelState& s) { stages.end_solves(s); });
    auto& hodge_star = add_stage_node<ModelState>(
        g, "hodge_star", [](ModelState& s) { conformal_stage::hodge_star(s.work.conformal); });
    auto& integrate = add_stage_node<ModelState>(
        g, "integrate", [](ModelState& s) { conformal_stage::integrate(s.work.conformal); });
    auto& zeros = add_stage_node<ModelState>(g, "zeros", [](ModelState& s) { segment_stage::zeros(s.work); });
    auto& fans = add_stage_node<ModelState>(g, "fans", [](ModelState& s) { segment_stage::fans(s.work); });
    auto& trace = add_stage_node<ModelState>(g, "trace", [](ModelState& s) { segment_stage::trace(s.work); });
    auto& cut = add_stage_node<ModelState>(g, "cut", [](ModelState& s) { segment_stage::cut(s.work); });
    auto& write = add_stage_node<ModelState>(g, "write", [&](ModelState& s) { stages.write(s); });
    auto& collect = g.add<function_node<ModelItem, continue_msg>>(
        "collect", serial, [&runs, &on_done](const ModelItem& item) {
            ModelRun& run = runs[item.id] = finish(*item.state);
            if (on_done) on_done(run);
            return continue_msg{};
        });

    g.connect(source, in_flight);
    g.connect(in_flight, read);
    g.connect(read, validate);
    g.connect(validate, prepare);
    g.connect(prepare, homology);
    g.connect(homology, laplacian);
    g.connect(laplacian, factorise);
    g.connect(factorise, split_solves);
    g.connect_port<0>(split_solves, solve, "blocks");
    g.connect_port<1>(split_solves, hodge_star, "failed");
    g.connect_port<0>(solve, end_solves, "last block");
    g.connect(end_solves, hodge_star);
    g.connect(hodge_star, integrate);
    g.connect(integrate, zeros);
    g.connect(zeros, fans);
    g.connect(fans, trace);
    g.connect(trace, cut);
    g.connect(cut, write);
    g.connect(write, collect);
    g.connect_decrement(collect, in_flight);
    source.activate();
}

}  // namespace

SegmentationGraph::SegmentationGraph(SegmentationGraphOptions options, engine::FactorizationCache* cache)
    : options_(std::move(options)), cache_(cache) {}

std::vector<ModelRun> SegmentationGraph::run(const std::vector<engine::ModelTask>& tasks,
                                             const ModelCallback& on_done) const {
    for (std::size_t i = 0; i < tasks.size(); ++i)
        HOLOFLOW_REQUIRE(tasks[i].id == i, "task ids must be their positions");
    std::vector<ModelRun> runs(tasks.size());
    const Stages stages{options_, cache_};
    engine::Graph g;
    build(g, stages, options_, tasks, runs, on_done);
    g.wait_for_all();
    return runs;
}

std::vector<ModelRun> SegmentationGraph::run_serial(const std::vector<engine::ModelTask>& tasks,
                                                    const ModelCallback& on_done) const {
    using engine::run_stage;
    const Stages stages{options_, cache_};
    std::vector<ModelRun> runs;
    for (const engine::ModelTask& task : tasks) {
        const std::shared_ptr<ModelState> state = new_state(task);
        ModelState& s = *state;
        run_stage(s, "read", [&](ModelState& m) { stages.read(m); });
        run_stage(s, "validate", [&](ModelState& m) { stages.validate(m); });
        run_stage(s, "prepare", [&](ModelState& m) { stages.prepare(m); });
        run_stage(s, "homology", [](ModelState& m) { conformal_stage::homology(m.work.conformal); });
        run_stage(s, "laplacian", [](ModelState& m) { conformal_stage::laplacian(m.work.conformal); });
        run_stage(s, "factorise", [&](ModelState& m) { stages.factorise(m); });
        run_stage(s, "solves", [&](ModelState& m) {
            const int blocks = stages.begin_solves(m);
            for (int b = 0; b < blocks; ++b) stages.solve(m, b);
        });
        run_stage(s, "end_solves", [&](ModelState& m) { stages.end_solves(m); });
        run_stage(s, "hodge_star", [](ModelState& m) { conformal_stage::hodge_star(m.work.conformal); });
        run_stage(s, "integrate", [](ModelState& m) { conformal_stage::integrate(m.work.conformal); });
        run_stage(s, "zeros", [](ModelState& m) { segment_stage::zeros(m.work); });
        run_stage(s, "fans", [](ModelState& m) { segment_stage::fans(m.work); });
        run_stage(s, "trace", [](ModelState& m) { segment_stage::trace(m.work); });
        run_stage(s, "cut", [](ModelState& m) { segment_stage::cut(m.work); });
        run_stage(s, "write", [&](ModelState& m) { stages.write(m); });
        runs.push_back(finish(s));
        if (on_done) on_done(runs.back());
    }
    return runs;
}

void SegmentationGraph::to_dot(std::ostream& out) const {
    const std::vector<engine::ModelTask> none;
    std::vector<ModelRun> runs;
    const Stages stages{options_, cache_};
    engine::Graph g;
    build(g, stages, options_, none, runs, {});
    g.wait_for_all();
    g.to_dot(out, "holoflow segmentation");
}

}  // namespace holoflow::graphs
