// The whole conformal stage (compute_conformal) against its sparse-solver core alone, on turbine
// (genus 11, CAD triangles) at Loop subdivision levels 0, 1, 2 (18k, 74k, 295k faces):
//   BM_engine_conformal/loop:L     compute_conformal, every stage
//   BM_kernel_bare_cholmod/loop:L  CholeskySymbolic::analyse + CholeskyFactor::factorize + one
//                                  solve with the 2g right-hand sides, on the same Laplacian the
//                                  pipeline factors (intrinsic Delaunay cotan weights, assembled
//                                  outside the timing loop)
//   BM_engine_conformal_genus/genus:G/alone:A
//                                  compute_conformal on shapes::genus_surface(G, 4), with the
//                                  harmonic basis (A = 0) or the chosen form alone
//                                  (ConformalOptions::chosen_form_only, A = 1): the basis grows
//                                  with 2g solves and dense #E x 2g forms, the form alone does not
// The console output ends with the ratio conformal / bare CHOLMOD per level.
#include <benchmark/benchmark.h>

#include <map>
#include <memory>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <oneapi/tbb/version.h>
#include <unistd.h>

#include "bench_support.h"
#include "holoflow/engine/conformal_pipeline.h"
#include "holoflow/kernels/cholesky.h"
#include "holoflow/kernels/shapes.h"
#include "holoflow/kernels/topology.h"

namespace {

using holoflow::Index;
using holoflow::MeshView;
namespace engine = holoflow::engine;
namespace kernels = holoflow::kernels;
using holoflow::bench::turbine_loop;

constexpr double kResidualTol = 1e-8;  // relative; a direct solve reaches ~1e-12 on these meshes
constexpr int kMaxLevel = 2;

void BM_engine_conformal(benchmark::State& state) {
    std::shared_ptr<const MeshView> mesh;
    int genus = 0;
    try {
        mesh = turbine_loop(static_cast<int>(state.range(0)));
        genus = kernels::compute_topology(*mesh).genus;
    } catch (const std::exception& e) {
        state.SkipWithError(e.what());
        return;
    }
    const engine::ConformalResult check = engine::compute_conformal(*mesh);  // warm-up
    if (check.basis.genus != genus || !check.tau.allFinite()) {
        state.SkipWithError("conformal stage lost the genus or produced non-finite values");
        return;
    }
    double solver_ms = 0;  // the pipeline's own analyse + factorise + solves stages
    for (auto _ : state) {
        const engine::ConformalResult r = engine::compute_conformal(*mesh);
        for (const auto& [stage, ms] : r.timings_ms)
            if (stage == "analyse" || stage == "factorise" || stage == "solves") solver_ms += ms;
        benchmark::DoNotOptimize(r.tau.data());
    }
    state.counters["faces"] = static_cast<double>(mesh->n_faces());
    state.counters["genus"] = genus;
    state.counters["solver_stages_ms"] = solver_ms / static_cast<double>(state.iterations());
    state.SetItemsProcessed(state.iterations() * mesh->n_faces());
}

void BM_kernel_bare_cholmod(benchmark::State& state) {
    holoflow::bench::PipelineLaplacian in;
    Index faces = 0;
    try {
        const auto mesh = turbine_loop(static_cast<int>(state.range(0)));
        faces = mesh->n_faces();
        in = holoflow::bench::pipeline_laplacian(mesh);
    } catch (const std::exception& e) {
        state.SkipWithError(e.what());
        return;
    }
    const kernels::LaplacianMatrix& L = in.work.laplacian;
    {  // warm-up and validation
        const auto factor = kernels::CholeskyFactor::factorize(kernels::CholeskySymbolic::analyse(L), L);
        const double residual = holoflow::bench::relative_residual(L, factor->solve(in.rhs), in.rhs);
        if (!(residual < kResidualTol)) {
            state.SkipWithError(("residual " + std::to_string(residual) + " too large").c_str());
            return;
        }
        state.counters["factor_nnz"] = static_cast<double>(factor->symbolic()->factor_nonzeros());
    }
    for (auto _ : state) {
        const auto symbolic = kernels::CholeskySymbolic::analyse(L);
        const auto factor = kernels::CholeskyFactor::factorize(symbolic, L);
        const Eigen::MatrixXd x = factor->solve(in.rhs);
        benchmark::DoNotOptimize(x.data());
    }
    state.counters["faces"] = static_cast<double>(faces);
    state.counters["rhs"] = static_cast<double>(in.rhs.cols());
    state.SetItemsProcessed(state.iterations() * faces);
}

void BM_engine_conformal_genus(benchmark::State& state) {
    const int genus = static_cast<int>(state.range(0));
    engine::ConformalOptions options;
    options.chosen_form_only = state.range(1) != 0;
    const MeshView mesh = holoflow::shapes::genus_surface(genus, 4);
    const engine::ConformalResult check = engine::compute_conformal(mesh, options);  // warm-up
    if (check.basis.genus != genus || !check.tau.allFinite()) {
        state.SkipWithError("conformal stage lost the genus or produced non-finite values");
        return;
    }
    for (auto _ : state) {
        const engine::ConformalResult r = engine::compute_conformal(mesh, options);
        benchmark::DoNotOptimize(r.tau.data());
    }
    state.counters["faces"] = static_cast<double>(mesh.n_faces());
    state.SetItemsProcessed(state.iterations() * mesh.n_faces());
}

// Level 2 takes seconds per iteration: a few iterations are plenty there.
BENCHMARK(BM_engine_conformal)
    ->ArgName("loop")
    ->DenseRange(0, 1)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_engine_conformal)
    ->ArgName("loop")
    ->Arg(2)
    ->Iterations(2)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_engine_conformal_genus)
    ->ArgNames({"genus", "alone"})
    ->ArgsProduct({{8, 32, 128}, {0, 1}})
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_kernel_bare_cholmod)
    ->ArgName("loop")
    ->DenseRange(0, 1)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_kernel_bare_cholmod)
    ->ArgName("loop")
    ->Arg(2)
    ->Iterations(3)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

// Console output plus, at the end, whole stage / bare solver per level from this very run, in
// wall and in main-thread CPU time (the latter is steadier on a shared machine). With
// --benchmark_repetitions the medians are used.
class RatioReporter : public benchmark::ConsoleReporter {
  public:
    RatioReporter() : ConsoleReporter(::isatty(STDOUT_FILENO) ? OO_ColorTabular : OO_Tabular) {}

    void ReportRuns(const std::vector<Run>& runs) override {
        for (const Run& run : runs) {
            const bool median = run.run_type == Run::RT_Aggregate && run.aggregate_name == "median";
            if (run.error_occurred || !(median || run.run_type == Run::RT_Iteration)) continue;
            // "BM_x/loop:L/iterations:N/real_time[_median]" -> ("BM_x", L)
            const std::string name = run.benchmark_name();
            const std::size_t at = name.find("/loop:");
            if (at == std::string::npos) continue;
            const Key key{name.substr(0, at), std::stoi(name.substr(at + 6))};
            if (median || !from_median_.contains(key))
                times_[key] = {run.GetAdjustedRealTime(), run.GetAdjustedCPUTime()};
            if (median) from_median_.insert(key);
        }
        ConsoleReporter::ReportRuns(runs);
    }

    void Finalize() override {
        ConsoleReporter::Finalize();
        std::ostream& out = GetOutputStream();
        for (int level = 0; level <= kMaxLevel; ++level) {
            const auto whole = times_.find({"BM_engine_conformal", level});
            const auto bare = times_.find({"BM_kernel_bare_cholmod", level});
            if (whole == times_.end() || bare == times_.end()) continue;
            const auto [whole_real, whole_cpu] = whole->second;
            const auto [bare_real, bare_cpu] = bare->second;
            out << "ratio conformal / bare CHOLMOD at loop:" << level << ": "
                << whole_real / bare_real << " wall (" << whole_real << " / " << bare_real
                << " ms), " << whole_cpu / bare_cpu << " cpu (" << whole_cpu << " / "
                << bare_cpu << " ms)\n";
        }
    }

  private:
    using Key = std::pair<std::string, int>;
    std::map<Key, std::pair<double, double>> times_;  // real, cpu
    std::set<Key> from_median_;
};

}  // namespace

int main(int argc, char** argv) {
    benchmark::Initialize(&argc, argv);
    if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
    benchmark::AddCustomContext("mesh", "libcgal-demo turbine.off, Loop-subdivided");
    benchmark::AddCustomContext("tbb", TBB_VERSION_STRING);
    RatioReporter reporter;
    benchmark::RunSpecifiedBenchmarks(&reporter);
    benchmark::Shutdown();
    return 0;
}
