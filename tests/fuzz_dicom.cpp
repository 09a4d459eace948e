/// libFuzzer target for DICOM series, read by GDCM under us: the first two bytes (little-endian) are the
/// length of a first file, the rest of the input after it a second file, both in one directory (two
/// slices to group by series, sort along their normal and stack; nothing after the first: one file).
/// Any input must give a volume whose voxel count matches its dimensions, or an IoError/ResourceError
/// naming the directory or the file; never a crash, a hang, or an allocation the files cannot justify.
/// Build: cmake -DISOFORGE_FUZZ=ON with clang (see scripts/fuzz.sh).
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>

#include <unistd.h>

#include "core/error.h"
#include "fuzz_file.h"
#include "volume/dense_volume.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size < 2) return 0;
    static const std::filesystem::path dir =
        std::filesystem::temp_directory_path() / ("isoforge-fuzz-dicom-" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    const std::size_t rest = size - 2, first = std::min<std::size_t>(rest, data[0] | (data[1] << 8));
    isoforge::fuzz::writeFile(dir / "a.dcm", data + 2, first);
    if (rest > first) isoforge::fuzz::writeFile(dir / "b.dcm", data + 2 + first, rest - first);
    try {
        const isoforge::volume::DenseVolume v = isoforge::volume::readVolume(dir);
        if (v.values.size() != v.voxelCount()) __builtin_trap();
    } catch (const isoforge::IoError&) {
    } catch (const isoforge::ResourceError&) {
    }
    return 0;
}
