#include "holoflow/engine/memory_limits.h"

#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <cstdlib>
#include <cstring>

#include <malloc.h>

namespace holoflow::engine {
namespace {

constexpr std::size_t kMiB = std::size_t{1} << 20;

char* touched_block(std::size_t bytes) {
    auto* p = static_cast<char*>(std::malloc(bytes));
    if (p != nullptr) std::memset(p, 1, bytes);
    return p;
}

std::size_t mapped_blocks() { return mallinfo2().hblks; }

// The sanitizers' allocators replace glibc's and ignore its settings.
#if !defined(__SANITIZE_ADDRESS__) && !defined(__SANITIZE_THREAD__)
TEST(KeepFreedMemory, BlocksUpTo32MiBComeFromTheHeapAndStayThereUnlessAnAddressSpaceLimitIsSet) {
    // glibc's start-up mmap threshold, held fixed: a test before this one in the same process
    // may have raised it (glibc raises it to the size of each mapped block freed, up to 32 MiB).
    mallopt(M_MMAP_THRESHOLD, 128 * 1024);
    AddressSpacePlan limited;
    limited.data_bytes = std::size_t{1} << 30;
    keep_freed_memory(limited);  // nothing changes: glibc maps a block this large
    const std::size_t mapped_before = mapped_blocks();
    char* block = touched_block(24 * kMiB);
    ASSERT_NE(block, nullptr);
    EXPECT_EQ(mapped_blocks(), mapped_before + 1);
    std::free(block);

    keep_freed_memory(AddressSpacePlan{});  // no limit
    std::array<char*, 4> blocks{};
    for (char*& b : blocks) {
        b = touched_block(28 * kMiB);
        ASSERT_NE(b, nullptr);
    }
    EXPECT_EQ(mapped_blocks(), mapped_before);  // from the heap
    for (char* b : blocks) std::free(b);
    // 112 MiB free at the heap's top, more than glibc would keep there (twice its threshold)
    EXPECT_GE(mallinfo2().fordblks, blocks.size() * 28 * kMiB);
    block = touched_block(28 * kMiB);
    ASSERT_NE(block, nullptr);
    EXPECT_EQ(mapped_blocks(), mapped_before);
    std::free(block);
}
#endif

}  // namespace
}  // namespace holoflow::engine
