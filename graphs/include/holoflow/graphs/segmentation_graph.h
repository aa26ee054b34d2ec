#pragma once

#include <chrono>
#include <cstddef>
#include <functional>
#include <memory>
#include <ostream>
#include <vector>

#include <nlohmann/json.hpp>

#include "holoflow/engine/batch.h"
#include "holoflow/engine/factorization_cache.h"
#include "holoflow/engine/mesh_loader.h"
#include "holoflow/engine/segmentation_pipeline.h"

namespace holoflow::graphs {

struct SegmentationGraphOptions {
    engine::LoadOptions load;
    engine::SegmentOptions segment;
    //! Models between reading and collection at once: bounds memory (each holds its mesh,
    //! factor and forms) while keeping every core busy.
    std::size_t max_in_flight = 4;
    //! Per-model time limit, checked before every stage (a stage already running finishes);
    //! zero: none.
    std::chrono::milliseconds timeout{0};
    //! Keep every model's full SegmentationResult in its ModelRun (tests); otherwise a model's
    //! data is dropped as soon as its folder is written.
    bool keep_results = false;
};

//! What a run returns per model, in task order.
struct ModelRun {
    engine::ModelOutcome outcome;
    nlohmann::json report;  //!< segmentation.json of a successful model
    //! With keep_results: the model's segmentation, one result per component of its mesh.
    std::shared_ptr<const std::vector<engine::SegmentationResult>> components;
};

//! Called once per finished model; may amend its outcome (e.g. a failure to record it).
using ModelCallback = std::function<void(ModelRun&)>;

//! \brief The segmentation as a oneTBB flow graph, one node per stage:
//! read -> validate -> prepare (topology, components, tip slicing, double cover) -> laplacian ->
//! homology_and_factorise (cut graph and closed forms beside the factorisation) -> split_solves
//! -> solve (the 2g harmonic solves in blocks, concurrently) -> end_solves -> hodge_star ->
//! integrate -> zeros -> fans -> trace -> cut (and patches) -> write -> collect. A collection
//! streams through it: model ids wait in a queue and a limiter admits max_in_flight of them at
//! once, every message carries its model's id, and the collector stores results by id, so order
//! of arrival decides nothing. A failing model (bad file, solver failure, time limit) becomes a
//! failed ModelRun; the others go on. A mesh of several components is segmented per
//! component: each stage runs on every component in turn, the solve blocks of all of them run
//! concurrently, and the folder and report hold them together (engine::segmentation_report).
//! run_serial is the twin: the same stage functions in plain loops, same bits.
class SegmentationGraph {
  public:
    //! `cache` (optional, shared across runs and threads) reuses symbolic analyses.
    explicit SegmentationGraph(SegmentationGraphOptions options, engine::FactorizationCache* cache = nullptr);

    //! Runs the tasks through the flow graph; `on_done` is called once per model, one call at a
    //! time, in completion order. A task with an empty out_dir writes nothing.
    std::vector<ModelRun> run(const std::vector<engine::ModelTask>& tasks, const ModelCallback& on_done = {}) const;
    //! The serial twin: same stages, in task order, on the calling thread.
    std::vector<ModelRun> run_serial(const std::vector<engine::ModelTask>& tasks,
                                     const ModelCallback& on_done = {}) const;

    //! The graph's nodes and edges as Graphviz DOT.
    void to_dot(std::ostream& out) const;

  private:
    SegmentationGraphOptions options_;
    engine::FactorizationCache* cache_;
};

}  // namespace holoflow::graphs
