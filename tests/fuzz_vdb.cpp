/// libFuzzer target for .vdb files, read by OpenVDB under us (isoforge::volume::readVdb checks the layout
/// OpenVDB trusts: length fields, counts, offsets) and then used as isoforge uses them: every grid
/// summarized as `isoforge info` does, and the float grid converted to a dense volume as readVolume does.
/// Any input must give grids or an IoError/ResourceError naming the file; never a crash, a hang, or memory
/// the file cannot justify (libFuzzer's -rss_limit_mb).
///
/// OpenVDB allocates a voxel buffer's claimed compressed size before reading it: an absurd claim (64 GB) is
/// a bad_alloc in a release build, which readVdb turns into an IoError. AddressSanitizer's operator new
/// cannot throw and ends the process instead, so this target replaces operator new with one that throws
/// when malloc (ASan's, with allocator_may_return_null) fails, as the release allocator does; scripts/fuzz.sh
/// raises libFuzzer's single-allocation limit for it, while the resident-memory limit stays.
/// Build: cmake -DISOFORGE_FUZZ=ON with clang (see scripts/fuzz.sh).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <new>

#include "core/error.h"
#include "fuzz_file.h"
#include "volume/dense_volume.h"
#include "volume/vdb_io.h"

// alloc_dealloc_mismatch=0: what the replaced operator new hands out is malloc's, whichever delete frees it.
extern "C" const char* __asan_default_options() {
    return "allocator_may_return_null=1:alloc_dealloc_mismatch=0";
}

namespace {
void* allocate(std::size_t n) {
    if (void* p = std::malloc(n ? n : 1)) return p;
    throw std::bad_alloc();
}
}  // namespace

void* operator new(std::size_t n) {
    return allocate(n);
}
void* operator new[](std::size_t n) {
    return allocate(n);
}
void operator delete(void* p) noexcept {
    std::free(p);
}
void operator delete[](void* p) noexcept {
    std::free(p);
}
void operator delete(void* p, std::size_t) noexcept {
    std::free(p);
}
void operator delete[](void* p, std::size_t) noexcept {
    std::free(p);
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const auto path = isoforge::fuzz::scratchFile(data, size, ".vdb");
    try {
        for (const auto& g : isoforge::volume::readVdb(path)) (void)isoforge::volume::summarize(*g);
        const isoforge::volume::DenseVolume v = isoforge::volume::readVolume(path);
        if (v.values.size() != v.voxelCount()) __builtin_trap();
    } catch (const isoforge::IoError&) {
    } catch (const isoforge::ResourceError&) {
    }
    return 0;
}
