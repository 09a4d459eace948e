/// libFuzzer target for raw voxel files and the options that describe them (--dims, --type, --spacing,
/// --offset, --big-endian): the first 16 bytes are the options — three little-endian uint32 dimensions
/// (hostile ones included: a 100-byte file claiming 10^12 voxels must get the ResourceError with the
/// estimate before any allocation), a type byte, a flags byte (big-endian), a uint16 header offset — and
/// the rest is the file. Any input must give a volume whose voxel count matches its dimensions, or an
/// IoError/ResourceError naming the file; never a crash.
/// Build: cmake -DISOFORGE_FUZZ=ON with clang (see scripts/fuzz.sh).
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "core/error.h"
#include "fuzz_file.h"
#include "volume/dense_volume.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size < 16) return 0;
    static const char* const types[] = {"uint8", "int8", "uint16", "int16", "uint32", "int32", "float32", "float64"};
    isoforge::volume::VolumeReadOptions o;
    for (int i = 0; i < 3; ++i) {
        std::uint32_t d;
        std::memcpy(&d, data + 4 * i, 4);
        o.rawDims[std::size_t(i)] = std::int64_t(d);
    }
    o.rawType = types[data[12] % 8];
    o.rawBigEndian = data[13] & 1;
    o.rawSpacing = glm::dvec3(1.0, 0.5 + (data[13] >> 1), 2.0);
    o.rawOffset = std::uint64_t(data[14]) | (std::uint64_t(data[15]) << 8);
    const auto path = isoforge::fuzz::scratchFile(data + 16, size - 16, ".raw");
    try {
        const isoforge::volume::DenseVolume v = isoforge::volume::readVolume(path, o);
        if (v.values.size() != v.voxelCount()) __builtin_trap();
    } catch (const isoforge::IoError&) {
    } catch (const isoforge::ResourceError&) {
    }
    return 0;
}
