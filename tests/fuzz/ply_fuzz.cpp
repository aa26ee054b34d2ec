// libFuzzer target: PLY bytes -> parse_polygon_soup -> mesh_from_soup -> compute_topology.
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    return holoflow::fuzz::read_load_topology(data, size, holoflow::engine::MeshFormat::Ply);
}
