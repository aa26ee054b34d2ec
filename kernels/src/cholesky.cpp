#include "holoflow/kernels/cholesky.h"

#include <dlfcn.h>

#include <cmath>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include <cholmod.h>

#include "holoflow/kernels/errors.h"

extern "C" void openblas_set_num_threads(int);
extern "C" void* blas_memory_alloc(int);  // OpenBLAS's buffer pool (exported, undocumented)
extern "C" void blas_memory_free(void*);

namespace {

//! CHOLMOD calls on this thread in progress (a Common alive: every call goes through one).
thread_local int cholmod_calls = 0;

}  // namespace

//! CHOLMOD 3 (Debian's SuiteSparse 5, built with OpenMP) wraps small loops of its supernodal
//! factorization in `omp parallel for` regions of up to 4 threads. Such threads would stack on
//! busy oneTBB workers, so CHOLMOD's regions run on their caller. Serialised by libgomp, a region
//! still cost a one-thread team whose barrier ends in a futex system call: 39k of them in one
//! factorization of a 100k-face mesh, most of its time on this machine. Defined in the program,
//! this entry point of GCC's OpenMP ABI (the only one CHOLMOD calls besides omp_get_num_threads
//! and omp_get_thread_num, which then report the one thread) takes precedence over libgomp's:
//! inside a CHOLMOD call it runs the region's body once on the calling thread, what a one-thread
//! team ran; any other caller gets libgomp's own.
extern "C" void GOMP_parallel(void (*body)(void*), void* data, unsigned num_threads, unsigned flags) {
    if (cholmod_calls > 0) return body(data);
    using Entry = void (*)(void (*)(void*), void*, unsigned, unsigned);
    static const auto libgomp = reinterpret_cast<Entry>(dlsym(RTLD_NEXT, "GOMP_parallel"));
    if (libgomp != nullptr) return libgomp(body, data, num_threads, flags);
    body(data);
}

//! CHOLMOD 3's supernodal factorization reads the clock before and after each of its BLAS calls,
//! only to sum times into cholmod_common fields we never read. On a virtual machine's clock two
//! reads per call were 8 % of a factorization (perf, turbine after one Loop step). Defined in the
//! program like GOMP_parallel above, this takes precedence over SuiteSparse's: inside a CHOLMOD
//! call it returns 0 without reading the clock; any other caller gets SuiteSparse's own.
extern "C" double SuiteSparse_time(void) {
    if (cholmod_calls > 0) return 0;
    using Entry = double (*)();
    static const auto suitesparse = reinterpret_cast<Entry>(dlsym(RTLD_NEXT, "SuiteSparse_time"));
    return suitesparse != nullptr ? suitesparse() : 0;
}

namespace holoflow::kernels {
namespace {

//! One BLAS thread: callers parallelise over meshes and right-hand sides, and a single thread
//! keeps every BLAS reduction in a fixed order (same bits on any machine load). CHOLMOD's own
//! OpenMP regions run on their caller (GOMP_parallel above).
void pin_blas_threads() {
    static std::once_flag once;
    std::call_once(once, [] { openblas_set_num_threads(1); });
}

}  // namespace

void reserve_blas_work_buffers(int count) {
    pin_blas_threads();
    std::vector<void*> buffers;
    for (int k = 0; k < count; ++k) buffers.push_back(blas_memory_alloc(0));  // all held at once
    for (void* buffer : buffers) blas_memory_free(buffer);  // back in the pool, still mapped
}

namespace {

//! A configured cholmod_common. Not thread-safe, so each call builds its own: start/finish only
//! set fields and free workspace (well under a microsecond next to any solve).
class Common {
  public:
    Common() {
        ++cholmod_calls;
        cholmod_start(&c_);  // fails only for a null pointer
        c_.nmethods = 1;     // AMD only: the default also tries METIS, slower at every size
        c_.method[0].ordering = CHOLMOD_AMD;
        c_.postorder = 1;
        c_.supernodal = CHOLMOD_SUPERNODAL;
        c_.quick_return_if_not_posdef = 1;
        c_.print = 0;  // failures become exceptions, never prints
        c_.error_handler = nullptr;
        c_.useGPU = 0;
    }
    ~Common() {
        cholmod_finish(&c_);
        --cholmod_calls;
    }
    Common(const Common&) = delete;
    Common& operator=(const Common&) = delete;

    cholmod_common* get() { return &c_; }

    //! Throws SolverFailure naming the step if CHOLMOD reported an error (status < 0).
    void check(const char* step, bool result_ok) const {
        if (c_.status >= 0 && result_ok) return;
        std::string reason;
        switch (c_.status) {
            case CHOLMOD_OUT_OF_MEMORY:
                reason = "out of memory";
                break;
            case CHOLMOD_TOO_LARGE:
                reason = "problem too large";
                break;
            case CHOLMOD_INVALID:
                reason = "invalid input";
                break;
            case CHOLMOD_NOT_INSTALLED:
                reason = "method not installed";
                break;
            default:
                reason = "status " + std::to_string(c_.status);
                break;
        }
        throw SolverFailure(std::string(step) + ": CHOLMOD failed (" + reason + ")");
    }

  private:
    cholmod_common c_;
};

//! Owns a cholmod_factor; frees it with a private common (no shared mutable state).
struct FactorHandle {
    cholmod_factor* L = nullptr;
    FactorHandle() = default;
    explicit FactorHandle(cholmod_factor* f) : L(f) {}
    FactorHandle(const FactorHandle&) = delete;
    FactorHandle& operator=(const FactorHandle&) = delete;
    ~FactorHandle() {
        if (L == nullptr) return;
        Common c;
        cholmod_free_factor(&L, c.get());
    }
};

//! Owns a cholmod_dense allocated by the given common.
struct DenseHandle {
    cholmod_dense* X = nullptr;
    cholmod_common* common = nullptr;
    DenseHandle(cholmod_dense* x, cholmod_common* c) : X(x), common(c) {}
    DenseHandle(const DenseHandle&) = delete;
    DenseHandle& operator=(const DenseHandle&) = delete;
    ~DenseHandle() {
        if (X != nullptr) cholmod_free_dense(&X, common);
    }
};

enum class Stored { Upper = 1, Lower = -1 };

//! Non-owning CHOLMOD view of one triangle of a symmetric CSC matrix with sorted rows (CHOLMOD
//! reads it only); without values, the pattern only.
cholmod_sparse symmetric_view(const std::vector<Index>& col_start, const std::vector<Index>& row,
                              const double* value, Stored stored) {
    cholmod_sparse s{};
    s.nrow = s.ncol = col_start.size() - 1;
    s.nzmax = row.size();
    s.p = const_cast<Index*>(col_start.data());
    s.i = const_cast<Index*>(row.data());
    s.nz = nullptr;
    s.x = const_cast<double*>(value);
    s.z = nullptr;
    s.stype = static_cast<int>(stored);
    s.itype = CHOLMOD_INT;
    s.xtype = value != nullptr ? CHOLMOD_REAL : CHOLMOD_PATTERN;
    s.dtype = CHOLMOD_DOUBLE;
    s.sorted = 1;
    s.packed = 1;
    return s;
}

void require(bool condition, const std::string& message) {
    if (!condition) throw InvalidInput("analyse: " + message);
}

void require_valid_pattern(const LaplacianMatrix& A) {
    require(A.n > 0, "empty matrix");
    require(A.col_start.size() == static_cast<std::size_t>(A.n) + 1 && A.col_start.front() == 0 &&
                static_cast<std::size_t>(A.col_start.back()) == A.row.size() &&
                A.value.size() == A.row.size(),
            "inconsistent CSC arrays");
    for (Index j = 0; j < A.n; ++j) {
        const Index begin = A.col_start[j], end = A.col_start[j + 1];
        bool ok = begin < end && A.row[end - 1] == j && A.row[begin] >= 0;
        for (Index s = begin + 1; ok && s < end; ++s) ok = A.row[s - 1] < A.row[s];
        if (!ok)
            require(false, "column " + std::to_string(j) +
                               " is not sorted upper-triangular ending with its diagonal");
    }
}

}  // namespace

struct CholeskySymbolic::Impl {
    Index n = 0;
    std::vector<Index> col_start, row;  // the analysed pattern, for matches()
    FactorHandle symbolic;
    //! The lower triangle of P A P^T (P the analysis' ordering), the matrix CHOLMOD's supernodal
    //! factorization reads, in CSC with sorted rows. Its entry k is A's entry `from[k]`, so a
    //! factorization gathers its values instead of transposing A (what cholmod_factorize would
    //! do at every call: 9 % of its time on a 74k-face mesh).
    std::vector<Index> permuted_start, permuted_row, from;
};

struct CholeskyFactor::Impl {
    std::shared_ptr<const CholeskySymbolic> symbolic;
    FactorHandle numeric;
};

namespace {

//! Fills the permuted lower triangle of `impl` from its pattern and the analysis' ordering: a
//! counting sort of the entries by row, then by column, which leaves each column's rows sorted.
void permute_lower(CholeskySymbolic::Impl& impl) {
    const auto n = static_cast<std::size_t>(impl.n);
    const auto* perm = static_cast<const Index*>(impl.symbolic.L->Perm);
    std::vector<Index> inverse(n);
    for (std::size_t k = 0; k < n; ++k) inverse[perm[k]] = static_cast<Index>(k);
    const std::size_t entries = impl.row.size();
    // Pass 1: the entries grouped by their permuted row (the larger of the two indices).
    std::vector<Index> by_row_start(n + 1, 0), by_row_column(entries), by_row_from(entries);
    std::vector<Index> permuted_column(entries), permuted_row(entries);
    for (Index j = 0; j < impl.n; ++j)
        for (Index s = impl.col_start[j]; s < impl.col_start[j + 1]; ++s) {
            const Index a = inverse[j], b = inverse[impl.row[s]];
            permuted_row[s] = std::max(a, b);
            permuted_column[s] = std::min(a, b);
            ++by_row_start[permuted_row[s] + 1];
        }
    for (std::size_t k = 0; k < n; ++k) by_row_start[k + 1] += by_row_start[k];
    std::vector<Index> next(by_row_start.begin(), by_row_start.end() - 1);
    for (std::size_t s = 0; s < entries; ++s) {
        const Index slot = next[permuted_row[s]]++;
        by_row_column[slot] = permuted_column[s];
        by_row_from[slot] = static_cast<Index>(s);
    }
    // Pass 2: grouped by column, visiting rows in increasing order.
    impl.permuted_start.assign(n + 1, 0);
    for (std::size_t s = 0; s < entries; ++s) ++impl.permuted_start[permuted_column[s] + 1];
    for (std::size_t k = 0; k < n; ++k) impl.permuted_start[k + 1] += impl.permuted_start[k];
    next.assign(impl.permuted_start.begin(), impl.permuted_start.end() - 1);
    impl.permuted_row.resize(entries);
    impl.from.resize(entries);
    for (Index r = 0; r < impl.n; ++r)
        for (Index t = by_row_start[r]; t < by_row_start[r + 1]; ++t) {
            const Index slot = next[by_row_column[t]]++;
            impl.permuted_row[slot] = r;
            impl.from[slot] = by_row_from[t];
        }
}

}  // namespace

CholeskySymbolic::CholeskySymbolic(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
CholeskySymbolic::~CholeskySymbolic() = default;

std::shared_ptr<const CholeskySymbolic> CholeskySymbolic::analyse(const LaplacianMatrix& A) {
    require_valid_pattern(A);
    pin_blas_threads();
    auto impl = std::make_unique<Impl>();
    impl->n = A.n;
    impl->col_start = A.col_start;
    impl->row = A.row;
    Common c;
    cholmod_sparse view = symmetric_view(A.col_start, A.row, nullptr, Stored::Upper);
    impl->symbolic.L = cholmod_analyze(&view, c.get());
    c.check("analyse", impl->symbolic.L != nullptr);
    if (!impl->symbolic.L->is_super)
        throw SolverFailure("analyse: CHOLMOD returned a simplicial analysis");
    permute_lower(*impl);
    return std::shared_ptr<const CholeskySymbolic>(new CholeskySymbolic(std::move(impl)));
}

std::size_t CholeskySymbolic::factor_nonzeros() const { return impl_->symbolic.L->xsize; }

bool CholeskySymbolic::matches(const LaplacianMatrix& A) const {
    return A.n == impl_->n && A.col_start == impl_->col_start && A.row == impl_->row;
}

Index CholeskySymbolic::size() const { return impl_->n; }

CholeskyFactor::CholeskyFactor(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
CholeskyFactor::~CholeskyFactor() = default;

std::shared_ptr<const CholeskyFactor> CholeskyFactor::factorize(
    std::shared_ptr<const CholeskySymbolic> symbolic, const LaplacianMatrix& A) {
    HOLOFLOW_REQUIRE(symbolic != nullptr, "no symbolic analysis");
    HOLOFLOW_REQUIRE(symbolic->matches(A), "matrix pattern differs from the analysed one");
    HOLOFLOW_REQUIRE(A.value.size() == A.row.size(), "matrix has no values");
    const CholeskySymbolic::Impl& analysis = *symbolic->impl_;
    std::vector<double> permuted_value(analysis.from.size());
    for (std::size_t k = 0; k < permuted_value.size(); ++k) permuted_value[k] = A.value[analysis.from[k]];
    for (Index j = 0; j < A.n; ++j)
        for (Index s = A.col_start[j]; s < A.col_start[j + 1]; ++s)
            if (!std::isfinite(A.value[s]))
                throw SolverFailure("factorize: matrix entry (" + std::to_string(A.row[s]) + ", " +
                                    std::to_string(j) + ") is not finite");
    pin_blas_threads();

    auto impl = std::make_unique<Impl>();
    Common c;
    // The analysis stays untouched (shared by concurrent factorizations): work on a copy.
    impl->numeric.L = cholmod_copy_factor(analysis.symbolic.L, c.get());
    c.check("factorize (copy analysis)", impl->numeric.L != nullptr);
    cholmod_sparse permuted =
        symmetric_view(analysis.permuted_start, analysis.permuted_row, permuted_value.data(), Stored::Lower);
    double no_shift[2] = {0, 0};
    const int ok = cholmod_super_numeric(&permuted, nullptr, no_shift, impl->numeric.L, c.get());
    c.check("factorize", ok != 0);
    const cholmod_factor* L = impl->numeric.L;
    if (c.get()->status == CHOLMOD_NOT_POSDEF || L->minor < L->n) {
        const auto* perm = static_cast<const Index*>(L->Perm);
        const std::size_t k = L->minor < L->n ? L->minor : 0;
        throw SolverFailure("factorize: matrix is not positive definite (pivot " +
                            std::to_string(k) + ", row " + std::to_string(perm[k]) + ")");
    }
    if (!L->is_super || !L->is_ll || L->xtype != CHOLMOD_REAL)
        throw SolverFailure("factorize: CHOLMOD returned an unexpected factor type");
    impl->symbolic = std::move(symbolic);
    return std::shared_ptr<const CholeskyFactor>(new CholeskyFactor(std::move(impl)));
}

Eigen::MatrixXd CholeskyFactor::solve(const Eigen::MatrixXd& B) const {
    const Index n = size();
    HOLOFLOW_REQUIRE(B.rows() == n, "right-hand side has " + std::to_string(B.rows()) +
                                        " rows, matrix has " + std::to_string(n));
    if (B.cols() == 0) return Eigen::MatrixXd(n, 0);
    pin_blas_threads();

    Common c;  // per call: a cholmod_common is not thread-safe, the factor is only read
    cholmod_dense b{};
    b.nrow = static_cast<std::size_t>(n);
    b.ncol = static_cast<std::size_t>(B.cols());
    b.nzmax = b.nrow * b.ncol;
    b.d = b.nrow;
    b.x = const_cast<double*>(B.data());  // read only by cholmod_solve
    b.z = nullptr;
    b.xtype = CHOLMOD_REAL;
    b.dtype = CHOLMOD_DOUBLE;
    DenseHandle x(cholmod_solve(CHOLMOD_A, impl_->numeric.L, &b, c.get()), c.get());
    c.check("solve", x.X != nullptr);

    Eigen::MatrixXd X =
        Eigen::Map<const Eigen::MatrixXd>(static_cast<const double*>(x.X->x), n, B.cols());
    if (!X.allFinite()) {
        Eigen::Index bad_row = 0, bad_col = 0;
        (!X.array().isFinite()).maxCoeff(&bad_row, &bad_col);
        throw SolverFailure("solve: solution entry (" + std::to_string(bad_row) + ", " +
                            std::to_string(bad_col) + ") is not finite");
    }
    return X;
}

Index CholeskyFactor::size() const { return impl_->symbolic->size(); }

const std::shared_ptr<const CholeskySymbolic>& CholeskyFactor::symbolic() const {
    return impl_->symbolic;
}

}  // namespace holoflow::kernels
