/// libFuzzer target for .vdb files, read by OpenVDB under us (isoforge::volume::readVdb guards what
/// OpenVDB does not: short reads, impossible allocations) and then used as isoforge uses them: every
/// grid summarized as `isoforge info` does, and the float grid converted to a dense volume as readVolume
/// does. Any input must give grids or an IoError/ResourceError naming the file; never a crash, a hang,
/// or an allocation the file cannot justify.
/// Build: cmake -DISOFORGE_FUZZ=ON with clang (see scripts/fuzz.sh).
#include <cstddef>
#include <cstdint>

#include "core/error.h"
#include "fuzz_file.h"
#include "volume/dense_volume.h"
#include "volume/vdb_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const auto path = isoforge::fuzz::scratchFile(data, size, ".vdb");
    try {
        for (const auto& g : isoforge::volume::readVdb(path)) (void)isoforge::volume::summarize(*g);
        const isoforge::volume::DenseVolume v = isoforge::volume::readVolume(path);
        if (v.values.size() != v.voxelCount()) __builtin_trap();
    } catch (const isoforge::IoError&) {
    } catch (const isoforge::ResourceError&) {
    }
    return 0;
}
