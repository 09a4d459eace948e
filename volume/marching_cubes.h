#pragma once
/// @file isoforge's parallel marching cubes on sparse OpenVDB grids.

#include <cstddef>
#include <cstdint>
#include <vector>

#include <openvdb/openvdb.h>

#include "core/progress.h"
#include "mesh/trimesh.h"

namespace isoforge::volume {

/// Which side of the iso-value is the solid (the inside of the surface).
enum class InsideSide {
    Auto,   ///< level sets and grids sampled from fields: below (negative inside); fog, density, CT: above
    Below,  ///< values < iso are inside
    Above,  ///< values > iso are inside
};

struct MeshingOptions {
    float isovalue = 0.f;
    InsideSide inside = InsideSide::Auto;
    bool worldSpace = true;  ///< false: positions in index space (voxel units)
    bool normals = false;    ///< per-vertex normals from the grid gradient (central differences)
    /// When set, receives per vertex (in vertex order) the larger of the grid's values at the two ends of
    /// its edge: scikit-image's `values` (python/), read where the mesher has them.
    std::vector<float>* edgeValues = nullptr;
    Progress* progress = nullptr;
};

struct MeshingStats {
    std::size_t leaves = 0;         ///< leaf nodes of the grid
    std::size_t blocks = 0;         ///< 8^3 cell blocks visited (leaves, their lower neighbours, tile borders)
    std::size_t surfaceBlocks = 0;  ///< blocks that produced vertices or triangles
    double secondsSetup = 0, secondsCount = 0, secondsWrite = 0;
};

/// Extracts the iso-surface of `grid` as an indexed triangle mesh.
///
/// Visits only 8^3 blocks of cells that touch a leaf node or the border of a tile whose value lies
/// on the other side of the iso-value than its neighbour; parallel over blocks (TBB). One vertex
/// per intersected grid edge, shared by every cell around it; built by count, prefix-sum and write
/// passes, so the output (vertex and triangle order included) is the same whatever the thread
/// count. Closed surfaces come out watertight, edge- and vertex-manifold, with no degenerate
/// triangles, oriented counter-clockwise seen from outside (outward normals); values equal to the
/// iso-value count as outside, and vertices are kept a thousandth of a voxel away from grid
/// corners so that no triangle collapses.
///
/// @param out reused: its buffers are resized, not reallocated, when large enough
/// @throw ResourceError if the grid's index extent cannot be addressed (over 2^21 leaves per axis)
void extractIsosurface(const openvdb::FloatGrid& grid, const MeshingOptions& options, mesh::TriMesh& out,
                       MeshingStats* stats = nullptr);

/// A slab of the grid for out-of-core and distributed meshing (volume/bricked.h): the cells of the 8^3
/// blocks whose index-space x origin lies in [x0, x1), with vertices numbered from vertexBase.
/// The default is the whole grid.
struct SlabRange {
    std::int64_t x0 = -(std::int64_t{1} << 40), x1 = std::int64_t{1} << 40;  ///< multiples of 8
    std::uint64_t vertexBase = 0;  ///< the number of the slab's first vertex (the vertices of slabs before it)
};

/// The part of extractIsosurface's mesh that the slab makes: its vertices (the owned ones, in the
/// whole mesh's order) and its triangles, numbered as in the whole mesh (vertex v is
/// out.positions[v - vertexBase]). Slabs taken in order and concatenated give the whole mesh's bytes.
/// `out` also receives, after the owned vertices, the "ghost" vertices of the blocks at x1 that the
/// slab's triangles use; the next slab owns them and makes them again, identical.
/// `grid` need only hold the values for x in [x0 - 8, x1 + 16) (the slab, a block column below it,
/// two above): the rest of the grid is not read.
/// @return the number of vertices the slab owns
/// @throw std::invalid_argument if x0 or x1 is not a multiple of 8 or the range is empty
std::size_t extractSlab(const openvdb::FloatGrid& grid, const MeshingOptions& options, const SlabRange& slab,
                        mesh::TriMesh& out, MeshingStats* stats = nullptr);

/// Convenience overload returning a new mesh.
mesh::TriMesh extractIsosurface(const openvdb::FloatGrid& grid, const MeshingOptions& options = {},
                                MeshingStats* stats = nullptr);

/// Index-space boxes that together hold every cell the iso-surface crosses (a cell is crossed when
/// its eight corners are not all on one side of `iso`; cell (i, j, k) spans [i, i+1] x [j, j+1] x
/// [k, k+1], and each box's min and max are corners). At most one box per brick^3 cells (brick 2,
/// 4 or 8), tight around the crossed cells in it, over the same blocks the mesher visits; in block
/// order. The ray marcher's depth pre-pass rasterizes them: every crossing of the trilinear
/// interpolant lies in one of these boxes.
std::vector<openvdb::CoordBBox> crossedCellBoxes(const openvdb::FloatGrid& grid, float iso,
                                                 InsideSide side = InsideSide::Auto, int brick = 4);

/// True if `grid` is meshed with the inside below the iso-value under `side`.
bool insideIsBelow(const openvdb::FloatGrid& grid, InsideSide side);

}  // namespace isoforge::volume
