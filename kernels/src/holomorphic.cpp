#include "holoflow/kernels/holomorphic.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>

#include "holoflow/kernels/errors.h"
#include "holoflow/kernels/double_cover.h"
#include "holoflow/kernels/homology.h"

namespace holoflow::kernels {

HodgeStar hodge_star(std::span<const double> w, const Eigen::SparseMatrix<double>& eta, const Eigen::MatrixXd& omega,
                     const Eigen::MatrixXd& wedge) {
    const Eigen::Index k = omega.cols();
    HOLOFLOW_REQUIRE(k >= 2 && k % 2 == 0, "need 2g >= 2 harmonic forms");
    HOLOFLOW_REQUIRE(static_cast<Eigen::Index>(w.size()) == omega.rows(),
                     "forms and weights must have one row per edge");
    HOLOFLOW_REQUIRE(eta.rows() == omega.rows() && eta.cols() == k, "closed forms must match the harmonic ones");
    HOLOFLOW_REQUIRE(wedge.rows() == k && wedge.cols() == k, "wedge matrix must be 2g x 2g");
    HodgeStar h;
    h.wedge = wedge;
    Eigen::SparseMatrix<double> weighted = eta;
    for (Eigen::Index c = 0; c < weighted.outerSize(); ++c)
        for (Eigen::SparseMatrix<double>::InnerIterator it(weighted, c); it; ++it) it.valueRef() *= w[it.row()];
    const Eigen::MatrixXd inner = weighted.transpose() * omega;
    h.inner = 0.5 * (inner + inner.transpose());  // exactly symmetric

    const Eigen::PartialPivLU<Eigen::MatrixXd> lu = wedge_factor(h.wedge);
    h.wedge_det = lu.determinant();
    h.star = lu.solve(h.inner).transpose();
    if (!h.star.allFinite()) throw SolverFailure("hodge_star: non-finite star matrix");

    h.wedge_integrality_error = (h.wedge - h.wedge.array().round().matrix()).cwiseAbs().maxCoeff();
    const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(k, k);
    h.star_square_error = (h.star * h.star + I).norm() / I.norm();
    h.star_isometry_error =
        (h.star.transpose() * h.wedge * h.star - h.wedge).norm() / h.wedge.norm();
    return h;
}

Eigen::PartialPivLU<Eigen::MatrixXd> wedge_factor(const Eigen::MatrixXd& wedge) {
    HOLOFLOW_REQUIRE(wedge.rows() == wedge.cols(), "wedge matrix must be square");
    // A is an integer matrix of det +-1 for a cohomology basis, 0 otherwise: partial pivoting
    // (blocked; full pivoting took 1 s at 2g = 938) tells them apart by its determinant.
    Eigen::PartialPivLU<Eigen::MatrixXd> lu(wedge);
    const double det = lu.determinant();
    if (!(std::abs(det) > 1e-6) || !std::isfinite(det))
        throw SolverFailure("wedge matrix is singular (det " + std::to_string(det) +
                            "): forms are not a cohomology basis");
    return lu;
}

HolomorphicBasis holomorphic_basis(const HodgeStar& star) {
    const Eigen::Index n = star.wedge.rows(), g = n / 2;
    HOLOFLOW_REQUIRE(star.wedge_integrality_error < 1e-6 && std::abs(std::abs(star.wedge_det) - 1) < 1e-6,
                     "wedge matrix is not integral unimodular (det " +
                         std::to_string(star.wedge_det) + ")");
    // Loops and their dual forms: A = -I^{-1} for the loops' intersection matrix I.
    const Eigen::MatrixXi A = star.wedge.array().round().cast<int>();
    const Eigen::MatrixXi intersection =
        (-A.cast<double>().inverse()).array().round().cast<int>();
    HolomorphicBasis b;
    b.genus = static_cast<int>(g);
    b.canonical = symplectic_basis(intersection);

    // Periods of tau_i = omega_i + i *omega_i over loop m are delta_im + i C(i, m).
    // Over the canonical cycles K: (I + i C) K = K + i C K, in real arithmetic (a quarter of the
    // flops of the complex product).
    const Eigen::MatrixXd K = b.canonical.cast<double>();
    Eigen::MatrixXcd periods(n, n);
    periods.real() = K;
    periods.imag().noalias() = star.star * K;
    const Eigen::MatrixXcd a_periods = periods.leftCols(g).transpose();  // g x 2g
    // The 2g forms tau_i span the g-dimensional space only up to discretisation error: take the
    // least-norm combination with the required a-periods, a_periods^* gram^-1 with the Hermitian
    // positive definite gram by Cholesky (full pivoting where that fails).
    const Eigen::MatrixXcd gram = a_periods * a_periods.adjoint();
    const Eigen::LLT<Eigen::MatrixXcd> llt(gram);
    b.coefficients = llt.info() == Eigen::Success ? Eigen::MatrixXcd(llt.solve(a_periods).adjoint())
                                                  : Eigen::MatrixXcd(a_periods.adjoint() * gram.fullPivLu().inverse());
    b.period_matrix = b.coefficients.transpose() * periods.rightCols(g);
    if (!b.period_matrix.allFinite()) throw SolverFailure("holomorphic_basis: non-finite periods");

    b.period_symmetry_error =
        (b.period_matrix - b.period_matrix.transpose()).norm() / b.period_matrix.norm();
    const Eigen::MatrixXd im = b.period_matrix.imag();
    b.period_im_min_eigenvalue =
        Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(0.5 * (im + im.transpose()))
            .eigenvalues()
            .minCoeff();
    return b;
}

Eigen::MatrixXcd holomorphic_forms(const Eigen::MatrixXd& omega, const HodgeStar& star,
                                   const HolomorphicBasis& basis) {
    using Complex = std::complex<double>;
    const Eigen::Index n = omega.cols();
    HOLOFLOW_REQUIRE(n == star.star.rows(), "forms do not match the Hodge star");
    // tau = omega (I + i C^T); phi = tau * coefficients.
    const Eigen::MatrixXcd mix =
        (Eigen::MatrixXd::Identity(n, n).cast<Complex>() +
         Complex(0, 1) * star.star.transpose().cast<Complex>()) *
        basis.coefficients;
    return omega.cast<Complex>() * mix;
}

std::complex<double> reduce_modulus(std::complex<double> tau) {
    for (int guard = 0; guard < 1000; ++guard) {
        tau -= std::round(tau.real());
        if (std::norm(tau) >= 1 - 1e-15) break;
        tau = -1.0 / tau;
    }
    return tau;
}

std::array<std::complex<double>, 2> reduce_lattice(std::complex<double> a, std::complex<double> b) {
    HOLOFLOW_REQUIRE(std::isfinite(std::abs(a)) && std::isfinite(std::abs(b)) && std::abs((b / a).imag()) > 1e-12,
                     "a lattice needs two finite periods that are not parallel");
    if ((b / a).imag() < 0) b = -b;
    // Gauss: take the shorter as A, reduce B by whole multiples of A; stop when B stays longer.
    for (int guard = 0; guard < 1000; ++guard) {
        if (std::norm(b) < std::norm(a)) {
            std::swap(a, b);
            b = -b;  // (a, b) -> (b, -a) keeps Im(b / a) > 0
        }
        const double shift = std::round((b / a).real());
        if (shift == 0) break;
        b -= shift * a;
    }
    return {a, b};
}

Eigen::VectorXcd rectangle_form(const Eigen::VectorXcd& tau, std::complex<double> A, std::complex<double> B) {
    const std::complex<double> m = B / A;
    HOLOFLOW_REQUIRE(std::isfinite(std::abs(m)) && m.imag() > 0, "the periods must be a positively oriented lattice basis");
    const double size = std::abs(A), shear = m.real() / m.imag();
    Eigen::VectorXcd out(tau.size());
    for (Eigen::Index e = 0; e < tau.size(); ++e) {
        const std::complex<double> w = tau(e) / A;
        out(e) = size * std::complex<double>(w.real() - shear * w.imag(), w.imag());
    }
    return out;
}

}  // namespace holoflow::kernels

namespace holoflow::kernels {

Eigen::VectorXd generic_form_coefficients(Eigen::Index n, int phase) {
    HOLOFLOW_REQUIRE(phase >= 1, "the phase of the generic coefficients starts at 1");
    // Golden-angle phases: distinct, nonzero, and free of small rational relations.
    Eigen::VectorXd d(n);
    for (Eigen::Index i = 0; i < n; ++i) d(i) = 1.5 + std::cos(2.399963229728653 * static_cast<double>(i + phase));
    return d;
}

Eigen::VectorXd integer_form_coefficients(Eigen::Index n, int scale) {
    // 1.5 + cos(.) lies in [0.5, 2.5]: at scale 1 it rounds to 1 or 2 (3 only at cos = 1, which
    // no phase hits).
    return (static_cast<double>(scale) * generic_form_coefficients(n)).array().round();
}

Eigen::MatrixXi involution_matrix(const DoubleCover& cover, const HomologyBasis& homology) {
    const MeshView& mesh = cover.mesh;
    const bool sparse = homology.closed_forms.size() == 0;
    HOLOFLOW_REQUIRE(static_cast<Index>(sparse ? homology.sparse_closed_forms.rows() : homology.closed_forms.rows()) ==
                         mesh.n_edges(),
                     "homology basis belongs to another mesh");
    // The image of halfedge x->y is the halfedge s(x)->s(y): the twin of the halfedge
    // s(y)->s(x) of the mirror face (which has the reversed orientation).
    auto mirror = [&](Index h) {
        const Index f = cover.face_involution[MeshView::face(h)];
        const Index sx = cover.vertex_involution[mesh.tail(h)], sy = cover.vertex_involution[mesh.head(h)];
        for (int k = 0; k < 3; ++k) {
            const Index m = 3 * f + k;
            if (mesh.tail(m) == sy && mesh.head(m) == sx) return mesh.twin[m];
        }
        throw InvalidInput("involution_matrix: cover faces do not mirror each other");
    };
    const Eigen::Index n = sparse ? homology.sparse_closed_forms.cols() : homology.closed_forms.cols();
    HOLOFLOW_REQUIRE(homology.loops.size() == static_cast<std::size_t>(n), "one homology loop per closed form");
    std::vector<std::vector<Index>> images(homology.loops.size());
    for (std::size_t j = 0; j < images.size(); ++j)
        for (const Index h : homology.loops[j]) images[j].push_back(mirror(h));
    const Eigen::MatrixXd periods = sparse ? integrate_along_paths(mesh, homology.sparse_closed_forms, images)
                                           : integrate_along_paths(mesh, homology.closed_forms, images);
    return periods.array().round().cast<int>();
}

Eigen::VectorXd even_form_coefficients(const Eigen::MatrixXi& involution, const Eigen::VectorXd& x) {
    const Eigen::Index n = involution.rows();
    HOLOFLOW_REQUIRE(involution.cols() == n && x.size() == n, "involution and coefficients disagree in size");
    const Eigen::MatrixXd plus = Eigen::MatrixXd::Identity(n, n) + involution.transpose().cast<double>();
    return plus * x;
}

Eigen::VectorXd even_form_coefficients(const Eigen::MatrixXi& involution, int phase) {
    return even_form_coefficients(involution, generic_form_coefficients(involution.rows(), phase));
}

Eigen::VectorXd even_integer_form_coefficients(const Eigen::MatrixXi& involution) {
    // round(k g) / k tends to g, whose even part is not zero, so some k gives d != 0; each entry
    // of d is an integer combination of entries |x| <= 2.5 k, so k = 64 is far past cancellation.
    // The smallest such k keeps the periods, and so the leaves, short.
    Eigen::VectorXd d;
    for (int k = 1; k <= 64; ++k) {
        d = even_form_coefficients(involution, integer_form_coefficients(involution.rows(), k));
        if (d.cwiseAbs().maxCoeff() > 0) break;
    }
    return d;
}

}  // namespace holoflow::kernels
