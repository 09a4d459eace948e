// runHelper (core/isolate.h) with tests/isolate_helper_main.cpp: a library's abort() in the helper is an
// IoError here with the library's last line; errors and results cross the pipe whole, however large; an
// allocation past the helper's bound is a ResourceError.
#include <cerrno>
#include <string>
#include <vector>

#include <sys/wait.h>

#include <gtest/gtest.h>

#include "core/error.h"
#include "core/isolate.h"

namespace isoforge {
namespace {

std::string run(const std::string& mode) {
    return runHelper("f", "test", ISOFORGE_TEST_HELPER, {mode});
}

TEST(Isolate, ResultsErrorsAndAbortsCrossTheProcessBoundary) {
    // A result larger than a pipe's buffer, with the helper chattering on stderr meanwhile (both drained).
    const std::string big = run("big");
    ASSERT_EQ(big.size(), 10'000'000u);
    EXPECT_EQ(big[4096], char('a' + 4096 % 26));
    EXPECT_EQ(run("empty"), "");

    // Errors keep their kind and message.
    EXPECT_THROW(run("parse"), ParseError);
    try {
        run("resource");
        ADD_FAILURE() << "no error";
    } catch (const ResourceError& e) {
        EXPECT_STREQ(e.what(), "f: needs 1 TB");
    }
    try {
        run("odd");
        ADD_FAILURE() << "no error";
    } catch (const IoError& e) {
        EXPECT_STREQ(e.what(), "f: odd");
    }
    // An allocation past the bound.
    try {
        run("hog");
        ADD_FAILURE() << "no error";
    } catch (const ResourceError& e) {
        EXPECT_NE(std::string(e.what()).find("needed more than the 64 MiB its size justifies"), std::string::npos)
            << e.what();
    } catch (const IoError& e) {
        // Under AddressSanitizer the allocator reports and aborts instead of throwing.
        EXPECT_NE(std::string(e.what()).find("stopped the reading process"), std::string::npos) << e.what();
    }

    // An abort in the helper (an assertion inside a library) ends the helper only.
    try {
        run("abort");
        ADD_FAILURE() << "no error";
    } catch (const IoError& e) {
        const std::string m = e.what();
        EXPECT_EQ(m.find("f: test stopped the reading process (signal 6"), 0u) << m;
        EXPECT_NE(m.find("Should not happen"), std::string::npos) << m;
        EXPECT_EQ(m.find('\n'), std::string::npos) << m;
    }
}

TEST(Isolate, ResultsLandInTheCallersBufferAndItsErrorsWaitForTheHelper) {
    // Pieces of the helper's own buffer, then a string, into a buffer of ours (the DICOM voxels' path).
    std::vector<char> buffer;
    const std::uint64_t size = runHelper("f", "test", ISOFORGE_TEST_HELPER, {"pieces"}, [&](std::uint64_t n) {
        buffer.resize(std::size_t(n));
        return buffer.data();
    });
    ASSERT_EQ(size, 3'000'003u);
    for (std::size_t i = 0; i < 3'000'000; i += 999) ASSERT_EQ(buffer[i], char('a' + i % 23)) << i;
    EXPECT_EQ(std::string(buffer.end() - 3, buffer.end()), "end");

    // A buffer that cannot be had: its error, once the helper has been drained and waited for.
    try {
        runHelper("f", "test", ISOFORGE_TEST_HELPER, {"big"},
                  [](std::uint64_t n) -> char* { throw ResourceError("no room for " + std::to_string(n) + " bytes"); });
        ADD_FAILURE() << "no error";
    } catch (const ResourceError& e) {
        EXPECT_STREQ(e.what(), "no room for 10000000 bytes");
    }
    errno = 0;
    EXPECT_EQ(::waitpid(-1, nullptr, WNOHANG), -1) << "a helper left unwaited for";
    EXPECT_EQ(errno, ECHILD);
}

TEST(Isolate, StreamsComeInPartsAndTheirErrorsAfterThem) {
    std::string part;
    const auto into = [&](std::uint64_t n) {
        part.assign(std::size_t(n), '\0');
        return part.data();
    };
    {
        HelperStream h("f", "test", ISOFORGE_TEST_HELPER, {"stream"});
        EXPECT_EQ(h.next(into), 3u);
        EXPECT_EQ(part, "one");
        EXPECT_EQ(h.next(into), 2'000'000u);
        EXPECT_EQ(part, std::string(2'000'000, 'b'));
        EXPECT_EQ(h.next(into), 5u);
        EXPECT_EQ(part, "three");
        h.finish();
    }
    {  // an error after two parts: the parts, then the error
        HelperStream h("f", "test", ISOFORGE_TEST_HELPER, {"stream-fail"});
        h.next(into);
        h.next(into);
        try {
            h.next(into);
            ADD_FAILURE() << "no error";
        } catch (const IoError& e) {
            EXPECT_STREQ(e.what(), "f: slice 3 is corrupt");
        }
    }
    {  // an abort after one part
        HelperStream h("f", "test", ISOFORGE_TEST_HELPER, {"stream-abort"});
        h.next(into);
        try {
            h.next(into);
            ADD_FAILURE() << "no error";
        } catch (const IoError& e) {
            EXPECT_EQ(std::string(e.what()).find("f: test stopped the reading process (signal 6"), 0u) << e.what();
            EXPECT_NE(std::string(e.what()).find("len > 0"), std::string::npos) << e.what();
        }
    }
    {  // more asked for than sent
        HelperStream h("f", "test", ISOFORGE_TEST_HELPER, {"stream"});
        for (int i = 0; i < 3; ++i) h.next(into);
        EXPECT_THROW(h.next(into), IoError);
    }
    {  // left after one part, the helper blocked on a full pipe: it is ended, not waited for forever
        HelperStream h("f", "test", ISOFORGE_TEST_HELPER, {"stream"});
        h.next(into);
    }
    errno = 0;
    EXPECT_EQ(::waitpid(-1, nullptr, WNOHANG), -1) << "a helper left unwaited for";
    EXPECT_EQ(errno, ECHILD);
}

}  // namespace
}  // namespace isoforge
