#pragma once
/// @file From a grid to the mesh a user asked for: marching cubes, then (optionally) feature vertices
/// (--sharp), simplification within a bound (--max-error) and the colours of a CSG scene. The one
/// pipeline behind `isoforge mesh` and the Python package's `mesh()`, so that both give the same bytes.

#include <cstddef>

#include <openvdb/openvdb.h>

#include "core/progress.h"
#include "implicit/field.h"
#include "mesh/simplify.h"
#include "mesh/trimesh.h"
#include "volume/marching_cubes.h"
#include "volume/sharpen.h"

namespace isoforge::volume {

struct SurfaceOptions {
    float isovalue = 0.f;
    InsideSide inside = InsideSide::Auto;
    bool normals = false;     ///< per-vertex normals from the grid gradient
    bool indexSpace = false;  ///< positions in voxel units
    bool sharp = false;       ///< feature vertices on sharp edges and corners (volume/sharpen.h)
    double maxError = 0;      ///< > 0: simplify within this distance, world units (mesh/simplify.h)
    Progress* progress = nullptr;
};

struct SurfaceStats {
    MeshingStats meshing;
    SharpenStats sharpen;
    mesh::SimplifyStats simplify;
    std::size_t fullTriangles = 0;  ///< before simplification
};

/// The iso-surface of `grid` as `options` ask. `field` (may be null) is the field the grid was sampled
/// from: --sharp then takes its Hermite data from the field rather than the grid's interpolant, and
/// the vertices take the colours of the field's CSG colour nodes (white where none is given; no
/// colours at all when no node gives one).
/// @throw std::invalid_argument for maxError with indexSpace (the bound is in world units).
mesh::TriMesh meshSurface(const openvdb::FloatGrid& grid, const implicit::FieldPtr& field,
                          const SurfaceOptions& options, SurfaceStats* stats = nullptr);

}  // namespace isoforge::volume
