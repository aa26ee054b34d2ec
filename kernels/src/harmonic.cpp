#include "holoflow/kernels/harmonic.h"

#include <string>

#include "holoflow/kernels/errors.h"
#include "holoflow/kernels/parallel.h"

namespace holoflow::kernels {
namespace {

constexpr Eigen::Index kParallelEdges = 16384;  // smaller forms: one task beats the TBB split

//! Runs fn(c) for every column c; columns in parallel on large meshes. Each column is written
//! by one task in a fixed order, so the result does not depend on the thread count.
template <class Fn>
void for_each_column(Eigen::Index n_edges, Eigen::Index n_cols, const Fn& fn) {
    const auto cols = static_cast<std::size_t>(n_cols);
    const std::size_t grain = n_edges >= kParallelEdges ? 1 : cols + 1;
    par::for_each_range(cols, grain, [&](std::size_t begin, std::size_t end) {
        for (std::size_t c = begin; c < end; ++c) fn(static_cast<Eigen::Index>(c));
    });
}

}  // namespace

Eigen::MatrixXd codifferential(Index n_vertices, const EdgeMatrix& E, std::span<const double> w,
                               const Eigen::MatrixXd& omega) {
    HOLOFLOW_REQUIRE(w.size() == static_cast<std::size_t>(E.rows()), "need one weight per edge");
    HOLOFLOW_REQUIRE(omega.rows() == E.rows(), "need one form value per edge");
    HOLOFLOW_REQUIRE(E.size() == 0 || (E.minCoeff() >= 0 && E.maxCoeff() < n_vertices),
                     "edge vertex index out of range");
    Eigen::MatrixXd delta = Eigen::MatrixXd::Zero(n_vertices, omega.cols());
    for_each_column(E.rows(), omega.cols(), [&](Eigen::Index c) {
        double* out = delta.col(c).data();
        const double* in = omega.col(c).data();
        for (Eigen::Index e = 0; e < E.rows(); ++e) {
            const double flux = w[e] * in[e];
            out[E(e, 1)] += flux;
            out[E(e, 0)] -= flux;
        }
    });
    return delta;
}

Eigen::MatrixXd harmonic_projection(const EdgeMatrix& E, std::span<const double> w,
                                    const CholeskyFactor& factor, const Eigen::MatrixXd& eta,
                                    std::span<const Index> pinned) {
    const Index n = factor.size();
    HOLOFLOW_REQUIRE(eta.rows() == E.rows(), "need one form value per edge");
    for (Index p : pinned)
        HOLOFLOW_REQUIRE(p >= 0 && p < n, "pinned vertex " + std::to_string(p) + " out of range");
    // delta(eta + d f) = delta eta + L f = 0; pinned rows are identity rows with f = 0.
    Eigen::MatrixXd rhs = -codifferential(n, E, w, eta);
    for (Index p : pinned) rhs.row(p).setZero();
    const Eigen::MatrixXd f = factor.solve(rhs);
    Eigen::MatrixXd omega = eta;
    for_each_column(E.rows(), omega.cols(), [&](Eigen::Index c) {
        double* out = omega.col(c).data();
        const double* fc = f.col(c).data();
        for (Eigen::Index e = 0; e < E.rows(); ++e) out[e] += fc[E(e, 1)] - fc[E(e, 0)];
    });
    return omega;
}

}  // namespace holoflow::kernels
