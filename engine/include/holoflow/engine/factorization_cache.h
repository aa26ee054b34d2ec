#pragma once

#include <cstddef>
#include <cstdint>
#include <list>
#include <memory>
#include <mutex>
#include <utility>

#include "holoflow/kernels/cholesky.h"
#include "holoflow/kernels/cotan_laplacian.h"

namespace holoflow::engine {

//! Hash of a Laplacian's sparsity pattern (size, column starts, row indices; values ignored):
//! equal for every model with the same connectivity, e.g. the poses of one mesh.
std::uint64_t pattern_hash(const kernels::LaplacianMatrix& A);

//! Symbolic Cholesky analyses shared across the models of a batch, keyed by pattern_hash and
//! checked with CholeskySymbolic::matches, so a hash collision costs a fresh analysis, never a
//! wrong one. The AMD ordering is a function of the pattern alone, so a reused analysis gives the
//! same factor bits as a fresh one. Thread-safe; least recently used entries are dropped beyond
//! `capacity`. The numeric factor is per model and not cached here.
class FactorizationCache {
  public:
    struct Stats {
        std::size_t hits = 0;
        std::size_t misses = 0;
    };

    explicit FactorizationCache(std::size_t capacity = 8) : capacity_(capacity) {}

    //! The analysis of A's pattern: a cached one, or a new one (cached). \throw as analyse().
    std::shared_ptr<const kernels::CholeskySymbolic> analysis(const kernels::LaplacianMatrix& A);

    Stats stats() const;

  private:
    using Entry = std::pair<std::uint64_t, std::shared_ptr<const kernels::CholeskySymbolic>>;
    std::size_t capacity_;
    mutable std::mutex mutex_;
    std::list<Entry> entries_;  // most recently used first
    Stats stats_;
};

}  // namespace holoflow::engine
