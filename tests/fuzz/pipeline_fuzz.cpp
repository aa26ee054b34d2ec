// libFuzzer target: a small OFF mesh -> load -> topology -> the whole segmentation (conformal
// stage, zeros, fans, tracing, cutting, patches, reports) when the mesh has a holomorphic 1-form
// after tip slicing or doubling (any connected mesh but a sphere or disk too small to slice
// still tries). Only the documented exceptions (MeshError, InvalidInput, SolverFailure) are caught;
// a success must carry finite results and the exact zero count.

#include <cmath>
#include <cstddef>
#include <cstdint>

#include "fuzz_common.h"
#include "holoflow/engine/conformal_pipeline.h"
#include "holoflow/engine/segmentation_pipeline.h"
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

    engine::SegmentOptions options;
    // The last byte picks the Laplacian and the mode, so that every variant is explored.
    if (data[size - 1] & 1) options.conformal.laplacian = engine::LaplacianKind::Extrinsic;
    if (data[size - 1] & 2) options.mode = engine::SegmentMode::Vertical;
    try {
        const engine::SegmentationResult r = engine::segment(mesh, options);
        const engine::ConformalResult& c = r.conformal;
        HOLOFLOW_FUZZ_CHECK(c.surface && c.tau.allFinite() && c.basis.period_matrix.allFinite());
        HOLOFLOW_FUZZ_CHECK(static_cast<Index>(c.map.conformal_factor.size()) == c.surface->n_vertices());
        for (const auto& uv : c.map.wedge_uv) HOLOFLOW_FUZZ_CHECK(std::isfinite(uv.real()) && std::isfinite(uv.imag()));
        // sum (w_v - 1) + flips = 2g - 2 and sum m_v = 2g - 2 hold by construction on the closed
        // working surface.
        const int genus = c.basis.genus;
        if (genus >= 2) HOLOFLOW_FUZZ_CHECK(r.zeros.total_index == 2 * genus - 2);
        HOLOFLOW_FUZZ_CHECK(static_cast<Index>(r.patches.face_patch.size()) == r.cut.mesh.n_faces());
        for (const auto& uv : r.patches.corner_uv) HOLOFLOW_FUZZ_CHECK(std::isfinite(uv.real()) && std::isfinite(uv.imag()));
        (void)engine::segmentation_report(r).dump();
        (void)engine::complex_report(r).dump();
    } catch (const InvalidInput&) {  // also MeshError
    } catch (const SolverFailure&) {
    }
    return 0;
}
