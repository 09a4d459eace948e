// A helper program for Isolate.* (tests/test_isolate.cpp): `isoforge-test-helper MODE` answers as a reader
// helper would: big (10 MB, with 5,000 lines of warnings on stderr), empty, parse, resource, odd, abort,
// hog (allocates 1 GiB under a 64 MiB bound), pieces (3 MB from a kept buffer, then "end"), stream,
// stream-fail, stream-abort (parts for a HelperStream).
#include <cstdlib>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/isolate.h"

int main(int argc, char** argv) {
    const std::string mode = argc > 1 ? argv[1] : "";
    // In parts (as the DICOM helper streams slices): "one", 2 MB, "three"; or two parts then an error
    // (stream-fail) or an abort (stream-abort).
    if (mode.rfind("stream", 0) == 0)
        isoforge::helperStreamMain("f", "test", 0, [&](const isoforge::HelperSend& send) {
            send(std::string("one"));
            if (mode == "stream-abort") {
                std::cerr << "codec.cxx:12: Assertion `len > 0' failed.\n";
                std::abort();
            }
            send(std::string(2'000'000, 'b'));
            if (mode == "stream-fail") throw isoforge::IoError("f: slice 3 is corrupt");
            send(std::string("three"));
        });
    if (mode == "pieces")  // 3 MB in two pieces of a kept buffer, then "end" (as the DICOM helper answers)
        isoforge::helperMain("f", "test", 0, [] {
            auto kept = std::make_shared<std::vector<char>>(3'000'000);
            for (std::size_t i = 0; i < kept->size(); ++i) (*kept)[i] = char('a' + i % 23);
            isoforge::HelperAnswer a("end");
            a.first = {{kept->data(), 1'000'000}, {kept->data() + 1'000'000, 2'000'000}};
            a.keep = kept;
            return a;
        });
    isoforge::helperMain("f", "test", mode == "hog" ? std::uint64_t(64) << 20 : 0, [&]() -> std::string {
        if (mode == "big") {
            for (int i = 0; i < 5000; ++i) std::cerr << "a warning line of the library, number " << i << "\n";
            std::string s(10'000'000, 'x');
            for (std::size_t i = 0; i < s.size(); i += 4096) s[i] = char('a' + i % 26);
            return s;
        }
        if (mode == "empty") return {};
        if (mode == "parse") throw isoforge::ParseError("f:1:2: bad");
        if (mode == "resource") throw isoforge::ResourceError("f: needs 1 TB");
        if (mode == "odd") throw std::runtime_error("odd");
        if (mode == "abort") {
            std::cerr << "gdcm.cxx:436: Assertion `0 && \"Should not happen\"' failed.\n";
            std::abort();
        }
        if (mode == "hog") {
            std::vector<char> v(std::size_t(1) << 30, 1);
            return std::string(1, v[12345]);
        }
        return "?";
    });
}
