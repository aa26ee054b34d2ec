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
