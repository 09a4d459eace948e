#include "volume/vdb_compression_guard.h"

#include <cstdint>
#include <istream>
#include <string>

#include <dlfcn.h>
#include <openvdb/Exceptions.h>
#include <openvdb/io/Compression.h>
#include <openvdb/version.h>

// OpenVDB 11 and later check the size first; the guard is for 10, whose names are spelled below.
#if OPENVDB_LIBRARY_MAJOR_VERSION_NUMBER == 10
#define ISOFORGE_GUARD_OPENVDB_CHUNKS 1

namespace {

using ChunkReader = void (*)(std::istream&, char*, std::size_t);

// OpenVDB's own function of that name: the next definition after ours.
ChunkReader original(const char* symbol) {
    void* f = ::dlsym(RTLD_NEXT, symbol);
    if (!f) OPENVDB_THROW(openvdb::RuntimeError, std::string("cannot find OpenVDB's ") + symbol);
    return reinterpret_cast<ChunkReader>(f);
}

// A negative chunk size is an uncompressed chunk of that many bytes: it must be the buffer's size.
void checkChunk(std::istream& is, std::size_t numBytes, const char* kind, bool blosc) {
    const std::streampos at = is.tellg();
    std::int64_t size = 0;
    is.read(reinterpret_cast<char*>(&size), sizeof size);
    if (!is.good())
        OPENVDB_THROW(openvdb::RuntimeError, std::string("stream failure reading the size of a ") + kind + " chunk");
    // Neither blosc nor zlib makes a chunk much larger than its data (blosc adds 16 bytes, zlib about 0.1%
    // and 13): a larger claim is a corrupt file, refused before OpenVDB allocates it (a 64 GB claim was a
    // bad_alloc; under AddressSanitizer even a 1 GB one costs 128 MB of shadow to clear).
    if (size > 0 && std::uint64_t(size) > numBytes + numBytes / 512 + 1024)
        OPENVDB_THROW(openvdb::RuntimeError, "a " << kind << " chunk of " << size << " bytes for " << numBytes
                                                  << " bytes of values: more than compression could make");
    // blosc 1.21 decompresses by the sizes in the chunk's own 16-byte header (its API takes no source size):
    // a chunk shorter than a header, or whose header claims more bytes than the chunk holds, made it read
    // past OpenVDB's buffer (fuzz_vdb found it in the delayed-load metadata; vdb_layout.cpp checks those).
    if (size > 0 && blosc) {
        unsigned char header[16] = {};
        if (size < std::int64_t(sizeof header))
            OPENVDB_THROW(openvdb::RuntimeError, "a blosc chunk of " << size << " bytes, shorter than its header");
        is.read(reinterpret_cast<char*>(header), sizeof header);
        if (!is.good()) OPENVDB_THROW(openvdb::RuntimeError, "stream failure reading a blosc chunk's header");
        const std::uint32_t claimed = std::uint32_t(header[12]) | std::uint32_t(header[13]) << 8 |
                                      std::uint32_t(header[14]) << 16 | std::uint32_t(header[15]) << 24;
        if (claimed > std::uint64_t(size))
            OPENVDB_THROW(openvdb::RuntimeError,
                          "a blosc chunk of " << size << " bytes whose header claims " << claimed);
    }
    // The uncompressed size, negated in unsigned arithmetic: -2^63 has no positive int64 (fuzz_vdb, UBSan).
    const std::uint64_t uncompressed = std::uint64_t(0) - std::uint64_t(size);
    if (size <= 0 && uncompressed != numBytes)
        OPENVDB_THROW(openvdb::RuntimeError,
                      "expected an uncompressed chunk of " << numBytes << " bytes, the file says " << uncompressed);
    is.seekg(at);
}

}  // namespace

namespace openvdb {
OPENVDB_USE_VERSION_NAMESPACE
namespace OPENVDB_VERSION_NAME {
namespace io {

__attribute__((visibility("default"))) void bloscFromStream(std::istream& is, char* data, std::size_t numBytes) {
    static const ChunkReader next = original("_ZN7openvdb5v10_02io15bloscFromStreamERSiPcm");
    checkChunk(is, numBytes, "blosc", true);
    next(is, data, numBytes);
}

__attribute__((visibility("default"))) void unzipFromStream(std::istream& is, char* data, std::size_t numBytes) {
    static const ChunkReader next = original("_ZN7openvdb5v10_02io15unzipFromStreamERSiPcm");
    checkChunk(is, numBytes, "zip", false);
    next(is, data, numBytes);
}

}  // namespace io
}  // namespace OPENVDB_VERSION_NAME
}  // namespace openvdb
#endif

namespace isoforge::volume::detail {

bool openVdbChunkReadersGuarded() {
#ifndef ISOFORGE_GUARD_OPENVDB_CHUNKS
    return true;
#else
    // What the dynamic linker binds the name to for libopenvdb is what it finds first: ours, if exported.
    void* found = ::dlsym(RTLD_DEFAULT, "_ZN7openvdb5v10_02io15bloscFromStreamERSiPcm");
    return found == reinterpret_cast<void*>(static_cast<void (*)(std::istream&, char*, std::size_t)>(
                        &openvdb::OPENVDB_VERSION_NAME::io::bloscFromStream));
#endif
}

}  // namespace isoforge::volume::detail
