#pragma once

#include <cstddef>
#include <memory>

#include <Eigen/Core>

#include "holoflow/kernels/cotan_laplacian.h"

namespace holoflow::kernels {

//! Symbolic analysis (AMD ordering, supernodal structure) of a sparse Cholesky factorization:
//! reusable for every matrix with the same pattern (pose collections refactor numerically only).
//! Immutable after analyse(); any number of threads may factorize with it at once.
class CholeskySymbolic {
  public:
    struct Impl;

    //! \brief Orders (AMD only) and analyses the pattern of A; its values are not read.
    //! \throw InvalidInput on a malformed pattern, SolverFailure if CHOLMOD fails.
    static std::shared_ptr<const CholeskySymbolic> analyse(const LaplacianMatrix& A);

    //! Entries the numeric supernodal factor will store (8 bytes each): a memory estimate.
    std::size_t factor_nonzeros() const;
    //! True if A has the analysed size and pattern (its values may differ).
    bool matches(const LaplacianMatrix& A) const;
    //! Matrix size n.
    Index size() const;

    ~CholeskySymbolic();
    CholeskySymbolic(const CholeskySymbolic&) = delete;
    CholeskySymbolic& operator=(const CholeskySymbolic&) = delete;

  private:
    explicit CholeskySymbolic(std::unique_ptr<Impl> impl);
    std::unique_ptr<Impl> impl_;
    friend class CholeskyFactor;
};

//! Numeric supernodal LL^T factor of a symmetric positive definite LaplacianMatrix (CHOLMOD with
//! OpenBLAS, BLAS threads pinned to 1). Read-only: solve() may run from several threads at once.
class CholeskyFactor {
  public:
    struct Impl;

    //! \brief Factorizes A with the analysis of its pattern.
    //! \throw InvalidInput if symbolic is null or does not match A's pattern; SolverFailure if A
    //! has a non-finite value, is not positive definite, or CHOLMOD fails (message names the step).
    static std::shared_ptr<const CholeskyFactor> factorize(
        std::shared_ptr<const CholeskySymbolic> symbolic, const LaplacianMatrix& A);

    //! \brief Solves A X = B for all columns of B in one CHOLMOD call (one triangular sweep).
    //! Thread-safe; same bits on any thread.
    //! \throw InvalidInput if B has the wrong row count; SolverFailure if the solution is not
    //! finite or CHOLMOD fails.
    Eigen::MatrixXd solve(const Eigen::MatrixXd& B) const;

    //! Matrix size n.
    Index size() const;
    //! The analysis this factor was computed with.
    const std::shared_ptr<const CholeskySymbolic>& symbolic() const;

    ~CholeskyFactor();
    CholeskyFactor(const CholeskyFactor&) = delete;
    CholeskyFactor& operator=(const CholeskyFactor&) = delete;

  private:
    explicit CholeskyFactor(std::unique_ptr<Impl> impl);
    std::unique_ptr<Impl> impl_;
};

}  // namespace holoflow::kernels
