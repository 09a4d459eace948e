#pragma once
/// @file Running a third-party reader where its abort() cannot end isoforge: some libraries under us stop
/// the process on input they do not expect (Debian builds GDCM with assert() enabled: a cut DICOM meta
/// header ends in `assert(0 && "Should not happen")`). No check of ours can foresee every such assertion, so
/// the work runs in a forked child process and hands its result back through a pipe; a child that dies
/// becomes an IoError naming what it was reading.
#include <cstdint>
#include <functional>
#include <string>

namespace isoforge {

/// Runs `work` in a child process (fork, no exec) and returns the bytes it returned. An IoError,
/// ParseError or ResourceError thrown by `work` is thrown again here with its message; a child killed by a
/// signal (an abort inside the library), or one that ends without answering, throws
/// IoError("<what>: <library> stopped the reading process (signal N: ...)").
/// `work` must not use threads started before the call (only the calling thread exists in the child).
/// `memoryLimit` (bytes, 0 = none) bounds the child's address space beyond what the process holds at the
/// call, so that a length field the library believes cannot make it take more than the input justifies: an
/// allocation past it is a ResourceError saying so.
/// @throw ResourceError if no process can be started.
std::string runIsolated(const std::string& what, const std::string& library, const std::function<std::string()>& work,
                        std::uint64_t memoryLimit = 0);

}  // namespace isoforge
