#include "holoflow/kernels/cholesky.h"

#include <dlfcn.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <fstream>
#include <limits>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include <cholmod.h>
#include <gtest/gtest.h>
#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>

#include "holoflow/kernels/cotan_laplacian.h"
#include "holoflow/kernels/errors.h"
#include "holoflow/kernels/shapes.h"
#include "support/test_support.h"

// GCC's OpenMP entry point, which CHOLMOD calls for each parallel region (kernels/src/cholesky.cpp).
extern "C" void GOMP_parallel(void (*body)(void*), void* data, unsigned num_threads, unsigned flags);

namespace holoflow::kernels {
namespace {

constexpr double kSolveTol = 1e-10;  // relative: two direct solvers on a mesh Laplacian (cond ~1e4)
constexpr double kSweepTol = 1e-13;  // relative: same factor, BLAS blocking differs per RHS count
constexpr std::uint64_t kCholeskySeed = 77001;

Eigen::SparseMatrix<double> upper_matrix(const LaplacianMatrix& L) {
    std::vector<Eigen::Triplet<double>> t;
    for (Index j = 0; j < L.n; ++j)
        for (Index s = L.col_start[j]; s < L.col_start[j + 1]; ++s)
            t.emplace_back(L.row[s], j, L.value[s]);
    Eigen::SparseMatrix<double> A(L.n, L.n);
    A.setFromTriplets(t.begin(), t.end());
    return A;
}

Eigen::MatrixXd random_matrix(Index rows, Index cols, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> uniform(-1.0, 1.0);
    Eigen::MatrixXd B(rows, cols);
    for (Eigen::Index j = 0; j < cols; ++j)
        for (Eigen::Index i = 0; i < rows; ++i) B(i, j) = uniform(rng);
    return B;
}

double relative_error(const Eigen::MatrixXd& X, const Eigen::MatrixXd& ref) {
    return (X - ref).norm() / ref.norm();
}

//! Pinned cotan Laplacian of a closed mesh: symmetric positive definite.
LaplacianMatrix pinned_laplacian(const MeshView& mesh) {
    return assemble_laplacian(mesh.n_vertices(), mesh.E, cotan_weights(mesh), {0});
}

MeshView jittered(MeshView mesh, std::uint64_t seed, double amount) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> uniform(-amount, amount);
    for (Index v = 0; v < mesh.n_vertices(); ++v)
        for (int c = 0; c < 3; ++c) mesh.V(v, c) += uniform(rng);
    return mesh;
}

TEST(Cholesky, SolveMatchesSimplicialLDLT) {
    SCOPED_TRACE(kCholeskySeed);
    for (const MeshView& mesh :
         {shapes::icosphere(4), shapes::torus(2.0, 0.5, 60, 30), shapes::genus_surface(2, 4)}) {
        const LaplacianMatrix L = pinned_laplacian(mesh);
        const auto symbolic = CholeskySymbolic::analyse(L);
        EXPECT_TRUE(symbolic->matches(L));
        EXPECT_EQ(symbolic->size(), L.n);
        // The factor holds at least the lower triangle of L (fill-in only adds).
        EXPECT_GE(symbolic->factor_nonzeros(), static_cast<std::size_t>(L.nonzeros()));
        const auto factor = CholeskyFactor::factorize(symbolic, L);
        EXPECT_EQ(factor->size(), L.n);
        EXPECT_EQ(factor->symbolic(), symbolic);

        const Eigen::MatrixXd B = random_matrix(L.n, 6, kCholeskySeed);
        const Eigen::MatrixXd X = factor->solve(B);
        Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Upper> ldlt(upper_matrix(L));
        ASSERT_EQ(ldlt.info(), Eigen::Success);
        const Eigen::MatrixXd ref = ldlt.solve(B);
        EXPECT_LT(relative_error(X, ref), kSolveTol);
        const Eigen::MatrixXd residual = upper_matrix(L).selfadjointView<Eigen::Upper>() * X - B;
        EXPECT_LT(residual.norm() / B.norm(), kSolveTol);

        for (Eigen::Index c = 0; c < B.cols(); ++c) {
            const Eigen::MatrixXd xc = factor->solve(B.col(c));
            EXPECT_LT(relative_error(xc, X.col(c)), kSweepTol) << "column " << c;
        }
    }
}

TEST(Cholesky, RefactorWithSameSymbolicEqualsFreshFactorization) {
    const MeshView mesh = shapes::torus(2.0, 0.6, 40, 20);
    LaplacianMatrix L = pinned_laplacian(mesh);
    const auto symbolic = CholeskySymbolic::analyse(L);
    const auto before = CholeskyFactor::factorize(symbolic, L);

    SCOPED_TRACE(kCholeskySeed);
    fill_laplacian(L, cotan_weights(jittered(mesh, kCholeskySeed, 0.03)));  // moved vertices
    ASSERT_TRUE(symbolic->matches(L));
    const auto reused = CholeskyFactor::factorize(symbolic, L);
    const auto fresh = CholeskyFactor::factorize(CholeskySymbolic::analyse(L), L);

    const Eigen::MatrixXd B = random_matrix(L.n, 3, kCholeskySeed + 1);
    const Eigen::MatrixXd X = reused->solve(B);
    EXPECT_EQ(X, fresh->solve(B));  // same ordering, same arithmetic: same bits
    EXPECT_GT(relative_error(before->solve(B), X), 1e-6);  // the new values were used
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Upper> ldlt(upper_matrix(L));
    EXPECT_LT(relative_error(X, ldlt.solve(B)), kSolveTol);
}

//! X solving L X = B with CHOLMOD's own driver (cholmod_analyze, cholmod_factorize, cholmod_solve)
//! under the settings CholeskySymbolic uses: AMD only, postordered, supernodal.
Eigen::MatrixXd cholmod_driver_solve(const LaplacianMatrix& L, const Eigen::MatrixXd& B) {
    cholmod_common c;
    cholmod_start(&c);
    c.nmethods = 1;
    c.method[0].ordering = CHOLMOD_AMD;
    c.postorder = 1;
    c.supernodal = CHOLMOD_SUPERNODAL;
    cholmod_sparse A{};
    A.nrow = A.ncol = static_cast<std::size_t>(L.n);
    A.nzmax = L.row.size();
    A.p = const_cast<Index*>(L.col_start.data());
    A.i = const_cast<Index*>(L.row.data());
    A.x = const_cast<double*>(L.value.data());
    A.stype = 1;
    A.itype = CHOLMOD_INT;
    A.xtype = CHOLMOD_REAL;
    A.dtype = CHOLMOD_DOUBLE;
    A.sorted = A.packed = 1;
    cholmod_dense b{};
    b.nrow = b.d = static_cast<std::size_t>(B.rows());
    b.ncol = static_cast<std::size_t>(B.cols());
    b.nzmax = b.nrow * b.ncol;
    b.x = const_cast<double*>(B.data());
    b.xtype = CHOLMOD_REAL;
    b.dtype = CHOLMOD_DOUBLE;
    cholmod_factor* F = cholmod_analyze(&A, &c);
    Eigen::MatrixXd X;
    if (F != nullptr && cholmod_factorize(&A, F, &c) && c.status == CHOLMOD_OK && F->is_super) {
        cholmod_dense* x = cholmod_solve(CHOLMOD_A, F, &b, &c);
        if (x != nullptr) X = Eigen::Map<const Eigen::MatrixXd>(static_cast<double*>(x->x), B.rows(), B.cols());
        cholmod_free_dense(&x, &c);
    }
    cholmod_free_factor(&F, &c);
    cholmod_finish(&c);
    return X;
}

// CholeskyFactor hands CHOLMOD's supernodal factorization the permuted lower triangle it builds
// once per analysis, where cholmod_factorize would transpose the matrix at every call: the same
// entries in the same places, so the same bits as CHOLMOD's own driver.
TEST(Cholesky, FactorEqualsCholmodDriverBitForBit) {
    const std::vector<MeshView> meshes = {shapes::torus(2.0, 0.5, 60, 30), shapes::genus_surface(3, 3),
                                          *test::corpus_mesh("eight"), *test::corpus_mesh("elephant")};
    for (const MeshView& mesh : meshes) {
        const LaplacianMatrix L = pinned_laplacian(jittered(mesh, kCholeskySeed, 0.01));
        const Eigen::MatrixXd B = random_matrix(L.n, 5, kCholeskySeed + 2);
        const Eigen::MatrixXd X = CholeskyFactor::factorize(CholeskySymbolic::analyse(L), L)->solve(B);
        // After ours, which keeps OpenBLAS on one thread (a threaded BLAS rounds otherwise).
        const Eigen::MatrixXd ref = cholmod_driver_solve(L, B);
        ASSERT_EQ(ref.rows(), L.n) << "CHOLMOD's driver failed";
        EXPECT_EQ(X, ref) << L.n << " rows";
    }
}

// CHOLMOD's clock reads inside its factorization are skipped (kernels/src/cholesky.cpp defines
// SuiteSparse_time for the program); any other caller still reads the clock.
TEST(Cholesky, SuiteSparseClockOutsideCholmodIsTheClock) {
    EXPECT_EQ(dlsym(RTLD_DEFAULT, "SuiteSparse_time"), reinterpret_cast<void*>(&SuiteSparse_time));
    const double before = SuiteSparse_time();
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    EXPECT_GE(SuiteSparse_time() - before, 0.019);
}

TEST(Cholesky, PatternMismatchIsRejected) {
    const LaplacianMatrix L = pinned_laplacian(shapes::icosphere(2));
    const LaplacianMatrix other = pinned_laplacian(shapes::icosphere(1));
    const auto symbolic = CholeskySymbolic::analyse(L);
    EXPECT_FALSE(symbolic->matches(other));
    EXPECT_THROW(CholeskyFactor::factorize(symbolic, other), InvalidInput);
    EXPECT_THROW(CholeskyFactor::factorize(nullptr, L), InvalidInput);
    const auto factor = CholeskyFactor::factorize(symbolic, L);
    EXPECT_THROW(factor->solve(Eigen::MatrixXd::Ones(L.n + 1, 1)), InvalidInput);
    EXPECT_EQ(factor->solve(Eigen::MatrixXd(L.n, 0)).cols(), 0);

    LaplacianMatrix truncated = L;
    truncated.col_start.pop_back();
    EXPECT_THROW(CholeskySymbolic::analyse(truncated), InvalidInput);
    LaplacianMatrix unsorted = L;
    const Index j = L.n - 1;  // the last column holds off-diagonals before its diagonal
    ASSERT_GE(L.col_start[j + 1] - L.col_start[j], 2);
    std::swap(unsorted.row[L.col_start[j]], unsorted.row[L.col_start[j + 1] - 1]);
    EXPECT_THROW(CholeskySymbolic::analyse(unsorted), InvalidInput);
    EXPECT_THROW(CholeskySymbolic::analyse(LaplacianMatrix{}), InvalidInput);
}

TEST(Cholesky, NotPositiveDefiniteThrows) {
    LaplacianMatrix L = pinned_laplacian(shapes::icosphere(2));
    const auto symbolic = CholeskySymbolic::analyse(L);
    L.value[L.diagonal_slot[5]] = -1.0;
    EXPECT_THROW(CholeskyFactor::factorize(symbolic, L), SolverFailure);
    // Negative weights everywhere: negative definite away from the pinned vertex.
    const MeshView mesh = shapes::icosphere(2);
    std::vector<double> w = cotan_weights(mesh);
    for (double& x : w) x = -x;
    fill_laplacian(L, w);
    try {
        CholeskyFactor::factorize(symbolic, L);
        ADD_FAILURE() << "negative definite matrix was factorized";
    } catch (const SolverFailure& e) {
        EXPECT_NE(std::string(e.what()).find("not positive definite"), std::string::npos)
            << e.what();
    }
}

TEST(Cholesky, NonFiniteValuesThrow) {
    const MeshView mesh = shapes::icosphere(2);
    LaplacianMatrix L = pinned_laplacian(mesh);
    const auto symbolic = CholeskySymbolic::analyse(L);
    std::vector<double> w = cotan_weights(mesh);
    w[3] = std::numeric_limits<double>::quiet_NaN();
    fill_laplacian(L, w);
    EXPECT_THROW(CholeskyFactor::factorize(symbolic, L), SolverFailure);
    w[3] = std::numeric_limits<double>::infinity();
    fill_laplacian(L, w);
    EXPECT_THROW(CholeskyFactor::factorize(symbolic, L), SolverFailure);

    fill_laplacian(L, cotan_weights(mesh));
    const auto factor = CholeskyFactor::factorize(symbolic, L);
    Eigen::MatrixXd B = Eigen::MatrixXd::Ones(L.n, 2);
    B(7, 1) = std::numeric_limits<double>::quiet_NaN();
    EXPECT_THROW(factor->solve(B), SolverFailure);
}

TEST(Cholesky, ConcurrentSolvesGiveIdenticalResults) {
    const LaplacianMatrix L = pinned_laplacian(shapes::torus(2.0, 0.5, 80, 40));
    const auto factor = CholeskyFactor::factorize(CholeskySymbolic::analyse(L), L);
    const Eigen::MatrixXd B = random_matrix(L.n, 4, kCholeskySeed + 2);
    const Eigen::MatrixXd expected = factor->solve(B);

    constexpr int kThreads = 4, kRepeats = 8;
    std::vector<int> mismatches(kThreads, 0);
    std::vector<std::thread> threads;
    for (int t = 0; t < kThreads; ++t) {
        threads.emplace_back([&, t] {
            for (int r = 0; r < kRepeats; ++r)
                if (factor->solve(B) != expected) ++mismatches[t];
        });
    }
    for (std::thread& t : threads) t.join();
    for (int t = 0; t < kThreads; ++t) EXPECT_EQ(mismatches[t], 0) << "thread " << t;
}

TEST(Cholesky, ConcurrentFactorizationsShareOneAnalysis) {
    const MeshView mesh = shapes::icosphere(3);
    const LaplacianMatrix L0 = pinned_laplacian(mesh);
    const auto symbolic = CholeskySymbolic::analyse(L0);
    constexpr int kThreads = 3;
    std::vector<LaplacianMatrix> L(kThreads, L0);
    for (int t = 0; t < kThreads; ++t)
        fill_laplacian(L[t], cotan_weights(jittered(mesh, kCholeskySeed + t, 0.01)));
    const Eigen::MatrixXd B = random_matrix(L0.n, 2, kCholeskySeed + 3);
    std::vector<Eigen::MatrixXd> X(kThreads);
    std::vector<std::thread> threads;
    for (int t = 0; t < kThreads; ++t)
        threads.emplace_back(
            [&, t] { X[t] = CholeskyFactor::factorize(symbolic, L[t])->solve(B); });
    for (std::thread& t : threads) t.join();
    for (int t = 0; t < kThreads; ++t)
        EXPECT_EQ(X[t], CholeskyFactor::factorize(symbolic, L[t])->solve(B)) << "thread " << t;
}

// Threads of this process, from /proc/self/status.
int threads_in_process() {
    std::ifstream status("/proc/self/status");
    for (std::string line; std::getline(status, line);)
        if (line.rfind("Threads:", 0) == 0) return std::stoi(line.substr(8));
    return -1;
}

// CHOLMOD's OpenMP regions run on their caller with no libgomp team: the program's GOMP_parallel
// is the definition every library resolves, and factorizations large enough for CHOLMOD to ask
// for teams of 4 (regions over more than 128 rows), on the main thread and another one, start
// no thread. Outside CHOLMOD a region still gets its team from libgomp.
TEST(Cholesky, OpenMPRegionsRunOnTheirCaller) {
    EXPECT_EQ(dlsym(RTLD_DEFAULT, "GOMP_parallel"), reinterpret_cast<void*>(&GOMP_parallel));
    const LaplacianMatrix L = pinned_laplacian(shapes::icosphere(5));
    const auto symbolic = CholeskySymbolic::analyse(L);
    const int before = threads_in_process();
    ASSERT_GT(before, 0);
    CholeskyFactor::factorize(symbolic, L);
    EXPECT_EQ(threads_in_process(), before);
    std::thread other([&] { CholeskyFactor::factorize(symbolic, L); });
    other.join();
    EXPECT_EQ(threads_in_process(), before);

    std::atomic<int> bodies = 0;
    GOMP_parallel([](void* count) { ++*static_cast<std::atomic<int>*>(count); }, &bodies, 2, 0);
    EXPECT_EQ(bodies, 2);
}

}  // namespace
}  // namespace holoflow::kernels
