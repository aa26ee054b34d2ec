#include "holoflow/graphs/segmentation_graph.h"

#include <algorithm>
#include <atomic>
#include <exception>
#include <span>
#include <tuple>

#include "holoflow/engine/flow_graph.h"
#include "holoflow/engine/output.h"
#include "holoflow/kernels/topology.h"

namespace holoflow::graphs {
namespace {

using engine::Item;
using engine::StageClock;
namespace conformal_stage = engine::conformal_stage;
namespace segment_stage = engine::segment_stage;
using Clock = std::chrono::steady_clock;

//! One model on its way through the stages. Its outcome (`run.outcome`) fills in as it goes,
//! stage times included: `load` (read + validate), the pipeline's own stages, `write`.
struct ModelState {
    Clock::time_point deadline = Clock::time_point::max();
    engine::Status status;
    engine::PolygonSoup soup;
    engine::LoadedMesh loaded;
    std::vector<engine::SegmentationWork> parts;  // one per component of the mesh
    std::vector<int> first_block;                 // per part, its first solve block; then the total
    std::atomic<int> blocks_left{0};
    std::vector<std::exception_ptr> block_errors;  // one slot per solve block
    ModelRun run;

    const engine::ModelTask& task() const { return run.outcome.task; }
    //! Drops the heavy data of a failed (or written) model; the outcome fields stay.
    void release() {
        soup = {};
        loaded = {};
        parts = {};
    }
};

// Runs `stage` for component p of n; with several components an error names its component
// (same error type, so the same kind and exit status).
template <class Stage>
void in_component(std::size_t p, std::size_t n, const Stage& stage) {
    if (n == 1) return stage();
    const auto named = [&](const std::exception& e) {
        return "component " + std::to_string(p) + " of " + std::to_string(n) + ": " + e.what();
    };
    try {
        stage();
    } catch (const InvalidInput& e) {
        throw InvalidInput(named(e));
    } catch (const SolverFailure& e) {
        throw SolverFailure(named(e));
    } catch (const engine::ResourceLimit& e) {
        throw engine::ResourceLimit(named(e));
    }
}

// Runs `stage` on every part, errors named as in_component does.
template <class Stage>
void for_each_part(std::vector<engine::SegmentationWork>& parts, const Stage& stage) {
    for (std::size_t p = 0; p < parts.size(); ++p) in_component(p, parts.size(), [&] { stage(parts[p]); });
}

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
        StageClock clock(s.run.outcome.timings_ms);
        s.soup = engine::read_polygon_soup(s.task().path, options.load.max_file_bytes);
        clock.lap("load");
    }
    void validate(ModelState& s) const {
        const auto start = Clock::now();
        s.loaded = engine::mesh_from_soup(s.soup, options.load);
        s.soup = {};
        s.run.outcome.vertices = static_cast<std::size_t>(s.loaded.mesh->n_vertices());
        s.run.outcome.faces = static_cast<std::size_t>(s.loaded.mesh->n_faces());
        s.run.outcome.timings_ms.back().second +=
            std::chrono::duration<double, std::milli>(Clock::now() - start).count();  // into `load`
    }
    void prepare(ModelState& s) const {
        const MeshView& mesh = *s.loaded.mesh;
        const kernels::Topology topology = kernels::compute_topology(mesh);
        std::vector<std::shared_ptr<const MeshView>> meshes{s.loaded.mesh};
        std::vector<std::vector<Index>> component_vertex;  // per component but a lone one: its vertices' ids in mesh
        if (topology.components > 1) {
            HOLOFLOW_REQUIRE(options.segment.tips.empty(), "tips are vertex ids of a connected mesh; this one has " +
                                                               std::to_string(topology.components) + " components");
            meshes.clear();
            for (kernels::ComponentMesh& component : kernels::component_meshes(mesh, topology)) {
                meshes.push_back(std::make_shared<const MeshView>(std::move(component.mesh)));
                component_vertex.push_back(std::move(component.source_vertex));
            }
        }
        engine::SegmentOptions segment_options = options.segment;
        segment_options.tips = engine::tip_vertices(s.loaded, options.segment.tips);
        s.run.outcome.genus = 0;
        for (std::size_t p = 0; p < meshes.size(); ++p)
            in_component(p, meshes.size(), [&] {
                s.parts.push_back(segment_stage::prepare(meshes[p], segment_options));
                for (Index& tip : s.parts.back().result.tips)  // reported as the file's ids
                    if (tip >= 0) tip = s.loaded.file_vertex[component_vertex.empty() ? tip : component_vertex[p][tip]];
                s.run.outcome.genus += s.parts.back().result.input_genus;
            });
    }
    void laplacian(ModelState& s) const {
        for_each_part(s.parts, [&](engine::SegmentationWork& part) { conformal_stage::laplacian(part.conformal); });
    }
    void homology_and_factorise(ModelState& s) const {
        for_each_part(s.parts, [&](engine::SegmentationWork& part) { conformal_stage::homology_and_factorise(part.conformal, cache); });
    }
    //! Hands each part's closed forms to its harmonic forms; returns the number of blocks (of all parts).
    int begin_solves(ModelState& s) const {
        s.first_block.assign(1, 0);
        for_each_part(s.parts, [&](engine::SegmentationWork& part) {
            s.first_block.push_back(s.first_block.back() + conformal_stage::begin_solves(part.conformal));
        });
        const int blocks = s.first_block.back();
        s.block_errors.assign(blocks, nullptr);
        s.blocks_left.store(blocks);
        return blocks;
    }
    //! Solves one block into its columns; never throws (the error waits in its slot).
    void solve(ModelState& s, int block) const {
        try {
            const std::size_t p =
                std::upper_bound(s.first_block.begin(), s.first_block.end(), block) - s.first_block.begin() - 1;
            const int local = block - s.first_block[p];
            engine::ConformalWork& c = s.parts[p].conformal;
            conformal_stage::solve_block(c, local);
        } catch (...) {
            s.block_errors[block] = std::current_exception();
        }
    }
    //! After the last block: the first failed block (by index) fails the model.
    void end_solves(ModelState& s) const {
        for (const std::exception_ptr& e : s.block_errors)
            if (e) std::rethrow_exception(e);
        s.block_errors.clear();
        for_each_part(s.parts, [&](engine::SegmentationWork& part) { conformal_stage::end_solves(part.conformal); });
        // The parts' blocks ran together, so each part's own `solves` (its begin to its end)
        // spans the others' too: the phase's wall time is shared out by block count instead.
        if (s.parts.size() > 1) {
            const double span = std::chrono::duration<double, std::milli>(
                                    Clock::now() - s.parts.front().conformal.solves_started).count();
            for (std::size_t p = 0; p < s.parts.size(); ++p) {
                engine::StageTimes& times = s.parts[p].conformal.result.timings_ms;
                const auto solves = std::find_if(times.rbegin(), times.rend(), [](const auto& t) { return t.first == "solves"; });
                if (solves != times.rend())
                    solves->second = span * (s.first_block[p + 1] - s.first_block[p]) / s.first_block.back();
            }
        }
    }
    void hodge_star(ModelState& s) const {
        for_each_part(s.parts, [&](engine::SegmentationWork& part) { conformal_stage::hodge_star(part.conformal); });
    }
    void integrate(ModelState& s) const {
        for_each_part(s.parts, [&](engine::SegmentationWork& part) { conformal_stage::integrate(part.conformal); });
    }
    void zeros(ModelState& s) const {
        for_each_part(s.parts, [&](engine::SegmentationWork& part) { segment_stage::zeros(part); });
    }
    void fans(ModelState& s) const {
        for_each_part(s.parts, [&](engine::SegmentationWork& part) { segment_stage::fans(part); });
    }
    void trace(ModelState& s) const {
        for_each_part(s.parts, [&](engine::SegmentationWork& part) { segment_stage::trace(part); });
    }
    void cut(ModelState& s) const {
        for_each_part(s.parts, [&](engine::SegmentationWork& part) { segment_stage::cut(part); });
    }
    void tips_where_collapsed(ModelState& s) const {
        for_each_part(s.parts, [&](engine::SegmentationWork& part) { segment_stage::tips_where_collapsed(part); });
    }
    void write(ModelState& s) const {
        const auto start = Clock::now();
        std::vector<engine::SegmentationResult> results;
        for (engine::SegmentationWork& part : s.parts) results.push_back(std::move(part.result));
        s.parts.clear();
        engine::ModelOutcome& o = s.run.outcome;
        s.run.report = engine::segmentation_report(results);
        o.working_genus = s.run.report["working_genus"];
        o.zeros = s.run.report["zero_count"];
        o.patches = s.run.report["patch_count"];
        o.collapsed_area = s.run.report["collapsed_area"];
        const engine::StageTimes times = engine::summed_times(results);
        o.timings_ms.insert(o.timings_ms.end(), times.begin(), times.end());
        s.run.report["file"] = s.task().path;
        if (!s.task().out_dir.empty()) engine::write_segmentation_folder(s.task().out_dir, results, s.run.report);
        if (options.keep_results)
            s.run.components = std::make_shared<const std::vector<engine::SegmentationResult>>(std::move(results));
        s.release();
        o.timings_ms.emplace_back("write", std::chrono::duration<double, std::milli>(Clock::now() - start).count());
    }
};

struct NamedStage {
    const char* name;
    void (Stages::*run)(ModelState&) const;
};

// The stages before the solve blocks and after them, in order: the graph chains one node per
// entry and the serial twin loops over the same tables.
constexpr NamedStage kBeforeSolves[] = {
    {"read", &Stages::read},           {"validate", &Stages::validate},
    {"prepare", &Stages::prepare},     {"laplacian", &Stages::laplacian},
    {"homology_and_factorise", &Stages::homology_and_factorise},
};
constexpr NamedStage kAfterSolves[] = {
    {"end_solves", &Stages::end_solves}, {"hodge_star", &Stages::hodge_star}, {"integrate", &Stages::integrate},
    {"zeros", &Stages::zeros},           {"fans", &Stages::fans},             {"trace", &Stages::trace},
    {"cut", &Stages::cut},               {"tips_where_collapsed", &Stages::tips_where_collapsed},
    {"write", &Stages::write},
};
constexpr const char* kSolvesStage = "solves";  // begin_solves and the blocks

std::shared_ptr<ModelState> new_state(const engine::ModelTask& task) {
    auto s = std::make_shared<ModelState>();
    s->run.outcome.task = task;
    return s;
}

// The run as the collector hands it out.
ModelRun finish(ModelState& s) {
    s.release();
    s.run.outcome.status = s.status;
    if (!s.status.ok()) s.run.report = nullptr;
    return std::move(s.run);
}

// Builds the whole graph into `g`; `runs` receives each model's result at its id. Returns the
// queue the model ids go into.
tbb::flow::queue_node<std::uint64_t>& build(engine::Graph& g, const Stages& stages,
                                            const std::vector<engine::ModelTask>& tasks,
                                            std::vector<ModelRun>& runs, const ModelCallback& on_done) {
    using namespace tbb::flow;
    using StageNode = function_node<ModelItem, ModelItem>;
    using SplitNode = multifunction_node<ModelItem, std::tuple<SolveBlock, ModelItem>>;
    using SolveNode = multifunction_node<SolveBlock, std::tuple<ModelItem>>;

    // One node per table entry, each connected to the previous one.
    const auto add_chain = [&](std::span<const NamedStage> table) {
        std::vector<StageNode*> chain;
        for (const NamedStage& stage : table) {
            chain.push_back(&engine::add_stage_node<ModelState>(
                g, stage.name, [&stages, run = stage.run](ModelState& s) { (stages.*run)(s); }));
            if (chain.size() > 1) g.connect(*chain[chain.size() - 2], *chain.back());
        }
        return chain;
    };

    // Ids wait in the queue; the limiter pulls the next one whenever a model is collected.
    auto& models = g.add<queue_node<std::uint64_t>>("models");
    auto& in_flight = g.add<limiter_node<std::uint64_t>>("in_flight", std::max<std::size_t>(1, stages.options.max_in_flight));
    auto& admit = g.add<function_node<std::uint64_t, ModelItem>>(
        "admit", unlimited, [&tasks](std::uint64_t id) { return ModelItem{id, new_state(tasks[id])}; });
    const std::vector<StageNode*> before = add_chain(kBeforeSolves);
    auto& split_solves = g.add<SplitNode>(
        "split_solves", unlimited, [&](const ModelItem& item, SplitNode::output_ports_type& ports) {
            int blocks = 0;
            engine::run_stage(*item.state, kSolvesStage, [&](ModelState& s) { blocks = stages.begin_solves(s); });
            if (blocks == 0) std::get<1>(ports).try_put(item);  // failed, or the form alone: straight on
            for (int b = 0; b < blocks; ++b) std::get<0>(ports).try_put(SolveBlock{item, b});
        });
    auto& solve = g.add<SolveNode>("solve", unlimited, [&](const SolveBlock& block, SolveNode::output_ports_type& ports) {
        ModelState& s = *block.model.state;
        stages.solve(s, block.block);
        // The last block to finish passes the model on (acq_rel: it sees every block's slot).
        if (s.blocks_left.fetch_sub(1, std::memory_order_acq_rel) == 1) std::get<0>(ports).try_put(block.model);
    });
    const std::vector<StageNode*> after = add_chain(kAfterSolves);
    auto& collect = g.add<function_node<ModelItem, continue_msg>>(
        "collect", serial, [&runs, &on_done](const ModelItem& item) {
            ModelRun& run = runs[item.id] = finish(*item.state);
            if (on_done) on_done(run);
            return continue_msg{};
        });

    g.connect(models, in_flight);
    g.connect(in_flight, admit);
    g.connect(admit, *before.front());
    g.connect(*before.back(), split_solves);
    g.connect_port<0>(split_solves, solve, "blocks");
    g.connect_port<1>(split_solves, *after.front(), "failed");
    g.connect_port<0>(solve, *after.front(), "last block");
    g.connect(*after.back(), collect);
    g.connect_decrement(collect, in_flight);
    return models;
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
    auto& models = build(g, stages, tasks, runs, on_done);
    for (const engine::ModelTask& task : tasks) models.try_put(task.id);
    g.wait_for_all();
    return runs;
}

std::vector<ModelRun> SegmentationGraph::run_serial(const std::vector<engine::ModelTask>& tasks,
                                                    const ModelCallback& on_done) const {
    const Stages stages{options_, cache_};
    const auto run_table = [&](ModelState& s, std::span<const NamedStage> table) {
        for (const NamedStage& stage : table)
            engine::run_stage(s, stage.name, [&](ModelState& m) { (stages.*stage.run)(m); });
    };
    std::vector<ModelRun> runs;
    for (const engine::ModelTask& task : tasks) {
        const std::shared_ptr<ModelState> state = new_state(task);
        ModelState& s = *state;
        run_table(s, kBeforeSolves);
        engine::run_stage(s, kSolvesStage, [&](ModelState& m) {
            const int blocks = stages.begin_solves(m);
            for (int b = 0; b < blocks; ++b) stages.solve(m, b);
        });
        run_table(s, kAfterSolves);
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
    build(g, stages, none, runs, {});
    g.to_dot(out, "holoflow segmentation");
}

}  // namespace holoflow::graphs
