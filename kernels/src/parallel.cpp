#include "holoflow/kernels/parallel.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace holoflow::par {

void for_each_range(std::size_t n, std::size_t grain,
                    const std::function<void(std::size_t, std::size_t)>& fn) {
    if (n == 0) return;
    if (n < grain) {
        fn(0, n);
        return;
    }
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, grain),
                      [&](const tbb::blocked_range<std::size_t>& r) { fn(r.begin(), r.end()); });
}

}  // namespace holoflow::par

namespace holoflow::par {

void for_each_index(std::size_t n, bool parallel, const std::function<void(std::size_t)>& fn) {
    for_each_range(n, parallel ? 1 : n + 1, [&](std::size_t begin, std::size_t end) {
        for (std::size_t i = begin; i < end; ++i) fn(i);
    });
}

void run_together(bool parallel, std::initializer_list<std::function<void()>> jobs) {
    for_each_index(jobs.size(), parallel, [&](std::size_t i) { jobs.begin()[i](); });
}

}  // namespace holoflow::par
