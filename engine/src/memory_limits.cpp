#include "holoflow/engine/memory_limits.h"

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <string>

#include <malloc.h>

#include <sys/resource.h>
#include <unistd.h>

#include "holoflow/engine/conformal_pipeline.h"
#include "holoflow/kernels/cholesky.h"

namespace holoflow::engine {
namespace {

constexpr std::size_t kMiB = std::size_t{1} << 20;
//! A thread past the first: its stack (8 MiB by default) and glibc's malloc arena (64 MiB).
constexpr std::size_t kThreadBytes = 72 * kMiB;
//! glibc's largest mmap threshold: larger blocks are always mapped, and unmapped when freed
//! (keeping those in the heap too made the peak memory of a model with hundreds of forms 30 %
//! larger: the freed blocks did not fit the next ones).
constexpr std::size_t kLargestHeapBlock = 32 * kMiB;
//! The least address space worth running with for the data itself.
constexpr std::size_t kMinDataBytes = 32 * kMiB;

std::size_t process_size_bytes() {
    std::ifstream statm("/proc/self/statm");
    std::size_t pages = 0;
    statm >> pages;
    const long page = sysconf(_SC_PAGE_SIZE);
    return pages * static_cast<std::size_t>(page > 0 ? page : 4096);
}

//! Address space `threads` solving threads need beyond the process's present size.
std::size_t solver_bytes(unsigned threads) {
    return threads * (kernels::kBlasWorkBuffersPerThread * kernels::kBlasWorkBufferBytes) +
           (threads - 1) * kThreadBytes;
}

}  // namespace

std::size_t physical_memory_bytes() {
    const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGE_SIZE);
    std::size_t bytes = pages > 0 && page > 0 ? static_cast<std::size_t>(pages) * static_cast<std::size_t>(page) : 0;
    std::ifstream cgroup("/sys/fs/cgroup/memory.max");
    std::size_t limit = 0;
    if (cgroup >> limit && limit > 0 && (bytes == 0 || limit < bytes)) bytes = limit;  // "max" reads as no number
    return bytes;
}

AddressSpacePlan plan_address_space(unsigned wanted_threads) {
    AddressSpacePlan plan;
    plan.threads = std::max(1u, wanted_threads);
    rlimit limit{};
    if (getrlimit(RLIMIT_AS, &limit) != 0 || limit.rlim_cur == RLIM_INFINITY) return plan;
    const std::size_t used = process_size_bytes();
    const std::size_t free = limit.rlim_cur > used ? limit.rlim_cur - used : 0;
    while (plan.threads > 1 && solver_bytes(plan.threads) + kMinDataBytes > free) --plan.threads;
    const std::size_t needed = solver_bytes(plan.threads) + kMinDataBytes;
    // The estimate misses what the allocator rounds up: a probe of the buffers' whole span
    // (never touched, so it costs no memory) is what tells, before OpenBLAS is asked.
    const std::size_t buffers = std::size_t(plan.threads) * kernels::kBlasWorkBuffersPerThread;
    void* probe = needed <= free ? std::malloc(buffers * (kernels::kBlasWorkBufferBytes + kMiB)) : nullptr;
    if (probe == nullptr)
        throw ResourceLimit("the address-space limit (ulimit -v) of " + std::to_string(limit.rlim_cur / kMiB) +
                            " MiB leaves " + std::to_string(free / kMiB) + " MiB free; the sparse solver needs " +
                            std::to_string(needed / kMiB) + " MiB for its BLAS work buffers and data: raise it to at least " +
                            std::to_string((used + needed) / kMiB + 1) + " MiB");
    std::free(probe);
    kernels::reserve_blas_work_buffers(static_cast<int>(buffers));
    plan.data_bytes = free - solver_bytes(plan.threads);
    return plan;
}

void keep_freed_memory(const AddressSpacePlan& plan) {
    if (plan.data_bytes != std::numeric_limits<std::size_t>::max()) return;
    mallopt(M_ARENA_MAX, 1);
    mallopt(M_MMAP_THRESHOLD, static_cast<int>(kLargestHeapBlock));
    mallopt(M_TRIM_THRESHOLD, -1);  // never
}

std::size_t default_memory_limit_bytes(const AddressSpacePlan& plan) {
    return std::min(physical_memory_bytes(), plan.data_bytes) / 4 * 3;
}

}  // namespace holoflow::engine
