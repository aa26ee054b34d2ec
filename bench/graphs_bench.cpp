// The segmentation flow graph against its serial twin over the libcgal-demo corpus, batch
// throughput with 1 and 2 threads, and the factorization cache on a pose collection.
//
// The console output ends with the ratios the targets are stated in, each from this one run:
//   throughput 2 threads / 1 thread (target >= 1.7 on 2 cores),
//   engine overhead: graph at 1 thread / serial twin (target < 1.05),
//   pose collection: cached analysis + refactorization / fresh analyse + factorise (target <= 0.5).
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>
#include <oneapi/tbb/global_control.h>
#include <oneapi/tbb/version.h>
#include <unistd.h>

#include "bench_support.h"
#include "holoflow/engine/batch.h"
#include "holoflow/engine/factorization_cache.h"
#include "holoflow/graphs/segmentation_graph.h"
#include "holoflow/kernels/cholesky.h"

namespace {

using holoflow::Index;
using holoflow::MeshView;
namespace engine = holoflow::engine;
namespace graphs = holoflow::graphs;
namespace kernels = holoflow::kernels;

constexpr int kPoses = 20;

// Every mesh file of the corpus, as a batch would see the folder; no output folders (the
// benchmark times computation, and the writers are timed by the CLI table).
std::vector<engine::ModelTask> corpus_tasks() {
    static const std::vector<engine::ModelTask> tasks = [] {
        const std::string dir = HOLOFLOW_CORPUS_DIR;
        if (!std::filesystem::is_directory(dir)) return std::vector<engine::ModelTask>{};
        return engine::make_tasks(engine::expand_inputs({dir}), {});
    }();
    return tasks;
}

void report_models(benchmark::State& state, const std::vector<graphs::ModelRun>& runs) {
    std::size_t ok = 0, faces = 0;
    for (const auto& run : runs) {
        ok += run.outcome.status.ok();
        faces += run.outcome.faces;
    }
    state.counters["models"] = static_cast<double>(runs.size());
    state.counters["ok"] = static_cast<double>(ok);
    state.counters["models_per_s"] =
        benchmark::Counter(static_cast<double>(runs.size()), benchmark::Counter::kIsIterationInvariantRate);
    state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(faces));
}

void BM_graph_corpus_serial(benchmark::State& state) {
    const auto tasks = corpus_tasks();
    if (tasks.empty()) return state.SkipWithError("corpus missing: " HOLOFLOW_CORPUS_DIR);
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    const graphs::SegmentationGraph graph(graphs::SegmentationGraphOptions{});
    std::vector<graphs::ModelRun> runs;
    for (auto _ : state) runs = graph.run_serial(tasks);
    report_models(state, runs);
}

void BM_graph_corpus(benchmark::State& state) {
    const auto tasks = corpus_tasks();
    if (tasks.empty()) return state.SkipWithError("corpus missing: " HOLOFLOW_CORPUS_DIR);
    const int threads = static_cast<int>(state.range(0));
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    graphs::SegmentationGraphOptions options;
    options.max_in_flight = 2 * threads;
    const graphs::SegmentationGraph graph(options);
    std::vector<graphs::ModelRun> runs;
    for (auto _ : state) runs = graph.run(tasks);
    report_models(state, runs);
}

// The Laplacians of kPoses smooth deformations of turbine after one Loop step (73.8k faces):
// same triangles, moved vertices. Made once.
struct Poses {
    std::vector<kernels::LaplacianMatrix> laplacian;
    std::size_t distinct_patterns = 0;
};

const Poses& poses(bool intrinsic) {
    static std::map<bool, Poses> made;
    if (auto it = made.find(intrinsic); it != made.end()) return it->second;
    Poses p;
    if (std::filesystem::exists(std::string(HOLOFLOW_CORPUS_DIR) + "/turbine.off")) {
        const std::shared_ptr<const MeshView> base = holoflow::bench::turbine_loop(1);
        const Eigen::Vector3d lo = base->V.colwise().minCoeff(), hi = base->V.colwise().maxCoeff();
        const double size = (hi - lo).norm();
        std::vector<std::uint64_t> hashes;
        for (int k = 0; k < kPoses; ++k) {
            auto mesh = std::make_shared<MeshView>(*base);
            const double t = 0.03 * size * k / kPoses;  // up to 3% of the size: a bend
            for (Index v = 0; v < mesh->n_vertices(); ++v) {
                const double z = (mesh->V(v, 2) - lo(2)) / size;
                mesh->V(v, 0) += t * std::sin(3 * z);
                mesh->V(v, 1) += t * std::cos(2 * z) - t;
            }
            kernels::LaplacianMatrix L =
                holoflow::bench::pipeline_laplacian(mesh, intrinsic ? engine::LaplacianKind::IntrinsicDelaunay
                                                                    : engine::LaplacianKind::Extrinsic)
                    .work.laplacian;
            hashes.push_back(engine::pattern_hash(L));
            p.laplacian.push_back(std::move(L));
        }
        std::sort(hashes.begin(), hashes.end());
        p.distinct_patterns = static_cast<std::size_t>(std::unique(hashes.begin(), hashes.end()) - hashes.begin());
    }
    return made.emplace(intrinsic, std::move(p)).first->second;
}

void BM_engine_pose_fresh(benchmark::State& state) {
    const Poses& p = poses(state.range(0) == 1);
    if (p.laplacian.empty()) return state.SkipWithError("corpus mesh turbine.off missing");
    for (auto _ : state)
        for (const auto& L : p.laplacian)
            benchmark::DoNotOptimize(kernels::CholeskyFactor::factorize(kernels::CholeskySymbolic::analyse(L), L));
    state.counters["poses"] = static_cast<double>(p.laplacian.size());
    state.counters["patterns"] = static_cast<double>(p.distinct_patterns);
}

void BM_engine_pose_cached(benchmark::State& state) {
    const Poses& p = poses(state.range(0) == 1);
    if (p.laplacian.empty()) return state.SkipWithError("corpus mesh turbine.off missing");
    engine::FactorizationCache::Stats stats;
    for (auto _ : state) {
        engine::FactorizationCache cache;  // cold for every iteration: the first pose analyses
        for (const auto& L : p.laplacian)
            benchmark::DoNotOptimize(kernels::CholeskyFactor::factorize(cache.analysis(L), L));
        stats = cache.stats();
    }
    state.counters["poses"] = static_cast<double>(p.laplacian.size());
    state.counters["hits"] = static_cast<double>(stats.hits);
}

BENCHMARK(BM_graph_corpus_serial)->Iterations(2)->UseRealTime()->Unit(benchmark::kMillisecond);
BENCHMARK(BM_graph_corpus)->ArgName("threads")->Arg(1)->Arg(2)->Iterations(2)->UseRealTime()->Unit(benchmark::kMillisecond);
BENCHMARK(BM_engine_pose_fresh)->ArgName("intrinsic")->Arg(0)->Arg(1)->UseRealTime()->Unit(benchmark::kMillisecond);
BENCHMARK(BM_engine_pose_cached)->ArgName("intrinsic")->Arg(0)->Arg(1)->UseRealTime()->Unit(benchmark::kMillisecond);

// Prints the target ratios after the table, from the real times of this run.
class RatioReporter : public benchmark::ConsoleReporter {
  public:
    RatioReporter() : ConsoleReporter(::isatty(STDOUT_FILENO) ? OO_ColorTabular : OO_Tabular) {}
    void ReportRuns(const std::vector<Run>& runs) override {
        for (const Run& run : runs)
            if (!run.error_occurred && run.run_type == Run::RT_Iteration)
                time_[run.benchmark_name()] = run.GetAdjustedRealTime();
        ConsoleReporter::ReportRuns(runs);
    }
    void Finalize() override {
        ConsoleReporter::Finalize();
        const auto ratio = [&](const char* label, const std::string& a, const std::string& b) {
            if (time_.count(a) && time_.count(b))
                GetOutputStream() << label << ": " << time_[a] / time_[b] << "\n";
        };
        ratio("throughput 2 threads / 1 thread (target >= 1.7)", "BM_graph_corpus/threads:1/iterations:2/real_time",
              "BM_graph_corpus/threads:2/iterations:2/real_time");
        ratio("engine overhead, graph 1 thread / serial twin (target < 1.05)",
              "BM_graph_corpus/threads:1/iterations:2/real_time", "BM_graph_corpus_serial/iterations:2/real_time");
        ratio("pose collection, extrinsic: cached / fresh (target <= 0.5)", "BM_engine_pose_cached/intrinsic:0/real_time",
              "BM_engine_pose_fresh/intrinsic:0/real_time");
        ratio("pose collection, intrinsic Delaunay: cached / fresh", "BM_engine_pose_cached/intrinsic:1/real_time",
              "BM_engine_pose_fresh/intrinsic:1/real_time");
    }

  private:
    std::map<std::string, double> time_;
};

}  // namespace

int main(int argc, char** argv) {
    benchmark::Initialize(&argc, argv);
    if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
    benchmark::AddCustomContext("corpus", HOLOFLOW_CORPUS_DIR);
    benchmark::AddCustomContext("tbb", TBB_VERSION_STRING);
    RatioReporter reporter;
    benchmark::RunSpecifiedBenchmarks(&reporter);
    benchmark::Shutdown();
    return 0;
}
