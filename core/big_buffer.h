#pragma once
/// @file Buffers of tens of megabytes (a CT series' voxels) that are filled once: sized with huge pages where
/// the kernel has them. Touching 50 MB for the first time takes 12,800 page faults of 4 KB but 25 of 2 MB,
/// and on a virtual machine a fault costs microseconds: half of a DICOM read's time went to them.
#include <cstddef>
#include <vector>

namespace isoforge {

/// Asks the kernel to back [data, data + bytes) with transparent huge pages (madvise MADV_HUGEPAGE on the
/// whole 2 MB pages inside it); nothing where it has none or the range is small. Call it before the first
/// touch.
void adviseHugePages(const void* data, std::size_t bytes);

/// Faults in the pages of [data, data + bytes) ahead of their first use, pieces of 8 MB at a time on TBB's
/// threads (madvise MADV_POPULATE_WRITE; nothing where the kernel lacks it, before Linux 5.14). A fresh
/// page is zeroed by the kernel when first touched, and on a virtual machine backed by the host then too:
/// 108 MB of mesh took 0.33 s on two threads against 0.44 s on one when the host had to back it, 25 ms
/// against 40 ms when it did not.
void prefault(const void* data, std::size_t bytes);

/// v.resize(n) for a large v that was empty, with its storage advised and faulted in first.
template <class T>
void resizeLarge(std::vector<T>& v, std::size_t n) {
    v.reserve(n);
    adviseHugePages(v.data(), n * sizeof(T));
    prefault(v.data(), n * sizeof(T));
    v.resize(n);
}

}  // namespace isoforge
