#pragma once

#include <cstddef>
#include <memory>

#include <Eigen/Core>

#include "holoflow/kernels/cotan_laplacian.h"

namespace holoflow::kernels {

//! Address space of one OpenBLAS work buffer on x86-64 (its BUFFER_SIZE, 32 << 22 bytes).
constexpr std::size_t kBlasWorkBufferBytes = std::size_t{128} << 20;
//! Work buffers one factorization or solve holds at once (a level-3 call takes two).
constexpr int kBlasWorkBuffersPerThread = 2;

//! \brief Makes OpenBLAS map `count` work buffers now and keep them for its later calls.
//! Under an address-space limit OpenBLAS 0.3.21 retries a buffer it cannot map forever (fixed
//! upstream in 0.3.30): taken at start-up, while the space is free, the buffers are reused by
//! every later call on any thread. The caller checks first that `count` buffers fit.
void reserve_blas_work_buffers(int count);

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
