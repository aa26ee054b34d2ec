#pragma once

#include <array>
#include <complex>
#include <span>

#include <Eigen/Core>
#include <Eigen/LU>
#include <Eigen/SparseCore>

#include "holoflow/kernels/mesh_view.h"

namespace holoflow::kernels {

//! Discrete Hodge star on the harmonic basis (DESIGN 2.3): *omega_i = sum_j star(i, j) omega_j.
struct HodgeStar {
    Eigen::MatrixXd wedge;  //!< A(k, j) = integral of omega_k ^ omega_j (integer, unimodular)
    Eigen::MatrixXd inner;  //!< B(k, i) = <omega_k, omega_i> = sum_e w_e omega_k(e) omega_i(e)
    Eigen::MatrixXd star;   //!< C with C^T = A^{-1} B
    double wedge_det = 0;              //!< det A (+-1 for a homology basis)
    double wedge_integrality_error = 0;  //!< max |A - round(A)|
    double star_square_error = 0;      //!< ||C^2 + I||_F / ||I||_F
    double star_isometry_error = 0;    //!< ||C^T A C - A||_F / ||A||_F
};

//! \brief Hodge star matrix of harmonic 1-forms `omega` (#E x 2g on `mesh`, weights `w` per
//! edge). `eta` are the closed forms they were made from (omega = eta + d f, as sparse #E x 2g
//! on the same edges): omega is co-closed, so <d f, omega_i> = 0 and B = eta^T W omega, which
//! costs nnz(eta) 2g instead of #E (2g)^2 (pizza: 0.09 % of its 150k x 292 entries; equal to
//! omega^T W omega to 4e-15 relative on the corpus), then symmetrised. A depends only on
//! cohomology classes, so the caller passes `wedge` = wedge_matrix of the closed forms omega is
//! cohomologous to (on any triangulation carrying them): sparse integer forms make it exact
//! and cheap. C^T = A^{-1} B.
//! \pre 2g >= 2 columns, sizes match.  \throw InvalidInput; SolverFailure if A is singular.
HodgeStar hodge_star(std::span<const double> w, const Eigen::SparseMatrix<double>& eta, const Eigen::MatrixXd& omega,
                     const Eigen::MatrixXd& wedge);

//! LU factors of the wedge matrix A of 2g closed forms (what C^T = A^{-1} B solves with).
//! \throw SolverFailure where A is singular (|det A| <= 1e-6, or not finite: det A is +-1 for a
//! cohomology basis, 0 otherwise).
Eigen::PartialPivLU<Eigen::MatrixXd> wedge_factor(const Eigen::MatrixXd& wedge);

//! a-normalised holomorphic basis and period matrix on a canonical homology basis.
struct HolomorphicBasis {
    int genus = 0;
    //! Canonical cycles as integer combinations of the generator loops: cycle k (a_1..a_g,
    //! b_1..b_g) = sum_j canonical(j, k) loop_j; intersection matrix standard symplectic.
    Eigen::MatrixXi canonical;
    //! phi_k = sum_i coefficients(i, k) (omega_i + i *omega_i), 2g x g; integral over a_j of
    //! phi_k = delta_jk.
    Eigen::MatrixXcd coefficients;
    Eigen::MatrixXcd period_matrix;      //!< Omega(i, j) = integral over b_j of phi_i
    double period_symmetry_error = 0;    //!< ||Omega - Omega^T||_F / ||Omega||_F
    double period_im_min_eigenvalue = 0; //!< smallest eigenvalue of Im Omega (> 0)
};

//! \brief Canonical basis by symplectic reduction of the integer intersection matrix -A^{-1}
//! of the loops, then a-normalisation and the period matrix, from the Hodge star alone (the
//! periods of omega_i over loop j are delta_ij).  \throw InvalidInput if A is not unimodular.
HolomorphicBasis holomorphic_basis(const HodgeStar& star);

//! Values on edges (#E x g complex) of the normalised forms phi_k for harmonic forms `omega`
//! (#E x 2g) of any triangulation carrying the same cohomology basis.
Eigen::MatrixXcd holomorphic_forms(const Eigen::MatrixXd& omega, const HodgeStar& star,
                                   const HolomorphicBasis& basis);

//! Genus-1 period reduced to the standard fundamental domain of SL(2, Z):
//! |Re| <= 1/2, |tau| >= 1 (Im tau > 0 expected). Torus moduli compare after this.
std::complex<double> reduce_modulus(std::complex<double> tau);

//! The same reduction on a lattice basis: periods (a, b) of a genus-1 form become a basis (A, B)
//! of the same lattice with B / A = reduce_modulus(+-b / a): A a shortest period, B a shortest
//! one not parallel to it, Im(B / A) > 0. \throw InvalidInput if a and b are parallel.
std::array<std::complex<double>, 2> reduce_lattice(std::complex<double> a, std::complex<double> b);

//! The form composed with the real-linear map that sends the period A to |A| and B to
//! i |A| Im(B / A): the torus' parallelogram becomes a rectangle (the affine step of a
//! parallelogram patch; conformal where Re(B / A) = 0). Still closed; orientation kept.
Eigen::VectorXcd rectangle_form(const Eigen::VectorXcd& tau, std::complex<double> A, std::complex<double> B);

}  // namespace holoflow::kernels

namespace holoflow::kernels {

struct DoubleCover;
struct HomologyBasis;

//! Deterministic, generic real coefficients for a combination of n basis forms (no two equal,
//! none zero, no rational relation of small height), so the chosen form has no special symmetry.
//! `phase` >= 1 picks one of a sequence of such choices (the golden-angle phases shifted by
//! phase - 1 steps); integer_form_coefficients scales phase 1.
Eigen::VectorXd generic_form_coefficients(Eigen::Index n, int phase = 1);

//! The generic coefficients times `scale`, rounded to integers (at scale 1 each is 1 or 2). A form
//! sum_i d_i omega_i of the basis dual to the generator loops then has integer periods, so its
//! integral u is a circle-valued function and every level curve of u closes: the vertical
//! trajectories of tau are closed loops and saddle connections, never dense (DESIGN 2.6).
Eigen::VectorXd integer_form_coefficients(Eigen::Index n, int scale = 1);

//! \brief Action of the cover's involution s on cohomology in the dual basis of the generator
//! loops: S(i, j) = integral of eta_i over s(loop_j), so s*omega_i = sum_j S(i, j) omega_j.
//! Integer and S^2 = I. \pre homology computed on cover.mesh.
Eigen::MatrixXi involution_matrix(const DoubleCover& cover, const HomologyBasis& homology);

//! Coefficients d (sum_i d_i omega_i) of a form even under s: d = (I + S^T) x, so S^T d = d.
//! Its holomorphic completion satisfies s*tau = conj(tau) and the fixed set (the original
//! boundary) is a horizontal trajectory. `x`: generic_form_coefficients (the default) or
//! integer_form_coefficients (then d is an integer vector too).
Eigen::VectorXd even_form_coefficients(const Eigen::MatrixXi& involution, const Eigen::VectorXd& x);
//! The even part of generic_form_coefficients(n, phase).
Eigen::VectorXd even_form_coefficients(const Eigen::MatrixXi& involution, int phase = 1);

//! An even integer vector d = (I + S^T) x with x = integer_form_coefficients(n, k) for the
//! smallest k >= 1 that gives d != 0 (at k = 1 the 1s and 2s can be odd under s: then d = 0 and
//! the form vanishes everywhere).
Eigen::VectorXd even_integer_form_coefficients(const Eigen::MatrixXi& involution);

}  // namespace holoflow::kernels
