#pragma once
/// @file Grids for one iso-level built while a volume file's slices stream past: toGridNearLevel's grid
/// (volume/dense_grid.h) without the volume in memory. One pass over the file holds thirteen slices at a
/// time and the grid, whose blocks follow the surface: for a CT scan at a bone level a few percent of
/// the volume. `isoforge mesh VOLUME --memory` and isoforge-mpi build their slabs' grids this way.

#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include <openvdb/openvdb.h>

#include "core/progress.h"
#include "volume/voxel_source.h"

namespace isoforge::volume {

struct NearLevelOptions {
    float level = 0.f;
    bool insideAbove = true;  ///< as toGridNearLevel's insideAbove
    /// Beyond the array: outside, so that surfaces close at its faces (toGridNearLevel's grid), or the
    /// volume's minimum (toGrid's background: the command line's grid of a volume in memory). The same
    /// when inside is above the level; with inside below, the minimum is inside, and the background is
    /// the minimum, outside blocks tiles of the maximum.
    bool exteriorOutside = false;
    /// Only the 8^3 blocks with x origin in [xBegin, xEnd) (multiples of 8; clamped to the volume).
    std::int64_t xBegin = 0, xEnd = std::numeric_limits<std::int64_t>::max();
    /// When the grid outgrows budgetBytes, the pass drops the blocks from the largest of these ends
    /// below its current end on (ascending; slabs' ends, say) and goes on with the narrower range;
    /// past the first it throws ResourceError ("outgrew").
    std::uint64_t budgetBytes = std::numeric_limits<std::uint64_t>::max();
    std::vector<std::int64_t> narrowerEnds;
    Progress* progress = nullptr;
};

struct NearLevelGrid {
    /// The blocks near the level within [xBegin, xEnd), and tiles for the side away from the background
    openvdb::FloatGrid::Ptr grid;
    std::pair<float, float> range{0.f, 0.f};  ///< the whole volume's minimum and maximum
    std::int64_t xEnd = 0;                    ///< the end kept (xEnd, or one of narrowerEnds)
    std::uint64_t gridBytes = 0;              ///< the grid's memory (nodes and leaves)
    std::uint64_t windowBytes = 0;            ///< what is held while reading (nearLevelWindowBytes)
    double seconds = 0;
};

/// One pass over `source`. With exteriorOutside, each kept block, tile, background and range is
/// toGridNearLevel's on the whole volume; without it, marching cubes gives toGrid's mesh (the
/// volume's minimum as background), which is the same for inside above.
/// @throw IoError when the file is cut or corrupt (voxel_source.h); ResourceError as above
NearLevelGrid nearLevelGrid(const VoxelSource& source, const NearLevelOptions& options);

/// The bytes nearLevelGrid holds while it reads `source`: thirteen slices as floats (all of them if fewer),
/// one slice as stored, the column ranges of a layer of cells in the making (two floats per row of cells
/// and voxel column) and a ring of eight layers of cells (two floats per cell; a cell is 4^3 voxels).
std::uint64_t nearLevelWindowBytes(const VoxelSource& source);

}  // namespace isoforge::volume
