#pragma once

#include <cstddef>
#include <limits>

namespace holoflow::engine {

//! The machine's memory, or the cgroup's limit (memory.max) where that is lower; 0 if unknown.
std::size_t physical_memory_bytes();

//! What an address-space limit (RLIMIT_AS, `ulimit -v`) leaves the solver, once planned.
struct AddressSpacePlan {
    unsigned threads = 1;  //!< threads that may solve at once, at most the wanted ones
    //! Address space left for the models' data: the rest of the limit (no limit: the maximum).
    std::size_t data_bytes = std::numeric_limits<std::size_t>::max();
};

//! \brief Prepares the sparse solver for the process's address-space limit, if one is set.
//! OpenBLAS hangs where it cannot map a work buffer (kernels::reserve_blas_work_buffers), so
//! under a limit the buffers of every solving thread are mapped now, and the threads are as many
//! as the limit affords next to their stacks and malloc arenas (results do not depend on the
//! thread count). Without a limit it does nothing and returns `wanted_threads`.
//! \throw ResourceLimit when not even one solving thread fits, naming the limit to raise.
AddressSpacePlan plan_address_space(unsigned wanted_threads);

//! \brief Makes malloc keep what the models free for their next allocations, where the plan
//! found no address-space limit. Each stage frees arrays that the next one, often on another
//! thread, allocates again; glibc hands them back to the system (blocks from 128 KiB are mapped
//! and unmapped, the heap's top is trimmed, each thread has its own arena), so every stage
//! faulted its memory in anew, and page faults are dear (2 to 12 us each on a paravirtualised
//! machine). One arena that keeps blocks up to 32 MiB and never trims reuses them. Call it
//! before the first worker thread starts. Under a limit nothing changes: a heap that keeps
//! freed memory could leave too little address space for a larger block.
void keep_freed_memory(const AddressSpacePlan& plan);

//! The memory the conformal stage may use without --max-memory: 3/4 of the machine's memory,
//! and 3/4 of the address space the plan leaves for data.
std::size_t default_memory_limit_bytes(const AddressSpacePlan& plan);

}  // namespace holoflow::engine
