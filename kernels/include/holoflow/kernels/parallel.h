#pragma once

#include <cstddef>
#include <functional>

namespace holoflow::par {

//! Calls fn(begin, end) on disjoint subranges covering [0, n); runs on oneTBB workers when n is
//! at least `grain`, serially otherwise. Kernel headers stay free of TBB.
void for_each_range(std::size_t n, std::size_t grain,
                    const std::function<void(std::size_t, std::size_t)>& fn);

}  // namespace holoflow::par
