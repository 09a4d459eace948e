#pragma once
/// @file A stretch of the heap made ready, with huge pages, for a burst of small allocations.
///
/// Reading a .vdb file allocates its tree a leaf at a time (2 KB of values and a node each), from the top of
/// malloc's heap, which grows by a few pages at a time: every 4 KB page is faulted in on first touch. On a
/// virtual machine a fault costs microseconds, and reading a 45 MB level set (64,800 leaves, 140 MB of tree)
/// spent two thirds of its time in 38,000 of them. glibc backs its heap with transparent huge pages only when
/// told so before the process starts (GLIBC_TUNABLES=glibc.malloc.hugetlb=1), and then for every allocation
/// of the process. A WarmHeap does it for one burst: it grows the heap by the expected amount in blocks of
/// 32 MB, asks for huge pages on them (madvise, core/big_buffer.h), and hands them back to malloc's top,
/// which the burst then splits with 2 MB faults instead of 4 KB ones. Memory never touched stays unbacked.
#include <cstddef>

namespace isoforge {

class WarmHeap {
public:
    /// Readies about `bytes` of this thread's heap; nothing when `bytes` is small (under 16 MB) or warming
    /// is off (setWarmHeapEnabled).
    explicit WarmHeap(std::size_t bytes);
    /// Leaves malloc's thresholds where glibc's own dynamic ones stand after a 32 MB block was freed (a
    /// request up to 32 MB comes from the heap; up to 64 MB of free top is kept).
    ~WarmHeap();
    WarmHeap(const WarmHeap&) = delete;
    WarmHeap& operator=(const WarmHeap&) = delete;

private:
    bool active_ = false;
};

/// Whether WarmHeap does anything: off by default, since it sets malloc's thresholds for the whole process.
/// The command-line tool turns it on; a library user (the Python module) keeps malloc as the host set it.
void setWarmHeapEnabled(bool on);

}  // namespace isoforge
