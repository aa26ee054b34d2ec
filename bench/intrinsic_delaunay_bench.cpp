// Intrinsic Delaunay flipping on a CAD mesh with thousands of obtuse triangles (turbine, genus 11)
// and on its midpoint subdivision (same triangle shapes, four times as many), carrying the 2g
// closed forms of its homology basis as the solver pipeline does.
#include <benchmark/benchmark.h>

#include <filesystem>
#include <string>

#include "holoflow/engine/mesh_loader.h"
#include "holoflow/kernels/homology.h"
#include "holoflow/kernels/intrinsic_delaunay.h"
#include "holoflow/kernels/subdivision.h"

namespace {

using holoflow::MeshView;
namespace kernels = holoflow::kernels;

static void BM_kernel_intrinsic_delaunay(benchmark::State& state) {
    const std::string path = std::string(HOLOFLOW_CORPUS_DIR) + "/turbine.off";
    if (!std::filesystem::exists(path)) {
        state.SkipWithError(("corpus mesh missing: " + path).c_str());
        return;
    }
    const auto loaded = holoflow::engine::load_mesh(path).mesh;
    const MeshView mesh = state.range(0) == 0 ? *loaded : kernels::subdivide_midpoint(*loaded);
    const Eigen::MatrixXd forms = kernels::compute_homology_basis(mesh).closed_forms;

    // Warm-up and validation outside the timed loop.
    const kernels::IntrinsicTriangulation check = kernels::intrinsic_delaunay(mesh, forms);
    if (check.non_delaunay_edges != 0 || check.hit_flip_limit) {
        state.SkipWithError("flipping did not reach a Delaunay triangulation");
        return;
    }
    for (auto _ : state) benchmark::DoNotOptimize(kernels::intrinsic_delaunay(mesh, forms));
    state.counters["flips"] = static_cast<double>(check.flips);
    state.counters["faces"] = static_cast<double>(mesh.n_faces());
    state.counters["forms"] = static_cast<double>(forms.cols());
    state.SetItemsProcessed(state.iterations() * mesh.n_faces());
}
BENCHMARK(BM_kernel_intrinsic_delaunay)
    ->ArgName("subdivided")
    ->DenseRange(0, 1)
    ->Unit(benchmark::kMillisecond);

}  // namespace

int main(int argc, char** argv) {
    benchmark::Initialize(&argc, argv);
    if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
    benchmark::AddCustomContext("mesh", "libcgal-demo turbine.off");
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    return 0;
}
