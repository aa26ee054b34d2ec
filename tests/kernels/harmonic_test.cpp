#include "holoflow/kernels/harmonic.h"

#include <cmath>
#include <numbers>
#include <queue>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "holoflow/kernels/cholesky.h"
#include "holoflow/kernels/cotan_laplacian.h"
#include "holoflow/kernels/errors.h"
#include "holoflow/kernels/shapes.h"

namespace holoflow::kernels {
namespace {

constexpr double kResidualTol = 1e-10;  // relative to the right-hand side: one direct solve
constexpr double kLocalSumTol = 1e-12;  // sums of a few O(1) terms per vertex or face
constexpr std::uint64_t kFormSeed = 424242;

//! Torus with its grid indices (i around the big circle, j around the tube) recovered from the
//! positions, then jittered so that no symmetry makes the forms harmonic by accident.
struct IndexedTorus {
    MeshView mesh;
    std::vector<int> i, j;
    int nu = 0, nv = 0;
};

IndexedTorus indexed_torus(int nu, int nv, double jitter) {
    const double R = 2.0, r = 0.7;
    IndexedTorus t{shapes::torus(R, r, nu, nv), {}, {}, nu, nv};
    const auto turns = [](double angle, int n) {
        const int k = static_cast<int>(std::lround(angle / (2 * std::numbers::pi) * n));
        return (k % n + n) % n;
    };
    for (Index v = 0; v < t.mesh.n_vertices(); ++v) {
        const double x = t.mesh.V(v, 0), y = t.mesh.V(v, 1), z = t.mesh.V(v, 2);
        t.i.push_back(turns(std::atan2(y, x), nu));
        t.j.push_back(turns(std::atan2(z, std::hypot(x, y) - R), nv));
    }
    std::mt19937_64 rng(kFormSeed);
    std::uniform_real_distribution<double> uniform(-jitter, jitter);
    for (Index v = 0; v < t.mesh.n_vertices(); ++v)
        for (int c = 0; c < 3; ++c) t.mesh.V(v, c) += uniform(rng);
    return t;
}

//! Closed forms "d(theta)/2pi" around the big circle and around the tube: per edge the wrapped
//! index step over the period; each integrates to 1 around its own loop.
Eigen::MatrixXd angle_forms(const IndexedTorus& t) {
    const auto step = [](int from, int to, int n) {
        int d = to - from;
        if (2 * d > n) d -= n;
        if (2 * d < -n) d += n;
        return static_cast<double>(d) / n;
    };
    Eigen::MatrixXd eta(t.mesh.n_edges(), 2);
    for (Index e = 0; e < t.mesh.n_edges(); ++e) {
        const Index a = t.mesh.E(e, 0), b = t.mesh.E(e, 1);
        eta(e, 0) = step(t.i[a], t.i[b], t.nu);
        eta(e, 1) = step(t.j[a], t.j[b], t.nv);
    }
    return eta;
}

Eigen::MatrixXd gradient(const EdgeMatrix& E, const Eigen::MatrixXd& f) {
    Eigen::MatrixXd df(E.rows(), f.cols());
    for (Eigen::Index e = 0; e < E.rows(); ++e) df.row(e) = f.row(E(e, 1)) - f.row(E(e, 0));
    return df;
}

//! Largest |sum of the form around a face| (zero for closed forms).
double max_face_circulation(const MeshView& mesh, const Eigen::VectorXd& form) {
    double worst = 0;
    for (Index f = 0; f < mesh.n_faces(); ++f) {
        double sum = 0;
        for (Index h = 3 * f; h < 3 * f + 3; ++h)
            sum += mesh.edge_sign(h) * form[mesh.halfedge_edge[h]];
        worst = std::max(worst, std::abs(sum));
    }
    return worst;
}

//! Largest mismatch between a form and the gradient of its integral along a BFS tree: zero
//! exactly when the form is exact on a connected mesh.
double max_exactness_defect(const MeshView& mesh, const Eigen::VectorXd& form) {
    std::vector<double> g(static_cast<std::size_t>(mesh.n_vertices()), 0.0);
    std::vector<char> seen(g.size(), 0);
    std::vector<std::vector<std::pair<Index, Index>>> adjacent(g.size());
    for (Index e = 0; e < mesh.n_edges(); ++e) {
        adjacent[mesh.E(e, 0)].push_back({e, mesh.E(e, 1)});
        adjacent[mesh.E(e, 1)].push_back({e, mesh.E(e, 0)});
    }
    std::queue<Index> queue;
    queue.push(0);
    seen[0] = 1;
    while (!queue.empty()) {
        const Index v = queue.front();
        queue.pop();
        for (auto [e, u] : adjacent[v]) {
            if (seen[u]) continue;
            seen[u] = 1;
            g[u] = g[v] + (mesh.E(e, 1) == u ? form[e] : -form[e]);
            queue.push(u);
        }
    }
    double worst = 0;
    for (Index e = 0; e < mesh.n_edges(); ++e)
        worst = std::max(worst, std::abs(g[mesh.E(e, 1)] - g[mesh.E(e, 0)] - form[e]));
    return worst;
}

struct Solver {
    std::vector<double> w;
    LaplacianMatrix L;
    std::shared_ptr<const CholeskyFactor> factor;
};

Solver make_solver(const MeshView& mesh, std::vector<Index> pinned) {
    Solver s;
    s.w = cotan_weights(mesh);
    s.L = assemble_laplacian(mesh.n_vertices(), mesh.E, s.w, std::move(pinned));
    s.factor = CholeskyFactor::factorize(CholeskySymbolic::analyse(s.L), s.L);
    return s;
}

TEST(Codifferential, SignsAndLoops) {
    EdgeMatrix E(3, 2);
    E << 0, 1, 1, 2, 2, 2;
    const std::vector<double> w = {2.0, 0.5, 9.0};
    Eigen::MatrixXd omega(3, 1);
    omega << 3.0, 4.0, 5.0;
    const Eigen::MatrixXd delta = codifferential(3, E, w, omega);
    // +w omega at the head, -w omega at the tail; the loop cancels itself.
    EXPECT_DOUBLE_EQ(delta(0, 0), -6.0);
    EXPECT_DOUBLE_EQ(delta(1, 0), 6.0 - 2.0);
    EXPECT_DOUBLE_EQ(delta(2, 0), 2.0);
    EXPECT_THROW(codifferential(2, E, w, omega), InvalidInput);
}

TEST(Codifferential, OfGradientIsLaplacian) {
    const IndexedTorus t = indexed_torus(24, 12, 0.02);
    const std::vector<double> w = cotan_weights(t.mesh);
    const LaplacianMatrix L = assemble_laplacian(t.mesh.n_vertices(), t.mesh.E, w, {});
    std::mt19937_64 rng(kFormSeed + 1);
    SCOPED_TRACE(kFormSeed + 1);
    std::uniform_real_distribution<double> uniform(-1.0, 1.0);
    Eigen::MatrixXd g(t.mesh.n_vertices(), 2);
    for (Eigen::Index k = 0; k < g.size(); ++k) g.data()[k] = uniform(rng);
    const Eigen::MatrixXd delta =
        codifferential(t.mesh.n_vertices(), t.mesh.E, w, gradient(t.mesh.E, g));
    Eigen::MatrixXd Lg = Eigen::MatrixXd::Zero(g.rows(), g.cols());  // symmetric CSC product
    for (Index j = 0; j < L.n; ++j) {
        for (Index s = L.col_start[j]; s < L.col_start[j + 1]; ++s) {
            Lg.row(L.row[s]) += L.value[s] * g.row(j);
            if (L.row[s] != j) Lg.row(j) += L.value[s] * g.row(L.row[s]);
        }
    }
    EXPECT_LT((delta - Lg).cwiseAbs().maxCoeff(), kLocalSumTol * 10);
}

TEST(Gradient, PlusGradientIsCopyThenAddGradient) {
    const IndexedTorus t = indexed_torus(16, 8, 0.02);
    std::mt19937_64 rng(kFormSeed + 2);
    SCOPED_TRACE(kFormSeed + 2);
    std::uniform_real_distribution<double> uniform(-1.0, 1.0);
    Eigen::MatrixXd f(t.mesh.n_vertices(), 3), eta(t.mesh.n_edges(), 3);
    for (Eigen::Index k = 0; k < f.size(); ++k) f.data()[k] = uniform(rng);
    for (Eigen::Index k = 0; k < eta.size(); ++k) eta.data()[k] = uniform(rng);
    Eigen::MatrixXd expected = eta;
    add_gradient(t.mesh.E, f, expected);
    EXPECT_EQ(plus_gradient(t.mesh.E, eta, f), expected);  // the same bits
    EXPECT_THROW(plus_gradient(t.mesh.E, eta.topRows(3), f), InvalidInput);

    // Column by column, as the solve blocks write them: the same bits, the rest untouched.
    Eigen::MatrixXd blocks = Eigen::MatrixXd::Constant(eta.rows(), eta.cols(), 7.0);
    plus_gradient_columns(t.mesh.E, eta, f.rightCols(1), 2, blocks);
    EXPECT_EQ(blocks.col(2), expected.col(2));
    EXPECT_TRUE((blocks.leftCols(2).array() == 7.0).all());
    plus_gradient_columns(t.mesh.E, eta, f.leftCols(2), 0, blocks);
    EXPECT_EQ(blocks, expected);
    Eigen::MatrixXd in_place = eta;  // omega may be eta itself
    plus_gradient_columns(t.mesh.E, in_place, f.middleCols(1, 2), 1, in_place);
    EXPECT_EQ(in_place.rightCols(2), expected.rightCols(2));
    EXPECT_EQ(in_place.col(0), eta.col(0));
    EXPECT_THROW(plus_gradient_columns(t.mesh.E, eta, f.leftCols(2), 2, blocks), InvalidInput);
    EXPECT_THROW(plus_gradient_columns(t.mesh.E, eta, f, -1, blocks), InvalidInput);
}

TEST(HarmonicProjection, TorusFormsBecomeCoclosedInTheirClass) {
    const IndexedTorus t = indexed_torus(40, 20, 0.03);
    const std::vector<Index> pinned = {0};
    const Solver s = make_solver(t.mesh, pinned);
    const Eigen::MatrixXd eta = angle_forms(t);
    for (int c = 0; c < 2; ++c) ASSERT_LT(max_face_circulation(t.mesh, eta.col(c)), kLocalSumTol);

    const Eigen::MatrixXd omega = harmonic_projection(t.mesh.E, s.w, *s.factor, eta, pinned);
    ASSERT_EQ(omega.rows(), eta.rows());
    ASSERT_EQ(omega.cols(), 2);
    const Eigen::MatrixXd delta_eta = codifferential(t.mesh.n_vertices(), t.mesh.E, s.w, eta);
    const Eigen::MatrixXd delta_omega = codifferential(t.mesh.n_vertices(), t.mesh.E, s.w, omega);
    for (int c = 0; c < 2; ++c) {
        SCOPED_TRACE(c);
        const double rhs = delta_eta.col(c).cwiseAbs().maxCoeff();
        ASSERT_GT(rhs, 1e-3);  // the jittered forms are far from co-closed
        EXPECT_LT(delta_omega.col(c).cwiseAbs().maxCoeff(), kResidualTol * rhs);
        EXPECT_LT(max_face_circulation(t.mesh, omega.col(c)), kLocalSumTol);  // still closed
        const Eigen::VectorXd difference = omega.col(c) - eta.col(c);
        EXPECT_GT(difference.cwiseAbs().maxCoeff(), 1e-4);  // the projection did something
        EXPECT_LT(max_exactness_defect(t.mesh, difference), kLocalSumTol * 100);  // same class
    }

    // Harmonic = least weighted energy in the class: adding any gradient costs energy.
    std::mt19937_64 rng(kFormSeed + 2);
    SCOPED_TRACE(kFormSeed + 2);
    std::uniform_real_distribution<double> uniform(-0.01, 0.01);
    Eigen::MatrixXd g(t.mesh.n_vertices(), 2);
    for (Eigen::Index k = 0; k < g.size(); ++k) g.data()[k] = uniform(rng);
    const Eigen::MatrixXd other = omega + gradient(t.mesh.E, g);
    const Eigen::Map<const Eigen::VectorXd> w(s.w.data(), t.mesh.n_edges());
    for (int c = 0; c < 2; ++c) {
        const double e_omega = w.dot(omega.col(c).cwiseAbs2());
        const double e_other = w.dot(other.col(c).cwiseAbs2());
        // Cross term <omega, dg>_w vanishes, so the excess is exactly the energy of dg.
        const double e_dg = w.dot(gradient(t.mesh.E, g).col(c).cwiseAbs2());
        EXPECT_NEAR(e_other - e_omega, e_dg, kResidualTol * e_omega);
        EXPECT_GT(e_dg, 0.0);
    }
}

TEST(HarmonicProjection, ClassRepresentativeDoesNotMatter) {
    const IndexedTorus t = indexed_torus(30, 16, 0.02);
    const std::vector<Index> pinned = {5};
    const Solver s = make_solver(t.mesh, pinned);
    const Eigen::MatrixXd eta = angle_forms(t);
    std::mt19937_64 rng(kFormSeed + 3);
    SCOPED_TRACE(kFormSeed + 3);
    std::uniform_real_distribution<double> uniform(-1.0, 1.0);
    Eigen::MatrixXd g(t.mesh.n_vertices(), 2);
    for (Eigen::Index k = 0; k < g.size(); ++k) g.data()[k] = uniform(rng);

    const Eigen::MatrixXd omega = harmonic_projection(t.mesh.E, s.w, *s.factor, eta, pinned);
    const Eigen::MatrixXd shifted =
        harmonic_projection(t.mesh.E, s.w, *s.factor, eta + gradient(t.mesh.E, g), pinned);
    EXPECT_LT((shifted - omega).norm(), kResidualTol * omega.norm() * 100);  // g is O(1), eta O(0.1)
    // Idempotent: a harmonic form projects to itself.
    const Eigen::MatrixXd again = harmonic_projection(t.mesh.E, s.w, *s.factor, omega, pinned);
    EXPECT_LT((again - omega).norm(), kResidualTol * omega.norm());
    // Multi-column projection equals one column at a time.
    for (int c = 0; c < 2; ++c) {
        const Eigen::MatrixXd single =
            harmonic_projection(t.mesh.E, s.w, *s.factor, eta.col(c), pinned);
        EXPECT_LT((single - omega.col(c)).norm(), kResidualTol * omega.col(c).norm());
    }
}

TEST(HarmonicProjection, ExactFormsVanishOnGenusTwo) {
    const MeshView mesh = shapes::genus_surface(2, 3);
    const std::vector<Index> pinned = {0};
    const Solver s = make_solver(mesh, pinned);
    std::mt19937_64 rng(kFormSeed + 4);
    SCOPED_TRACE(kFormSeed + 4);
    std::uniform_real_distribution<double> uniform(-1.0, 1.0);
    Eigen::MatrixXd g(mesh.n_vertices(), 4);
    for (Eigen::Index k = 0; k < g.size(); ++k) g.data()[k] = uniform(rng);
    const Eigen::MatrixXd eta = gradient(mesh.E, g);
    const Eigen::MatrixXd omega = harmonic_projection(mesh.E, s.w, *s.factor, eta, pinned);
    // The class of an exact form is 0, whose harmonic representative is 0.
    EXPECT_LT(omega.cwiseAbs().maxCoeff(), kResidualTol * eta.cwiseAbs().maxCoeff() * 100);
    EXPECT_THROW(harmonic_projection(mesh.E, s.w, *s.factor, eta.topRows(3), pinned), InvalidInput);
}

TEST(HarmonicProjection, SameBitsOnOneOrTwoThreads) {
    const IndexedTorus t = indexed_torus(100, 60, 0.01);  // >= 16384 edges: columns in parallel
    const std::vector<Index> pinned = {0};
    const Solver s = make_solver(t.mesh, pinned);
    const Eigen::MatrixXd eta = angle_forms(t);
    Eigen::MatrixXd serial, parallel;
    {
        tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
        serial = harmonic_projection(t.mesh.E, s.w, *s.factor, eta, pinned);
    }
    {
        tbb::global_control two(tbb::global_control::max_allowed_parallelism, 2);
        parallel = harmonic_projection(t.mesh.E, s.w, *s.factor, eta, pinned);
    }
    EXPECT_EQ(serial, parallel);
}

}  // namespace
}  // namespace holoflow::kernels
