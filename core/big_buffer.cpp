#include "core/big_buffer.h"

#include <algorithm>
#include <cstdint>

#include <sys/mman.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace isoforge {

void adviseHugePages(const void* data, std::size_t bytes) {
#ifdef MADV_HUGEPAGE
    constexpr std::uintptr_t kHuge = std::uintptr_t(2) << 20;
    const std::uintptr_t begin = (reinterpret_cast<std::uintptr_t>(data) + kHuge - 1) & ~(kHuge - 1);
    const std::uintptr_t end = (reinterpret_cast<std::uintptr_t>(data) + bytes) & ~(kHuge - 1);
    // Advice only: a kernel without huge pages (or a range malloc did not map) refuses it, and nothing changes.
    if (end > begin) (void)::madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);
#else
    (void)data;
    (void)bytes;
#endif
}

void prefault(const void* data, std::size_t bytes) {
#ifdef MADV_POPULATE_WRITE
    constexpr std::uintptr_t kPage = 4096;
    constexpr std::size_t kPiece = std::size_t(8) << 20;
    const std::uintptr_t begin = (reinterpret_cast<std::uintptr_t>(data) + kPage - 1) & ~(kPage - 1);
    const std::uintptr_t end = (reinterpret_cast<std::uintptr_t>(data) + bytes) & ~(kPage - 1);
    if (end <= begin || end - begin < 2 * kPiece) return;  // one piece: the first touch does as well
    const std::size_t pieces = (end - begin + kPiece - 1) / kPiece;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, pieces, 1), [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t i = r.begin(); i < r.end(); ++i) {
            const std::uintptr_t from = begin + i * kPiece;
            const std::uintptr_t to = std::min<std::uintptr_t>(end, from + kPiece);
            // Advice only: where the kernel refuses it, the pages fault in on first touch as before.
            (void)::madvise(reinterpret_cast<void*>(from), to - from, MADV_POPULATE_WRITE);
        }
    });
#else
    (void)data;
    (void)bytes;
#endif
}

}  // namespace isoforge
