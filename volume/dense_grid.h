#pragma once
/// @file Dense volumes to and from sparse OpenVDB grids.

#include <cstdint>
#include <optional>
#include <utility>

#include <openvdb/openvdb.h>

#include "core/progress.h"
#include "volume/dense_volume.h"

namespace isoforge::volume {

struct ToGridOptions {
    std::optional<float> background;  ///< the value left out of the sparse grid; default: the volume's minimum
    float tolerance = 0.f;            ///< values within this of the background are culled too
    Progress* progress = nullptr;
    /// Only the voxels with x index in [xBegin, xEnd) (a slab, volume/bricked.h); the rest is background.
    std::int64_t xBegin = -(std::int64_t{1} << 40), xEnd = std::int64_t{1} << 40;
};

/// A sparse float grid holding the volume's voxels that differ from the background by more than the
/// tolerance, with the volume's index-to-world matrix as its (affine) transform. Converted in slabs of
/// 64 slices straight from the volume's memory: no second dense copy. Metadata: "isoforge_inside" =
/// "above" (densities, CT), the source format, units and modality.
openvdb::FloatGrid::Ptr toGrid(const DenseVolume& volume, const ToGridOptions& options = {});

/// Voxels held elsewhere (a numpy array), x fastest, then y, then z.
struct VolumeView {
    const float* values = nullptr;
    std::array<std::int64_t, 3> dims{0, 0, 0};
    glm::dmat4 indexToWorld{1.0};
    std::string format;  ///< for the grid's metadata
    /// The values are x indices [xOffset, xOffset + dims[0]) of a wider volume (a slab of it read alone,
    /// volume/voxel_source.h); toGrid places them there. toGridNearLevel takes whole volumes only.
    std::int64_t xOffset = 0;
};
/// The same from a view: read in place, no copy of the voxels.
openvdb::FloatGrid::Ptr toGrid(const VolumeView& volume, const ToGridOptions& options = {});

/// A sparse grid for the iso-surface at `level` alone: the 8^3 blocks whose voxels, or those within two
/// voxels of them, lie on both sides of the level become leaves (the voxels as they are); blocks wholly
/// inside become tiles of `insideValue`; the rest is the background `outsideValue` (outside the array
/// too). Every crossed cell and every gradient at a crossing sees the volume's own values, so
/// marching cubes gives the same vertices and normals as on toGrid's grid, while the memory and the
/// work grow with the surface, not the volume. Inside is above the level (values equal to it outside)
/// when `insideAbove`, else below; the inside value is the volume's maximum (its minimum when inside is
/// below) and the background the other extreme, as toGrid's background is. `range` (if given) gets
/// the volume's minimum and maximum. Parallel (TBB); deterministic.
/// Without `exteriorOutside`, beyond the array is the volume's minimum, as on toGrid's grid (whose
/// background it is): the same grid when inside is above; with inside below, the background is the
/// minimum (inside) and the blocks wholly outside are tiles of the maximum, so that marching cubes gives
/// toGrid's mesh there too (volume/near_level.h).
openvdb::FloatGrid::Ptr toGridNearLevel(const VolumeView& volume, float level, bool insideAbove,
                                        std::pair<float, float>* range = nullptr, bool exteriorOutside = true);

/// The dense volume of a grid's active bounding box (inactive voxels take the background).
/// @throw ResourceError if it would not fit in half of this machine's memory (active tiles of a tiny file can
///        span 4096^3 voxels), IoError if the grid has no active voxel; both name `source` when given.
DenseVolume toDense(const openvdb::FloatGrid& grid, const std::filesystem::path& source = {});

/// The index-to-world matrix as an OpenVDB transform (affine).
openvdb::math::Transform::Ptr transformOf(const glm::dmat4& indexToWorld);

}  // namespace isoforge::volume
