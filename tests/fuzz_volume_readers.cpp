/// libFuzzer target for the volume readers through readVolume: the first byte picks the format (NIfTI .nii
/// and .nii.gz, NRRD, MetaImage .mha), the rest is the file. Any input must give a volume whose voxel count
/// matches its dimensions, or an IoError (ParseError, ResourceError with the memory estimate) naming the
/// file; never a crash, a hang, or an allocation the file cannot justify (libFuzzer's -rss_limit_mb).
/// Build: cmake -DISOFORGE_FUZZ=ON with clang (see scripts/fuzz.sh).
#include <cstddef>
#include <cstdint>

#include "core/error.h"
#include "fuzz_file.h"
#include "volume/dense_volume.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size < 1) return 0;
    static const char* const extensions[] = {".nii", ".nii.gz", ".nrrd", ".mha"};
    const auto path = isoforge::fuzz::scratchFile(data + 1, size - 1, extensions[data[0] % 4]);
    try {
        const isoforge::volume::DenseVolume v = isoforge::volume::readVolume(path);
        if (v.values.size() != v.voxelCount()) __builtin_trap();
    } catch (const isoforge::IoError&) {
    } catch (const isoforge::ResourceError&) {
    }
    return 0;
}
