/// libFuzzer target for DICOM series, read by GDCM under us: the first two bytes (little-endian) are the
/// length of a first file, the rest of the input after it a second file, both in one directory (two
/// slices to group by series, sort along their normal and stack; nothing after the first: one file).
///
/// isoforge reads DICOM in a helper program (lib/isoforge/isoforge-dicom-reader: GDCM's assert() and its
/// appetite for memory cannot take isoforge down). A helper started per input would be blind to coverage
/// and slow (5 inputs a second), so this target runs what the helper runs, readDicomSeriesHere, in its own
/// process, and sends the volume through the helper's encoding and back. Any input must give a volume
/// whose voxel count matches its dimensions, or an IoError/ResourceError naming the directory or the file.
/// The helper's address-space limit (dicomMemoryLimit) is a bound on single requests here (tests/fuzz_alloc.h),
/// lowered: a request past it is the bad_alloc the helper reports as a ResourceError. A crash here is one the helper
/// contains in isoforge, and still a finding to guard against.
///
/// GDCM is built with assertions (Debian's build), and many broken files trip one: in isoforge that ends the
/// helper and is an IoError; here it would end the fuzzer every few hundred inputs, and a restart costs
/// seconds. So this target defines __assert_fail ahead of libc's: an assertion called from libgdcm jumps
/// back here (longjmp: GDCM's call sites do not expect an exception, and unwinding one through them
/// terminates), and is counted; any other assertion aborts as libc's does. What the skipped frames held is
/// left, as it is when the helper ends: memory and open files, which scripts/fuzz.sh bounds by running this
/// target in fresh processes of a few thousand inputs, with leak detection off.
/// Build: cmake -DISOFORGE_FUZZ=ON with clang (see scripts/fuzz.sh).
#include <algorithm>
#include <csetjmp>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <limits>
#include <new>
#include <string>

#include <dlfcn.h>
#include <gdcmTrace.h>
#include <unistd.h>

#include "core/error.h"
#include "fuzz_alloc.h"
#include "fuzz_file.h"
#include "volume/readers.h"

namespace {
std::jmp_buf* gdcmAssertion = nullptr;  // where an assertion in GDCM goes while it reads
std::size_t gdcmAssertions = 0;

void readAsTheHelperDoes(const std::filesystem::path& dir) {
    namespace detail = isoforge::volume::detail;
    try {
        const isoforge::volume::DenseVolume v = detail::readDicomSeriesHere(dir, "");
        if (v.values.size() != v.voxelCount()) __builtin_trap();
        const isoforge::volume::DenseVolume back = detail::deserializeVolume(detail::serializeVolume(v), "fuzz");
        if (back.dims != v.dims || back.values != v.values) __builtin_trap();
    } catch (const isoforge::IoError&) {
    } catch (const isoforge::ResourceError&) {
    } catch (const std::bad_alloc&) {  // the helper's ResourceError
    }
}

void readCatchingGdcmAssertions(const std::filesystem::path& dir) {
    std::jmp_buf jump;
    if (setjmp(jump)) {  // GDCM asserted: the helper's IoError
        gdcmAssertion = nullptr;
        // The reader's trace guard did not run: its stream is gone.
        gdcm::Trace::SetWarningStream(std::cerr);
        gdcm::Trace::SetErrorStream(std::cerr);
        ++gdcmAssertions;
        return;
    }
    gdcmAssertion = &jump;
    readAsTheHelperDoes(dir);
    gdcmAssertion = nullptr;
}

void reportAssertions() {
    std::fprintf(stderr, "fuzz_dicom: %zu GDCM assertions (contained by the helper in isoforge)\n", gdcmAssertions);
}
}  // namespace

extern "C" [[noreturn]] void __assert_fail(const char* expr, const char* file, unsigned line, const char* fn) {
    Dl_info caller{};
    if (gdcmAssertion && ::dladdr(__builtin_return_address(0), &caller) && caller.dli_fname &&
        std::strstr(caller.dli_fname, "libgdcm"))
        std::longjmp(*gdcmAssertion, 1);
    std::fprintf(stderr, "%s:%u: %s: Assertion `%s' failed.\n", file, line, fn, expr);
    std::abort();
}

extern "C" int LLVMFuzzerInitialize(int*, char***) {
    std::atexit(reportAssertions);
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size < 2) return 0;
    static const std::filesystem::path dir =
        std::filesystem::temp_directory_path() / ("isoforge-fuzz-dicom-" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    const std::size_t rest = size - 2, first = std::min<std::size_t>(rest, data[0] | (data[1] << 8));
    isoforge::fuzz::writeFile(dir / "a.dcm", data + 2, first);
    if (rest > first) isoforge::fuzz::writeFile(dir / "b.dcm", data + 2 + first, rest - first);
    namespace detail = isoforge::volume::detail;
    // The helper's bound less 448 MiB: inputs are a few KB, and a request GDCM makes past 64 MiB takes the
    // same path as one past 512 MiB (bad_alloc where it allocates) without clearing the memory first.
    isoforge::fuzz::allocationLimit() = detail::dicomMemoryLimit(dir) - (std::uint64_t(448) << 20);
    readCatchingGdcmAssertions(dir);
    isoforge::fuzz::allocationLimit() = std::numeric_limits<std::size_t>::max();
    return 0;
}
