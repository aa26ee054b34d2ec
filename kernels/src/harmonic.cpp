#include "holoflow/kernels/harmonic.h"

#include <algorithm>
#include <string>

#include "holoflow/kernels/errors.h"
#include "holoflow/kernels/parallel.h"

namespace holoflow::kernels {
namespace {

//! Runs fn(c) for every column c; columns in parallel on large meshes, each written by one task.
template <class Fn>
void for_each_column(Eigen::Index n_edges, Eigen::Index n_cols, const Fn& fn) {
    par::for_each_index(static_cast<std::size_t>(n_cols), n_edges >= par::kParallelColumnRows,
                        [&](std::size_t c) { fn(static_cast<Eigen::Index>(c)); });
}

}  // namespace

Eigen::MatrixXd codifferential(Index n_vertices, const EdgeMatrix& E, std::span<const double> w,
                               const FormColumns& omega) {
    HOLOFLOW_REQUIRE(w.size() == static_cast<std::size_t>(E.rows()), "need one weight per edge");
    HOLOFLOW_REQUIRE(omega.rows() == E.rows(), "need one form value per edge");
    HOLOFLOW_REQUIRE(E.size() == 0 || (E.minCoeff() >= 0 && E.maxCoeff() < n_vertices),
                     "edge vertex index out of range");
    // Zeroed column by column inside the tasks, not by MatrixXd::Zero: GCC turns malloc + zero
    // fill into calloc, whose fresh pages the first += reads (mapping the shared zero page) and
    // then writes, a copy-on-write fault with a TLB shootdown on every other core per 4 KiB page
    // (9 % of pizza's run).
    Eigen::MatrixXd delta(n_vertices, omega.cols());
    for_each_column(E.rows(), omega.cols(), [&](Eigen::Index c) {
        double* out = delta.col(c).data();
        std::fill(out, out + n_vertices, 0.0);
        const double* in = omega.col(c).data();
        for (Eigen::Index e = 0; e < E.rows(); ++e) {
            const double flux = w[e] * in[e];
            out[E(e, 1)] += flux;
            out[E(e, 0)] -= flux;
        }
    });
    return delta;
}

Eigen::MatrixXd harmonic_rhs(Index n_vertices, const EdgeMatrix& E, std::span<const double> w,
                             const FormColumns& eta, std::span<const Index> pinned) {
    HOLOFLOW_REQUIRE(eta.rows() == E.rows(), "need one form value per edge");
    for (Index p : pinned)
        HOLOFLOW_REQUIRE(p >= 0 && p < n_vertices, "pinned vertex " + std::to_string(p) + " out of range");
    // delta(eta + d f) = delta eta + L f = 0; pinned rows are identity rows with f = 0.
    Eigen::MatrixXd rhs = -codifferential(n_vertices, E, w, eta);
    for (Index p : pinned) rhs.row(p).setZero();
    return rhs;
}

Eigen::MatrixXd harmonic_potential(const EdgeMatrix& E, std::span<const double> w,
                                   const CholeskyFactor& factor, const FormColumns& eta,
                                   std::span<const Index> pinned) {
    return factor.solve(harmonic_rhs(factor.size(), E, w, eta, pinned));
}

void plus_gradient_columns(const EdgeMatrix& E, const Eigen::MatrixXd& eta, const Eigen::MatrixXd& f,
                           Eigen::Index first, Eigen::MatrixXd& omega) {
    HOLOFLOW_REQUIRE(eta.rows() == E.rows() && omega.rows() == E.rows() && omega.cols() == eta.cols(),
                     "need one form value per edge, as many forms in and out");
    HOLOFLOW_REQUIRE(first >= 0 && first + f.cols() <= eta.cols(), "form columns out of range");
    HOLOFLOW_REQUIRE(E.size() == 0 || E.maxCoeff() < f.rows(), "edge vertex index out of range");
    for_each_column(E.rows(), f.cols(), [&](Eigen::Index c) {
        double* out = omega.col(first + c).data();
        const double* in = eta.col(first + c).data();
        const double* fc = f.col(c).data();
        for (Eigen::Index e = 0; e < E.rows(); ++e) out[e] = in[e] + (fc[E(e, 1)] - fc[E(e, 0)]);
    });
}

void add_gradient(const EdgeMatrix& E, const Eigen::MatrixXd& f, Eigen::MatrixXd& omega) {
    HOLOFLOW_REQUIRE(f.cols() == omega.cols(), "need one potential per form");
    plus_gradient_columns(E, omega, f, 0, omega);
}

Eigen::MatrixXd plus_gradient(const EdgeMatrix& E, const Eigen::MatrixXd& eta, const Eigen::MatrixXd& f) {
    HOLOFLOW_REQUIRE(f.cols() == eta.cols(), "need one potential per form");
    Eigen::MatrixXd omega(eta.rows(), eta.cols());
    plus_gradient_columns(E, eta, f, 0, omega);
    return omega;
}

Eigen::MatrixXd harmonic_projection(const EdgeMatrix& E, std::span<const double> w,
                                    const CholeskyFactor& factor, const Eigen::MatrixXd& eta,
                                    std::span<const Index> pinned) {
    return plus_gradient(E, eta, harmonic_potential(E, w, factor, eta, pinned));
}

}  // namespace holoflow::kernels
