#pragma once
/// @file Running a third-party reader where its abort() cannot end isoforge: some libraries under us stop
/// the process on input they do not expect (Debian builds GDCM with assert() enabled: a cut DICOM meta
/// header ends in `assert(0 && "Should not happen")`), or allocate what a length field says. No check of
/// ours can foresee every such assertion, so the reading runs in a helper program (lib/isoforge/, found
/// as modules are) started with posix_spawn, which hands its result back through a pipe; a helper that
/// dies becomes an IoError naming what it was reading. A fresh program rather than a fork: a forked
/// child of a threaded process can inherit a lock another thread held (AddressSanitizer's allocator in
/// clang 14 is not fork-safe: a CI run hung on it).
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace isoforge {

/// A helper whose answer comes in parts, read as they are needed (a DICOM series slice by slice: the
/// helper holds one slice, and the pipe's back-pressure holds it until the caller wants the next). Started
/// as runHelper starts one; next() reads one part, finish() checks that the helper ended well. Destroyed
/// before finish(), it kills the helper. Errors are runHelper's: what the helper's work threw (after
/// any parts), an abort inside the library, a helper that ended without its part.
class HelperStream {
public:
    HelperStream(const std::string& what, const std::string& library, const std::filesystem::path& program,
                 const std::vector<std::string>& args);
    ~HelperStream();
    HelperStream(const HelperStream&) = delete;
    HelperStream& operator=(const HelperStream&) = delete;

    /// The next part's bytes, read straight into `place(size)` (a buffer of at least `size` bytes the
    /// caller owns); returns the size. What `place` throws is thrown once the helper has ended.
    std::uint64_t next(const std::function<char*(std::uint64_t size)>& place);
    /// Waits for the helper's end: it must send nothing more and exit well. Its stderr is passed on.
    void finish();

private:
    struct State;
    std::unique_ptr<State> s_;
};

/// Runs `program` with `args` (stdin closed, stdout and stderr piped) and returns the bytes its
/// helperMain's work returned. An IoError, ParseError or ResourceError the work threw is thrown again here
/// with its message; a helper killed by a signal (an abort inside the library) throws
/// IoError("<what>: <library> stopped the reading process (signal N: ...) (<its last stderr line>)").
/// The helper's stderr is passed on to ours when it succeeds.
/// @throw ResourceError if the program cannot be started.
std::string runHelper(const std::string& what, const std::string& library, const std::filesystem::path& program,
                      const std::vector<std::string>& args);
/// The same, with the result's bytes read straight into `place(size)`, a buffer of at least `size` bytes
/// that the caller owns (a volume's voxels: no 50 MB string in between); returns the size. What `place`
/// throws is thrown once the helper has ended.
std::uint64_t runHelper(const std::string& what, const std::string& library, const std::filesystem::path& program,
                        const std::vector<std::string>& args, const std::function<char*(std::uint64_t size)>& place);

/// What a helper's work answers: the bytes of `first` (spans into what `keep` holds), then those of `last`,
/// written as they are (no copy of a volume into one buffer first). A string converts to an answer.
struct HelperAnswer {
    HelperAnswer(std::string bytes = {}) : last(std::move(bytes)) {}  // NOLINT: a string is an answer
    std::vector<std::span<const char>> first;
    std::shared_ptr<const void> keep;
    std::string last;
};

/// The main of a helper program: bounds the address space to what the process holds now plus
/// `memoryLimit` bytes (0: no bound; with a sanitizer, its shadow reservations are part of what it holds),
/// runs `work` and writes its answer to stdout for runHelper. An allocation past the bound is a
/// ResourceError saying that reading `what` with `library` needed more than its size justifies.
/// Ends the process (_exit) once it has answered.
[[noreturn]] void helperMain(const std::string& what, const std::string& library, std::uint64_t memoryLimit,
                             const std::function<HelperAnswer()>& work);
/// The same for a HelperStream: `work` calls `send` once per part (each is written before send returns,
/// so the pipe's back-pressure paces the work). An error it throws after some parts is the stream's error.
using HelperSend = std::function<void(const HelperAnswer&)>;
[[noreturn]] void helperStreamMain(const std::string& what, const std::string& library, std::uint64_t memoryLimit,
                                   const std::function<void(const HelperSend& send)>& work);

}  // namespace isoforge
