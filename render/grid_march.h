#pragma once
/// @file Direct ray marching of OpenVDB float grids: hierarchical traversal of the tree (OpenVDB's
/// VolumeRayIntersector at leaf-node level, so empty tiles and nodes are skipped whole), trilinear
/// samples inside the active spans (steps of the distance for level sets), bisection to sub-voxel
/// precision, normals from the grid gradient. Several iso-surfaces at once, each with a material
/// (bone under translucent skin).

#include <vector>

#include <openvdb/openvdb.h>

#include "implicit/field.h"
#include "render/scene.h"

namespace isoforge::render {

struct IsoLayer {
    float iso = 0.f;
    implicit::Material material;  ///< colour sRGB; alpha = opacity
};

/// Renders the iso-surfaces of `grid`; inside is below each iso when `insideBelow`, above otherwise.
/// A grid with no active values gives the background and a warning.
/// @throw std::invalid_argument for non-uniform voxels (use the mesh path) or no layers.
Frame marchGrid(const openvdb::FloatGrid& grid, const std::vector<IsoLayer>& layers, bool insideBelow, const Look& look,
                const RenderOptions& options, RenderStats* stats = nullptr);

}  // namespace isoforge::render
