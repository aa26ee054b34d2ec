#pragma once

#include <cstddef>
#include <ostream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "holoflow/engine/batch.h"
#include "holoflow/engine/factorization_cache.h"
#include "holoflow/graphs/segmentation_graph.h"

namespace holoflow::graphs {

struct CollectionOptions {
    //! Per-model options; segment.conformal.max_solver_bytes is the whole memory limit (0: none).
    SegmentationGraphOptions graph;
    //! What a finished model's results depend on, kept in its result.json: a model an earlier run
    //! finished with equal settings is reused, not recomputed (unless `force`).
    nlohmann::json settings;
    unsigned threads = 1;  //!< oneTBB worker threads while the collection runs
    bool force = false;
    bool serial = false;   //!< the serial twin instead of the flow graph
};

struct CollectionRun {
    std::vector<engine::ModelOutcome> outcomes;  //!< in task order
    std::size_t reused = 0;                      //!< finished by an earlier run
    std::vector<std::string> recomputed_alone;   //!< over their memory share: computed again alone
};

//! \brief Segments a collection into its tasks' folders (each model's result.json written last),
//! reusing models an earlier run finished. The models computed at once (the threads, at most
//! graph.max_in_flight and the models left) split the memory limit. A model refused under its
//! share, or whose refinement try is, stops there; after the others it is computed again alone
//! with the whole limit (a line on `log` names those), so every model gets what it would get
//! alone and results never depend on `threads`. `progress` counts every model once.
CollectionRun run_collection(const std::vector<engine::ModelTask>& tasks, const CollectionOptions& options,
                             engine::BatchProgress& progress, std::ostream& log,
                             engine::FactorizationCache* cache = nullptr);

}  // namespace holoflow::graphs
