#pragma once

#include <span>

#include <Eigen/Core>

#include "holoflow/kernels/cholesky.h"
#include "holoflow/kernels/mesh_view.h"

namespace holoflow::kernels {

//! #E x k forms, or a range of their columns: a matrix or its middleCols bind without a copy.
using FormColumns = Eigen::Ref<const Eigen::MatrixXd>;

//! \brief Co-differential (weighted divergence) of 1-forms on edges: d^T W omega, i.e.
//! (delta omega)_v = sum over edges e at v of +w_e omega_e where v = E(e,1) (head) and -w_e
//! omega_e where v = E(e,0) (tail). Loops cancel. delta d equals the LaplacianMatrix of w.
//! omega is #E x k; returns #V x k. Deterministic (fixed edge order per column).
//! \throw InvalidInput on mismatched sizes or vertex indices out of range.
Eigen::MatrixXd codifferential(Index n_vertices, const EdgeMatrix& E, std::span<const double> w,
                               const FormColumns& omega);

//! Right-hand sides of harmonic_potential: -delta(eta) (#V x k), zero at the pinned vertices.
//! \throw InvalidInput on mismatched sizes or a pinned vertex out of range.
Eigen::MatrixXd harmonic_rhs(Index n_vertices, const EdgeMatrix& E, std::span<const double> w,
                             const FormColumns& eta, std::span<const Index> pinned);

//! \brief Potential f (#V x k) of the harmonic part of closed 1-forms: L f = -delta(eta), so
//! eta + d f is co-closed for the weights w. Vertex functions are shared by every triangulation
//! of the same vertices, so f computed on an intrinsic triangulation corrects the forms on the
//! mesh's own edges too. All k right-hand sides go through one solve; f = 0 at pinned vertices.
//! \throw InvalidInput on mismatched sizes; SolverFailure from the solve.
Eigen::MatrixXd harmonic_potential(const EdgeMatrix& E, std::span<const double> w,
                                   const CholeskyFactor& factor, const FormColumns& eta,
                                   std::span<const Index> pinned);

//! omega += d f along E(e,0) -> E(e,1), column by column (in parallel on large meshes).
//! \throw InvalidInput on mismatched sizes.
void add_gradient(const EdgeMatrix& E, const Eigen::MatrixXd& f, Eigen::MatrixXd& omega);

//! eta + d f in one pass, the same bits as copying eta and add_gradient (no separate copy of a
//! #E x k matrix). \throw InvalidInput on mismatched sizes.
Eigen::MatrixXd plus_gradient(const EdgeMatrix& E, const Eigen::MatrixXd& eta, const Eigen::MatrixXd& f);

//! The same for the columns first .. first + f.cols() - 1 only: omega's columns there become
//! eta's plus d f (f's columns in order); omega keeps its size and its other columns, and may be
//! eta itself. Tasks writing disjoint column ranges of one omega may run at once.
//! \throw InvalidInput on mismatched sizes or columns out of range.
void plus_gradient_columns(const EdgeMatrix& E, const Eigen::MatrixXd& eta, const Eigen::MatrixXd& f,
                           Eigen::Index first, Eigen::MatrixXd& omega);

//! \brief Harmonic part of closed 1-forms (DESIGN 2.3): omega = eta + d f with L f = -delta eta,
//! the co-closed representative of eta's cohomology class for the weights w (delta omega = 0).
//! E are the edges (1-forms measured from E(e,0) to E(e,1)), eta is #E x k, `factor` the Cholesky
//! factor of the LaplacianMatrix of (E, w) with the given pinned vertices (f = 0 there; one per
//! component of a closed surface). All k right-hand sides go through one solve.
//! \throw InvalidInput on mismatched sizes; SolverFailure from the solve.
Eigen::MatrixXd harmonic_projection(const EdgeMatrix& E, std::span<const double> w,
                                    const CholeskyFactor& factor, const Eigen::MatrixXd& eta,
                                    std::span<const Index> pinned);

}  // namespace holoflow::kernels
