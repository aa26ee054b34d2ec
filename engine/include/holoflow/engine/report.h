#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "holoflow/engine/mesh_loader.h"
#include "holoflow/kernels/topology.h"

namespace holoflow::engine {

//! The `holoflow info` object: keys `vertices`, `edges`, `faces`, `components`, `boundary_loops`,
//! `euler_characteristic`, `genus`, `orientable`, `repairs` (counts) are relied on by scripts.
nlohmann::json info_report(const std::string& path, const LoadedMesh& loaded,
                           const kernels::Topology& topology);

//! Human-readable lines of the same report.
std::string format_info_text(const nlohmann::json& report);

}  // namespace holoflow::engine
