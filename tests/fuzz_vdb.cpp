/// libFuzzer target for .vdb files, read by OpenVDB under us (isoforge::volume::readVdb checks the layout
/// OpenVDB trusts: length fields, counts, offsets) and then used as isoforge uses them: every grid
/// summarized as `isoforge info` does, and the float grid readVolume picks converted to a dense volume.
/// Any input must give grids or an IoError/ResourceError naming the file; never a crash, a hang, or memory
/// the file cannot justify (libFuzzer's -rss_limit_mb).
///
/// OpenVDB allocates a voxel buffer's claimed compressed size before reading it: an absurd claim (64 GB) is
/// a bad_alloc in a release build, which readVdb turns into an IoError. AddressSanitizer's operator new
/// cannot throw and ends the process instead, so this target's operator new throws when malloc (ASan's,
/// with allocator_may_return_null) fails, as the release allocator does (tests/fuzz_alloc.h); scripts/fuzz.sh
/// raises libFuzzer's single-allocation limit for it, while the resident-memory limit stays.
/// Build: cmake -DISOFORGE_FUZZ=ON with clang (see scripts/fuzz.sh).
#include <cstddef>
#include <cstdint>

#include "core/error.h"
#include "fuzz_alloc.h"
#include "fuzz_file.h"
#include "volume/dense_grid.h"
#include "volume/dense_volume.h"
#include "volume/vdb_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const auto path = isoforge::fuzz::scratchFile(data, size, ".vdb");
    try {
        // One read (OpenVDB's node allocation dominates): what `isoforge info` and readVolume do with it.
        const openvdb::GridPtrVec grids = isoforge::volume::readVdb(path);
        for (const auto& g : grids) (void)isoforge::volume::summarize(*g);
        const openvdb::FloatGrid::Ptr grid = isoforge::volume::pickFloatGrid(grids, path);
        // A few active tiles make a dense volume of up to half the machine (toDense allows it): past 2^18
        // voxels (64^3: leaves, tiles of the lower internal level and parts of the upper one's) the copy
        // tests nothing new. The corpus drifts to the largest copies allowed: at 2^24 voxels they took 60%
        // of the time, at 2^21 still 40% (zeroing and copying 8 MB; 90 inputs a second instead of 300).
        const openvdb::Coord d = grid->evalActiveVoxelBoundingBox().dim();
        if (double(d.x()) * d.y() * d.z() <= double(1 << 18)) {
            const isoforge::volume::DenseVolume v = isoforge::volume::toDense(*grid, path);
            if (v.values.size() != v.voxelCount()) __builtin_trap();
        }
    } catch (const isoforge::IoError&) {
    } catch (const isoforge::ResourceError&) {
    }
    return 0;
}
