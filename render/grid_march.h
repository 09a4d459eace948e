#pragma once
/// @file Direct ray marching of OpenVDB float grids. A depth pre-pass rasterizes boxes around every
/// cell the iso-surfaces cross, so each pixel's rays are marched only over the span of depths where
/// they can meet a surface (pixels no box covers are background without a sample); elsewhere (the eye
/// inside a surface, translucent layers behind the first) a hierarchical traversal of the tree
/// (OpenVDB's VolumeRayIntersector at leaf-node level) skips empty tiles and nodes whole. Samples are
/// trilinear, read through a flat table of the grid's 8^3 regions; level sets are marched by Newton
/// steps bounded by the distance, other grids in half-voxel steps with bisection; normals come from
/// the grid gradient. Several iso-surfaces at once, each with a material (bone under translucent skin).

#include <memory>
#include <vector>

#include <openvdb/openvdb.h>

#include "implicit/field.h"
#include "render/scene.h"

namespace isoforge::render {

struct IsoLayer {
    float iso = 0.f;
    implicit::Material material;  ///< colour sRGB; alpha = opacity
};

/// A grid prepared for direct rendering from any number of views. The view-independent parts of
/// the acceleration (a flat table of the grid's 8^3 regions, and boxes holding every cell that a
/// layer's iso-surface crosses) are built once, as Embree builds its BVH once per mesh; each
/// render() then costs the per-view depth pre-pass (the boxes rasterized: per pixel, the span of
/// depths where its rays may cross a surface) and the rays. The grid must outlive this object and
/// stay unchanged while it is used. render() may be called from several threads.
class PreparedGrid {
public:
    /// `depthPrepass` false: every ray is marched from the eye through the tree (the reference the
    /// pre-pass is tested against; slower).
    /// @throw std::invalid_argument for non-uniform voxels (use the mesh path) or no layers.
    PreparedGrid(const openvdb::FloatGrid& grid, std::vector<IsoLayer> layers, bool insideBelow,
                 bool depthPrepass = true);
    ~PreparedGrid();
    PreparedGrid(const PreparedGrid&) = delete;
    PreparedGrid& operator=(const PreparedGrid&) = delete;

    /// One frame; a grid with no active values gives the background and a warning.
    Frame render(const Look& look, const RenderOptions& options, RenderStats* stats = nullptr) const;
    /// Seconds the constructor took.
    double setupSeconds() const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

/// Renders the iso-surfaces of `grid` (a PreparedGrid used once: stats->setupSeconds holds its
/// preparation, included in stats->seconds); inside is below each iso when `insideBelow`, above otherwise.
/// A grid with no active values gives the background and a warning.
/// @throw std::invalid_argument for non-uniform voxels (use the mesh path) or no layers.
Frame marchGrid(const openvdb::FloatGrid& grid, const std::vector<IsoLayer>& layers, bool insideBelow, const Look& look,
                const RenderOptions& options, RenderStats* stats = nullptr);

}  // namespace isoforge::render
