#include "core/warm_heap.h"

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cstdlib>
#include <functional>
#include <vector>

#include <malloc.h>

#include "core/big_buffer.h"

namespace isoforge {

namespace {

std::atomic<bool> enabled{false};

// glibc takes a request from the heap below M_MMAP_THRESHOLD, whose largest accepted value on 64-bit
// systems is 32 MB (half of HEAP_MAX_SIZE); larger requests would be mapped on their own.
constexpr std::size_t kBlock = std::size_t(32) << 20;
constexpr std::size_t kMinimum = std::size_t(16) << 20;
constexpr std::size_t kMaximum = std::size_t(8) << 30;  // beyond it, the rest is faulted in as usual

}  // namespace

void setWarmHeapEnabled(bool on) {
    enabled.store(on);
}

WarmHeap::WarmHeap(std::size_t bytes) {
    if (!enabled.load() || bytes < kMinimum) return;
    active_ = true;
    ::mallopt(M_MMAP_THRESHOLD, int(kBlock));
    ::mallopt(M_TRIM_THRESHOLD, int(1) << 30);  // keep the grown top until the burst is over
    const std::size_t request = kBlock - 4096;  // under the threshold, with room for malloc's header
    std::vector<void*> blocks;                  // reserved first: its own storage must not land between the blocks
    blocks.reserve(std::min(bytes, kMaximum) / request + 1);
    for (std::size_t done = 0; done < std::min(bytes, kMaximum); done += request) {
        void* p = std::malloc(request);
        if (!p) break;
        blocks.push_back(p);
    }
    // The blocks follow each other at the heap's top: advice over each run of adjacent blocks, the seams
    // between them included (a block that came from elsewhere is advised alone).
    std::sort(blocks.begin(), blocks.end(), std::less<void*>());
    for (std::size_t i = 0; i < blocks.size();) {
        std::size_t j = i + 1;
        const auto at = [&](std::size_t k) { return reinterpret_cast<std::uintptr_t>(blocks[k]); };
        while (j < blocks.size() && at(j) - at(j - 1) - request <= 64) ++j;
        adviseHugePages(blocks[i], at(j - 1) + request - at(i));
        i = j;
    }
    // Freed in address order, the blocks merge with each other and the last with the top.
    for (void* p : blocks) std::free(p);
}

WarmHeap::~WarmHeap() {
    if (!active_) return;
    ::mallopt(M_TRIM_THRESHOLD, int(2 * kBlock));
    ::mallopt(M_MMAP_THRESHOLD, int(kBlock));
}

}  // namespace isoforge
