// Solver core: cotan Laplacian assembly, CHOLMOD analyse / factorize / solve on tori and
// icospheres from ~20k to ~1.3M faces. Sizes are named by `kfaces` (thousands of faces).
#include <benchmark/benchmark.h>

#include <cmath>
#include <map>
#include <memory>
#include <mutex>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Sparse>

#include "holoflow/kernels/cholesky.h"
#include "holoflow/kernels/cotan_laplacian.h"
#include "holoflow/kernels/harmonic.h"
#include "holoflow/kernels/shapes.h"

namespace {

using namespace holoflow;
using namespace holoflow::kernels;

enum Shape : int { kTorus = 0, kIcosphere = 1 };

//! Everything a benchmark may need for one mesh, built once (outside timing) and shared by all
//! benchmarks; building it runs every measured step once, which is the warm-up.
struct Problem {
    MeshView mesh;
    std::vector<double> w;
    LaplacianMatrix L;
    std::shared_ptr<const CholeskySymbolic> symbolic;
    std::shared_ptr<const CholeskyFactor> factor;
};

MeshView make_shape(int shape, int kfaces) {
    if (shape == kTorus) {
        // F = 2 nu nv with nu = 2 nv: nu = sqrt(F).
        const int nu = static_cast<int>(std::lround(std::sqrt(1000.0 * kfaces)));
        return shapes::torus(2.0, 0.7, nu, nu / 2);
    }
    // F = 20 4^level: the level with the closest face count.
    const int level = static_cast<int>(std::lround(std::log(50.0 * kfaces) / std::log(4.0)));
    return shapes::icosphere(level);
}

const Problem& problem(int shape, int kfaces) {
    static std::mutex mutex;
    static std::map<std::pair<int, int>, std::unique_ptr<Problem>> cache;
    std::lock_guard<std::mutex> lock(mutex);
    auto& slot = cache[{shape, kfaces}];
    if (!slot) {
        slot = std::make_unique<Problem>();
        slot->mesh = make_shape(shape, kfaces);
        slot->w = cotan_weights(slot->mesh);
        slot->L = assemble_laplacian(slot->mesh.n_vertices(), slot->mesh.E, slot->w, {0});
        slot->symbolic = CholeskySymbolic::analyse(slot->L);
        slot->factor = CholeskyFactor::factorize(slot->symbolic, slot->L);
    }
    return *slot;
}

Eigen::MatrixXd random_rhs(Index rows, Index cols) {
    std::mt19937_64 rng(12345);
    std::uniform_real_distribution<double> uniform(-1.0, 1.0);
    Eigen::MatrixXd B(rows, cols);
    for (Eigen::Index k = 0; k < B.size(); ++k) B.data()[k] = uniform(rng);
    for (Eigen::Index c = 0; c < cols; ++c) B(0, c) = 0;  // pinned vertex
    return B;
}

//! Relative residual ||L X - B|| / ||B|| with the symmetric upper-triangular CSC matrix.
double relative_residual(const LaplacianMatrix& L, const Eigen::MatrixXd& X,
                         const Eigen::MatrixXd& B) {
    Eigen::MatrixXd R = -B;
    for (Index j = 0; j < L.n; ++j) {
        for (Index s = L.col_start[j]; s < L.col_start[j + 1]; ++s) {
            R.row(L.row[s]) += L.value[s] * X.row(j);
            if (L.row[s] != j) R.row(j) += L.value[s] * X.row(L.row[s]);
        }
    }
    return R.norm() / B.norm();
}

constexpr double kResidualTol = 1e-9;  // direct solve of a mesh Laplacian

void set_counters(benchmark::State& state, const Problem& p) {
    state.counters["faces"] = p.mesh.n_faces();
    state.counters["vertices"] = p.mesh.n_vertices();
}

void BM_kernel_cotan_weights(benchmark::State& state) {
    const Problem& p = problem(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
    for (auto _ : state) benchmark::DoNotOptimize(cotan_weights(p.mesh));
    set_counters(state, p);
    state.SetItemsProcessed(state.iterations() * p.mesh.n_faces());
}

void BM_kernel_laplacian_assemble(benchmark::State& state) {  // pattern + fill
    const Problem& p = problem(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
    for (auto _ : state)
        benchmark::DoNotOptimize(assemble_laplacian(p.mesh.n_vertices(), p.mesh.E, p.w, {0}));
    set_counters(state, p);
    state.SetItemsProcessed(state.iterations() * p.mesh.n_faces());
}

void BM_kernel_laplacian_refill(benchmark::State& state) {  // values only, same pattern
    const Problem& p = problem(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
    LaplacianMatrix L = p.L;
    for (auto _ : state) {
        fill_laplacian(L, p.w);
        benchmark::DoNotOptimize(L.value.data());
    }
    if (L.value != p.L.value) state.SkipWithError("refill differs from the assembly");
    set_counters(state, p);
    state.SetItemsProcessed(state.iterations() * p.mesh.n_faces());
}

void BM_kernel_laplacian_triplets(benchmark::State& state) {  // Eigen triplets, for comparison
    const Problem& p = problem(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
    const EdgeMatrix& E = p.mesh.E;
    for (auto _ : state) {
        std::vector<Eigen::Triplet<double>> t;
        t.reserve(3 * static_cast<std::size_t>(E.rows()));
        for (Eigen::Index e = 0; e < E.rows(); ++e) {
            const Index a = std::min(E(e, 0), E(e, 1)), b = std::max(E(e, 0), E(e, 1));
            t.emplace_back(a, b, -p.w[e]);
            t.emplace_back(a, a, p.w[e]);
            t.emplace_back(b, b, p.w[e]);
        }
        Eigen::SparseMatrix<double> A(p.mesh.n_vertices(), p.mesh.n_vertices());
        A.setFromTriplets(t.begin(), t.end());
        benchmark::DoNotOptimize(A.valuePtr());
    }
    set_counters(state, p);
    state.SetItemsProcessed(state.iterations() * p.mesh.n_faces());
}

void BM_kernel_cholesky_analyse(benchmark::State& state) {
    const Problem& p = problem(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
    for (auto _ : state) benchmark::DoNotOptimize(CholeskySymbolic::analyse(p.L));
    set_counters(state, p);
    state.counters["factor_nnz"] = static_cast<double>(p.symbolic->factor_nonzeros());
}

void BM_kernel_cholesky_factorize(benchmark::State& state) {  // numeric only, analysis reused
    const Problem& p = problem(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
    for (auto _ : state) benchmark::DoNotOptimize(CholeskyFactor::factorize(p.symbolic, p.L));
    const Eigen::MatrixXd B = random_rhs(p.L.n, 1);
    const auto factor = CholeskyFactor::factorize(p.symbolic, p.L);
    if (relative_residual(p.L, factor->solve(B), B) > kResidualTol)
        state.SkipWithError("factorization residual too large");
    set_counters(state, p);
    state.counters["factor_MB"] = 8e-6 * static_cast<double>(p.symbolic->factor_nonzeros());
}

void BM_kernel_cholesky_solve(benchmark::State& state) {  // all RHS in one call
    const Problem& p = problem(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
    const Eigen::MatrixXd B = random_rhs(p.L.n, static_cast<Index>(state.range(2)));
    for (auto _ : state) benchmark::DoNotOptimize(p.factor->solve(B));
    if (relative_residual(p.L, p.factor->solve(B), B) > kResidualTol)
        state.SkipWithError("solve residual too large");
    set_counters(state, p);
    state.SetItemsProcessed(state.iterations() * state.range(2));
}

void BM_kernel_cholesky_solve_single(benchmark::State& state) {  // one RHS per call
    const Problem& p = problem(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
    const Eigen::MatrixXd B = random_rhs(p.L.n, static_cast<Index>(state.range(2)));
    Eigen::MatrixXd X(B.rows(), B.cols());
    for (auto _ : state) {
        for (Eigen::Index c = 0; c < B.cols(); ++c) X.col(c) = p.factor->solve(B.col(c));
        benchmark::DoNotOptimize(X.data());
    }
    if (relative_residual(p.L, X, B) > kResidualTol)
        state.SkipWithError("solve residual too large");
    set_counters(state, p);
    state.SetItemsProcessed(state.iterations() * state.range(2));
}

void BM_kernel_harmonic_projection(benchmark::State& state) {  // 2g forms: RHS, solve, d f
    const Problem& p = problem(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
    const Eigen::MatrixXd eta = random_rhs(p.mesh.n_edges(), static_cast<Index>(state.range(2)));
    const std::vector<Index> pinned = {0};
    for (auto _ : state)
        benchmark::DoNotOptimize(harmonic_projection(p.mesh.E, p.w, *p.factor, eta, pinned));
    set_counters(state, p);
}

const std::vector<int64_t> kShapes = {kTorus, kIcosphere};
const std::vector<int64_t> kKiloFaces = {20, 80, 320, 1280};  // icosphere levels 5..8
const std::vector<int64_t> kRhs = {2, 6, 10, 22};

void mesh_args(benchmark::internal::Benchmark* b) {
    b->ArgsProduct({kShapes, kKiloFaces})->ArgNames({"shape", "kfaces"});
    b->Unit(benchmark::kMillisecond);
}

void solve_args(benchmark::internal::Benchmark* b) {
    b->ArgsProduct({kShapes, kKiloFaces, kRhs})->ArgNames({"shape", "kfaces", "rhs"});
    b->Unit(benchmark::kMillisecond);
}

BENCHMARK(BM_kernel_cotan_weights)->Apply(mesh_args);
BENCHMARK(BM_kernel_laplacian_assemble)->Apply(mesh_args);
BENCHMARK(BM_kernel_laplacian_refill)->Apply(mesh_args);
BENCHMARK(BM_kernel_laplacian_triplets)->Apply(mesh_args);
BENCHMARK(BM_kernel_cholesky_analyse)->Apply(mesh_args);
BENCHMARK(BM_kernel_cholesky_factorize)->Apply(mesh_args);
BENCHMARK(BM_kernel_cholesky_solve)->Apply(solve_args);
BENCHMARK(BM_kernel_cholesky_solve_single)->Apply(solve_args);
BENCHMARK(BM_kernel_harmonic_projection)
    ->ArgsProduct({kShapes, kKiloFaces, {2, 22}})
    ->ArgNames({"shape", "kfaces", "rhs"})
    ->Unit(benchmark::kMillisecond);

}  // namespace

int main(int argc, char** argv) {
    benchmark::Initialize(&argc, argv);
    if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
    benchmark::AddCustomContext("shapes", "0 = torus (nu = 2 nv), 1 = icosphere");
    benchmark::AddCustomContext("solver", "CHOLMOD supernodal, AMD, OpenBLAS 1 thread");
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    return 0;
}
