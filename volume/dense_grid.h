#pragma once
/// @file Dense volumes to and from sparse OpenVDB grids.

#include <optional>

#include <openvdb/openvdb.h>

#include "core/progress.h"
#include "volume/dense_volume.h"

namespace isoforge::volume {

struct ToGridOptions {
    std::optional<float> background;  ///< the value left out of the sparse grid; default: the volume's minimum
    float tolerance = 0.f;            ///< values within this of the background are culled too
    Progress* progress = nullptr;
};

/// A sparse float grid holding the volume's voxels that differ from the background by more than the
/// tolerance, with the volume's index-to-world matrix as its (affine) transform. Converted in slabs of
/// 64 slices straight from the volume's memory: no second dense copy. Metadata: "isoforge_inside" =
/// "above" (densities, CT), the source format, units and modality.
openvdb::FloatGrid::Ptr toGrid(const DenseVolume& volume, const ToGridOptions& options = {});

/// The dense volume of a grid's active bounding box (inactive voxels take the background).
DenseVolume toDense(const openvdb::FloatGrid& grid);

/// The index-to-world matrix as an OpenVDB transform (affine).
openvdb::math::Transform::Ptr transformOf(const glm::dmat4& indexToWorld);

}  // namespace isoforge::volume
