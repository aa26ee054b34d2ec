#include "holoflow/kernels/holomorphic.h"

#include <cmath>
#include <complex>
#include <set>

#include <Eigen/LU>
#include <gtest/gtest.h>

#include "holoflow/engine/conformal_pipeline.h"
#include "holoflow/kernels/double_cover.h"
#include "holoflow/kernels/homology.h"
#include "holoflow/kernels/intrinsic_delaunay.h"
#include "holoflow/kernels/shapes.h"
#include "support/test_support.h"

namespace holoflow::kernels {
namespace {

using Complex = std::complex<double>;
constexpr double kArithmeticTol = 1e-12;  // exact arithmetic up to rounding
constexpr double kPeriodTol = 1e-9;       // a-normalisation solves a small dense system

bool in_fundamental_domain(Complex t) {
    return t.imag() > 0 && std::abs(t.real()) <= 0.5 + kArithmeticTol && std::norm(t) >= 1 - kArithmeticTol;
}

TEST(ReduceModulus, MapsIntoTheFundamentalDomain) {
    EXPECT_NEAR(std::abs(reduce_modulus({0, 2}) - Complex(0, 2)), 0, kArithmeticTol);
    EXPECT_NEAR(std::abs(reduce_modulus({0, 0.5}) - Complex(0, 2)), 0, kArithmeticTol);  // -1/tau
    EXPECT_NEAR(std::abs(reduce_modulus({3, 1}) - Complex(0, 1)), 0, kArithmeticTol);    // tau - 3
    // (a tau + b) / (c tau + d) of a reduced point comes back to it.
    const Complex base(0.3, 1.4);
    const Complex moved = (2.0 * base + 1.0) / (3.0 * base + 2.0);  // det 2*2 - 1*3 = 1
    EXPECT_NEAR(std::abs(reduce_modulus(moved) - base), 0, 1e-9);
    for (double x : {-7.3, -0.2, 0.49, 4.1})
        for (double y : {0.01, 0.3, 1.0, 9.0}) EXPECT_TRUE(in_fundamental_domain(reduce_modulus({x, y})));
}

TEST(ReduceLattice, SameLatticeShortestBasisPositivelyOriented) {
    for (const auto& [a, b] : {std::pair{Complex(1, 0), Complex(3.3, 1.4)}, {Complex(0.7, -6.1), Complex(1.6, 5.4)},
                               {Complex(0.76, 0.10), Complex(1.59, -8.76)}, {Complex(2, 1), Complex(-1, 0.02)}}) {
        const auto [A, B] = reduce_lattice(a, b);
        EXPECT_GT((B / A).imag(), 0);
        EXPECT_LE(std::abs(A), std::abs(B) * (1 + 1e-12));
        EXPECT_LE(std::abs((B / A).real()), 0.5 + 1e-12);
        // A and B are integer combinations of a and b with determinant +-1 (the same lattice).
        const auto coefficients = [&](Complex z) {
            const double det = a.real() * b.imag() - a.imag() * b.real();
            return std::pair{(z.real() * b.imag() - z.imag() * b.real()) / det,
                             (a.real() * z.imag() - a.imag() * z.real()) / det};
        };
        const auto [p, q] = coefficients(A);
        const auto [r, t] = coefficients(B);
        for (double c : {p, q, r, t}) EXPECT_NEAR(c, std::round(c), 1e-9);
        EXPECT_NEAR(std::abs(std::round(p) * std::round(t) - std::round(q) * std::round(r)), 1, 1e-12);
        const Complex m = (b / a).imag() > 0 ? b / a : -b / a;
        EXPECT_NEAR(std::abs(B / A - reduce_modulus(m)), 0, 1e-9);
    }
    EXPECT_THROW(reduce_lattice({1, 0}, {2, 0}), InvalidInput);
}

// The affine step: the periods become the rectangle's sides, and values in between follow
// real-linearly.
TEST(RectangleForm, SendsThePeriodsToTheSides) {
    const Complex A(0.7, -0.3), B(0.9, 2.2);
    Eigen::VectorXcd tau(3);
    tau << A, B, 0.25 * A - 2.0 * B;
    const Eigen::VectorXcd out = rectangle_form(tau, A, B);
    const double height = std::abs(A) * (B / A).imag();
    EXPECT_NEAR(std::abs(out(0) - Complex(std::abs(A), 0)), 0, 1e-12);
    EXPECT_NEAR(std::abs(out(1) - Complex(0, height)), 0, 1e-12);
    EXPECT_NEAR(std::abs(out(2) - (0.25 * out(0) - 2.0 * out(1))), 0, 1e-12);
    EXPECT_THROW(rectangle_form(tau, B, A), InvalidInput);  // negatively oriented
}

TEST(GenericCoefficients, DistinctAndNonzero) {
    const Eigen::VectorXd d = generic_form_coefficients(30);
    std::set<double> seen(d.data(), d.data() + d.size());
    EXPECT_EQ(seen.size(), 30u);
    EXPECT_GT(d.cwiseAbs().minCoeff(), 0.1);
}

// Phase k is phase 1 shifted by k - 1 places: each phase as generic as the first.
TEST(GenericCoefficients, PhasesAreShiftsOfTheFirst) {
    const Eigen::VectorXd first = generic_form_coefficients(40);
    for (int phase = 2; phase <= 8; ++phase) {
        const Eigen::VectorXd d = generic_form_coefficients(30, phase);
        EXPECT_EQ(d, first.segment(phase - 1, 30)) << phase;
    }
    EXPECT_EQ(generic_form_coefficients(30, 1), first.head(30));
    EXPECT_THROW(generic_form_coefficients(30, 0), InvalidInput);
}

TEST(IntegerCoefficients, SmallNonzeroIntegers) {
    const Eigen::VectorXd d = integer_form_coefficients(30);
    for (double x : d) {
        EXPECT_EQ(x, std::round(x));
        EXPECT_TRUE(x == 1 || x == 2) << x;
    }
    EXPECT_GT((d.array() == 1).count(), 0);
    EXPECT_GT((d.array() == 2).count(), 0);  // not all equal: no extra symmetry
}

// With integer coefficients Re tau has integer periods on every generator loop (so its
// integral is circle-valued and each level curve closes); generic coefficients have none.
TEST(IntegerCoefficients, RealPartHasIntegerPeriods) {
    const MeshView surface = shapes::genus_surface(2, 4);
    const auto real_periods = [&](const engine::ConformalResult& c) {
        std::vector<double> out;
        for (const auto& loop : c.homology.loops)
            out.push_back(integrate_along(surface, Eigen::MatrixXd(c.tau.real()), loop)(0));
        return out;
    };
    engine::ConformalOptions options;
    options.form = engine::FormChoice::IntegerPeriods;
    const engine::ConformalResult c = engine::compute_conformal(surface, options);
    EXPECT_EQ(c.form, engine::FormChoice::IntegerPeriods);
    const std::vector<double> integer = real_periods(c);
    ASSERT_EQ(integer.size(), 4u);
    for (double period : integer) {
        EXPECT_NEAR(period, std::round(period), kPeriodTol);
        EXPECT_GE(std::abs(std::round(period)), 1);
    }
    for (double period : real_periods(engine::compute_conformal(surface)))
        EXPECT_GT(std::abs(period - std::round(period)), 1e-3);
}

// The involution of a punctured torus's double cover (as found on punctured-torus.obj):
// S^T x = (x4 - x2, -x3, -x2, x1 - x3), under which the 1s and 2s of integer_form_coefficients
// are odd, so (I + S^T) x = 0 and the even form would vanish everywhere.
TEST(IntegerCoefficients, EvenFormNeverVanishes) {
    Eigen::MatrixXi St(4, 4);
    St << 0, -1, 0, 1, 0, 0, -1, 0, 0, -1, 0, 0, 1, 0, -1, 0;
    const Eigen::MatrixXi S = St.transpose();
    ASSERT_EQ(S * S, Eigen::MatrixXi::Identity(4, 4));
    EXPECT_EQ(even_form_coefficients(S, integer_form_coefficients(4)).norm(), 0);
    const Eigen::VectorXd d = even_integer_form_coefficients(S);
    EXPECT_EQ(St.cast<double>() * d, d);
    EXPECT_EQ(d, d.array().round().matrix());
    EXPECT_GT(d.norm(), 0.5);
}

TEST(HolomorphicBasis, NormalisedOnCanonicalCycles) {
    const MeshView surface = shapes::genus_surface(2, 4);
    const engine::ConformalResult c = engine::compute_conformal(surface);
    const HolomorphicBasis& b = c.basis;
    ASSERT_EQ(b.genus, 2);
    // Canonical cycles: intersection matrix standard (checked by the kernel) and unimodular.
    EXPECT_NEAR(std::abs(b.canonical.cast<double>().determinant()), 1.0, kArithmeticTol);

    const Eigen::MatrixXcd phi = holomorphic_forms(c.harmonic, c.star, b);
    ASSERT_EQ(phi.cols(), 2);
    // Periods over the generator loops, then over the canonical cycles.
    const Eigen::Index n = c.harmonic.cols();
    Eigen::MatrixXcd loop_periods(2, n);
    for (Eigen::Index j = 0; j < n; ++j) {
        const auto& loop = c.homology.loops[static_cast<std::size_t>(j)];
        const Eigen::VectorXd re = integrate_along(surface, phi.real(), loop);
        const Eigen::VectorXd im = integrate_along(surface, phi.imag(), loop);
        for (int k = 0; k < 2; ++k) loop_periods(k, j) = Complex(re(k), im(k));
    }
    const Eigen::MatrixXcd cycle_periods = loop_periods * b.canonical.cast<double>().cast<Complex>();
    const Eigen::MatrixXcd a = cycle_periods.leftCols(2), bp = cycle_periods.rightCols(2);
    EXPECT_LT((a - Eigen::MatrixXcd::Identity(2, 2)).norm(), kPeriodTol);
    EXPECT_LT((bp - b.period_matrix).norm(), kPeriodTol * b.period_matrix.norm());
    EXPECT_GT(b.period_im_min_eigenvalue, 0);
    EXPECT_LT(b.period_symmetry_error, 0.05);
}

// B from the sparse closed forms (eta^T W omega) is the Gram matrix omega^T W omega of the
// harmonic forms: <d f, omega> = 0 for co-closed omega. On the intrinsic Delaunay triangulation
// the pipeline solves on, with its weights, for a small and a high genus.
TEST(HodgeStar, InnerProductsFromTheClosedFormsAreTheGramMatrix) {
    for (const char* name : {"eight", "cheese"}) {
        SCOPED_TRACE(name);
        const auto mesh = test::corpus_mesh(name);
        const engine::ConformalResult c = engine::compute_conformal(*mesh);
        ASSERT_NE(c.intrinsic, nullptr);
        const IntrinsicTriangulation& t = *c.intrinsic;
        const Eigen::MatrixXd eta = carry_forms(t, compute_homology_basis(*c.surface).closed_forms),
                              omega = carry_forms(t, c.harmonic);
        const std::vector<double>& w = c.laplace_weights;  // the Laplacian's, on t's edges
        ASSERT_EQ(static_cast<Index>(w.size()), t.mesh.n_edges());
        const Eigen::Map<const Eigen::VectorXd> weight(w.data(), static_cast<Eigen::Index>(w.size()));
        const Eigen::MatrixXd gram = omega.transpose() * weight.asDiagonal() * omega;
        const HodgeStar star = hodge_star(w, eta.sparseView(), omega, c.star.wedge);
        EXPECT_LT((star.inner - gram).norm(), 1e-12 * gram.norm());
        EXPECT_EQ(star.inner, Eigen::MatrixXd(star.inner.transpose()));
        EXPECT_LT((star.star - c.star.star).norm(), 1e-9 * c.star.star.norm());  // the pipeline's, from its own data
    }
}

TEST(HodgeStar, RejectsSingularWedge) {
    const Eigen::MatrixXd omega = Eigen::MatrixXd::Random(10, 2);
    const std::vector<double> w(10, 1.0);
    const Eigen::SparseMatrix<double> eta = omega.sparseView();
    EXPECT_THROW(hodge_star(w, eta, omega, Eigen::MatrixXd::Zero(2, 2)), SolverFailure);
    EXPECT_THROW(hodge_star(w, eta, omega, Eigen::MatrixXd::Zero(3, 3)), InvalidInput);
    EXPECT_THROW(hodge_star(w, Eigen::MatrixXd(omega.topRows(9)).sparseView(), omega, Eigen::MatrixXd::Identity(2, 2)),
                 InvalidInput);
}

TEST(Involution, EvenFormsOnADoubleCover) {
    const MeshView sheet = shapes::perforated_sheet(2, 2);  // genus 0, 3 boundary loops
    const DoubleCover cover = double_cover(sheet);
    const HomologyBasis h = compute_homology_basis(cover.mesh);
    ASSERT_EQ(h.genus, 2);
    const Eigen::MatrixXi S = involution_matrix(cover, h);
    HomologyOptions sparse_forms;
    sparse_forms.sparse_forms = true;
    EXPECT_EQ(involution_matrix(cover, compute_homology_basis(cover.mesh, sparse_forms)), S);
    EXPECT_EQ(S * S, Eigen::MatrixXi::Identity(4, 4));  // s is an involution
    EXPECT_NE(S, Eigen::MatrixXi::Identity(4, 4));
    const Eigen::VectorXd d = even_form_coefficients(S);
    EXPECT_LT((S.transpose().cast<double>() * d - d).norm(), kArithmeticTol);
    EXPECT_GT(d.norm(), 0.1);
    // Integer x: an even integer vector.
    const Eigen::VectorXd di = even_integer_form_coefficients(S);
    EXPECT_EQ(S.transpose().cast<double>() * di, di);
    EXPECT_EQ(di, di.array().round().matrix());
    EXPECT_GT(di.norm(), 0.5);
    // The even subspace has half the dimension: trace(S) = 0 (an orientation-reversing
    // involution swaps the two halves of H^1 of the double).
    EXPECT_EQ(S.trace(), 0);
}

}  // namespace
}  // namespace holoflow::kernels
