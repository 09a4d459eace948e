// runIsolated (core/isolate.h): a library's abort() in the child is an IoError in the parent, with the
// library's last line; errors and results cross the pipe whole, however large.
#include <cstdlib>
#include <iostream>
#include <string>

#include <gtest/gtest.h>

#include "core/error.h"
#include "core/isolate.h"

namespace isoforge {
namespace {

TEST(Isolate, ResultsErrorsAndAbortsCrossTheProcessBoundary) {
    // A result larger than a pipe's buffer, with the child chattering on stderr meanwhile (both drained).
    const std::string big = runIsolated("big", "test", [] {
        for (int i = 0; i < 5000; ++i) std::cerr << "a warning line of the library, number " << i << "\n";
        std::string s(10'000'000, 'x');
        for (std::size_t i = 0; i < s.size(); i += 4096) s[i] = char('a' + i % 26);
        return s;
    });
    ASSERT_EQ(big.size(), 10'000'000u);
    EXPECT_EQ(big[4096], char('a' + 4096 % 26));
    EXPECT_EQ(runIsolated("empty", "test", [] { return std::string(); }), "");

    // Errors keep their kind and message.
    EXPECT_THROW(runIsolated("f", "test", []() -> std::string { throw ParseError("f:1:2: bad"); }), ParseError);
    try {
        runIsolated("f", "test", []() -> std::string { throw ResourceError("f: needs 1 TB"); });
        ADD_FAILURE() << "no error";
    } catch (const ResourceError& e) {
        EXPECT_STREQ(e.what(), "f: needs 1 TB");
    }
    try {
        runIsolated("f", "test", []() -> std::string { throw std::runtime_error("odd"); });
        ADD_FAILURE() << "no error";
    } catch (const IoError& e) {
        EXPECT_STREQ(e.what(), "f: odd");
    }

    // An abort in the child (an assertion inside a library) ends the child only.
    try {
        runIsolated("slice.dcm", "GDCM", []() -> std::string {
            std::cerr << "gdcm.cxx:436: Assertion `0 && \"Should not happen\"' failed.\n";
            std::abort();
        });
        ADD_FAILURE() << "no error";
    } catch (const IoError& e) {
        const std::string m = e.what();
        EXPECT_EQ(m.find("slice.dcm: GDCM stopped the reading process (signal 6"), 0u) << m;
        EXPECT_NE(m.find("Should not happen"), std::string::npos) << m;
        EXPECT_EQ(m.find('\n'), std::string::npos) << m;
    }
}

}  // namespace
}  // namespace isoforge
