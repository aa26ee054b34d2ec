#include "holoflow/engine/factorization_cache.h"

namespace holoflow::engine {
namespace {

// splitmix64 finaliser: mixes each word so that permuted patterns hash apart.
std::uint64_t mix(std::uint64_t h, std::uint64_t word) {
    std::uint64_t z = h + 0x9e3779b97f4a7c15ULL + word;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

}  // namespace

std::uint64_t pattern_hash(const kernels::LaplacianMatrix& A) {
    std::uint64_t h = mix(0, static_cast<std::uint64_t>(A.n));
    for (Index s : A.col_start) h = mix(h, static_cast<std::uint64_t>(s));
    for (Index r : A.row) h = mix(h, static_cast<std::uint64_t>(r));
    return h;
}

std::shared_ptr<const kernels::CholeskySymbolic> FactorizationCache::analysis(
    const kernels::LaplacianMatrix& A) {
    const std::uint64_t key = pattern_hash(A);
    {
        const std::lock_guard lock(mutex_);
        for (auto it = entries_.begin(); it != entries_.end(); ++it) {
            if (it->first == key && it->second->matches(A)) {
                entries_.splice(entries_.begin(), entries_, it);
                ++stats_.hits;
                return it->second;
            }
        }
        ++stats_.misses;
    }
    // Analysed outside the lock: other models keep going (two concurrent misses on one pattern
    // both analyse; the results are identical).
    auto symbolic = kernels::CholeskySymbolic::analyse(A);
    if (capacity_ > 0) {
        const std::lock_guard lock(mutex_);
        entries_.emplace_front(key, symbolic);
        while (entries_.size() > capacity_) entries_.pop_back();
    }
    return symbolic;
}

FactorizationCache::Stats FactorizationCache::stats() const {
    const std::lock_guard lock(mutex_);
    return stats_;
}

}  // namespace holoflow::engine
