// libFuzzer target: a small OFF mesh -> load -> topology -> compute_conformal when the mesh has a
// holomorphic 1-form (closed genus >= 1, or open and not a disk). Only the documented exceptions
// (MeshError, InvalidInput, SolverFailure) are caught; a success must carry finite results.

#include <cstddef>
#include <cstdint>

#include "fuzz_common.h"
#include "holoflow/engine/conformal_pipeline.h"
#include "holoflow/kernels/errors.h"

namespace {

// Small meshes only, so that one execution stays in the millisecond range.
constexpr std::size_t kMaxBytes = 1 << 15;
constexpr std::size_t kMaxPolygons = 400;
constexpr holoflow::Index kMaxFaces = 600;

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace holoflow;
    if (size > kMaxBytes) return 0;
    engine::PolygonSoup soup;
    try {
        soup = engine::parse_polygon_soup(reinterpret_cast<const char*>(data), size,
                                          engine::MeshFormat::Off);
    } catch (const engine::MeshError&) {
        return 0;
    }
    if (soup.n_polygons() > kMaxPolygons) return 0;
    engine::LoadedMesh loaded;
    if (!fuzz::load(soup, engine::ComponentPolicy::All, loaded)) return 0;
    const MeshView& mesh = *loaded.mesh;
    if (mesh.n_faces() > kMaxFaces) return 0;
    const kernels::Topology t = kernels::compute_topology(mesh);
    fuzz::check_topology(mesh, t);

    const bool closed = t.boundary_loops == 0;
    const bool disk = t.components == 1 && t.genus == 0 && t.boundary_loops == 1;
    if ((closed && t.genus < 1) || disk) return 0;

    engine::ConformalOptions options;
    // The last byte picks the Laplacian, so that both variants are explored.
    if (data[size - 1] & 1) options.laplacian = engine::LaplacianKind::Extrinsic;
    try {
        const engine::ConformalResult r = engine::compute_conformal(mesh, options);
        HOLOFLOW_FUZZ_CHECK(r.surface && r.harmonic.allFinite() && r.tau.allFinite());
        HOLOFLOW_FUZZ_CHECK(r.basis.period_matrix.allFinite());
        HOLOFLOW_FUZZ_CHECK(static_cast<Index>(r.map.corner_wedge.size()) ==
                            r.surface->n_halfedges());
        HOLOFLOW_FUZZ_CHECK(r.harmonic.rows() == r.surface->n_edges());
        (void)engine::conformal_report(r).dump();
    } catch (const InvalidInput&) {  // also MeshError
    } catch (const SolverFailure&) {
    }
    return 0;
}
