#pragma once
/// @file Mesh to volume: a narrow-band level set from a triangle mesh (OpenVDB's meshToVolume does
/// the scan conversion). Closed meshes get a signed distance (negative inside); open ones an
/// unsigned distance band, which has no inside.

#include <openvdb/openvdb.h>

#include "mesh/trimesh.h"

namespace isoforge::volume {

struct VoxelizeOptions {
    float voxelSize = 0.f;  ///< world units; required
    float halfWidth = 3.f;  ///< narrow band, voxels each side
};

struct VoxelizeResult {
    openvdb::FloatGrid::Ptr grid;
    bool isSigned = true;  ///< false: the mesh was open; the grid is an unsigned distance band
};

/// @throw std::invalid_argument for an empty mesh or a non-positive voxel size; ResourceError when
///        the band would not fit in memory (with the estimate).
VoxelizeResult voxelize(const mesh::TriMesh& mesh, const VoxelizeOptions& options);

}  // namespace isoforge::volume
