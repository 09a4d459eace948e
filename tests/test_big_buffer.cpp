#include <sys/mman.h>
#include <unistd.h>

#include <cstdint>
#include <vector>

#include <gtest/gtest.h>

#include "core/big_buffer.h"

using namespace isoforge;

namespace {
/// How many of the pages of [data, data + bytes) are resident (mincore).
std::size_t residentPages(const void* data, std::size_t bytes) {
    const std::uintptr_t page = std::uintptr_t(::sysconf(_SC_PAGESIZE));
    const std::uintptr_t begin = reinterpret_cast<std::uintptr_t>(data) & ~(page - 1);
    const std::uintptr_t end = reinterpret_cast<std::uintptr_t>(data) + bytes;
    std::vector<unsigned char> in((end - begin + page - 1) / page);
    if (::mincore(reinterpret_cast<void*>(begin), end - begin, in.data()) != 0) return 0;
    std::size_t n = 0;
    for (unsigned char c : in) n += c & 1;
    return n;
}
}  // namespace

TEST(BigBuffer, PrefaultMakesEveryWholePageResidentBeforeTheFirstTouch) {
    // resizeLarge faults a large buffer in on TBB's threads before resize zeroes it on one
    // (core/big_buffer.h). 100 MB reserved, untouched: few pages resident; prefaulted: all whole pages.
    {
        void* probe = ::mmap(nullptr, 4096, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
        ASSERT_NE(probe, MAP_FAILED);
        const int rc = ::madvise(probe, 4096, MADV_POPULATE_WRITE);
        ::munmap(probe, 4096);
        if (rc != 0) GTEST_SKIP() << "this kernel has no MADV_POPULATE_WRITE (Linux 5.14)";
    }
    const std::size_t bytes = std::size_t(100) << 20;
    std::vector<char> v;
    v.reserve(bytes);  // a mapping of its own (far above malloc's mmap threshold), not yet touched
    const std::size_t pages = bytes / std::size_t(::sysconf(_SC_PAGESIZE));
    ASSERT_LT(residentPages(v.data(), bytes), pages / 2);
    adviseHugePages(v.data(), bytes);
    prefault(v.data(), bytes);
    EXPECT_GE(residentPages(v.data(), bytes), pages - 1);
    v.resize(bytes);  // and the buffer is an ordinary one afterwards
    EXPECT_EQ(v[bytes / 2], 0);
}
