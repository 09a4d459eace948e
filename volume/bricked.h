#pragma once
/// @file Out-of-core meshing of fields: the domain cut into slabs along x, each slab sampled, meshed and
/// handed on before the next is held, so that memory grows with the surface in one slab rather than
/// with the whole surface. The pieces, taken in order, are the bytes of the in-memory path's mesh
/// (sample() then extractIsosurface()): the same vertices in the same order, the same triangles.
///
/// Why slabs along x: the mesher orders its 8^3 blocks by (x, y, z), so a slab of whole block columns
/// is a contiguous run of its vertices and triangles, and the only vertices a slab's triangles take
/// from elsewhere are those of the next slab's first block column (volume/marching_cubes.h,
/// extractSlab). Slabs are whole columns of OpenVDB's 128^3 internal nodes, where the sampler's
/// top-down visit starts, so that each slab's leaves are exactly the whole grid's.

#include <cstdint>
#include <functional>

#include "core/progress.h"
#include "implicit/field.h"
#include "mesh/trimesh.h"
#include "volume/dense_grid.h"
#include "volume/marching_cubes.h"
#include "volume/near_level.h"
#include "volume/sample.h"
#include "volume/voxel_source.h"

namespace isoforge::volume {

struct SlabOptions {
    SampleOptions sample;  ///< voxel size, band, clip; memoryLimit: the budget of one slab's grid (0: half the machine)
    float isovalue = 0.f;
    InsideSide inside = InsideSide::Auto;
    bool normals = false;     ///< per-vertex normals from the grid gradient
    bool indexSpace = false;  ///< positions in voxel units
    bool colors = false;      ///< per-vertex colours of the field's CSG colour nodes (white where none)
    int slabWidth = 128;      ///< voxels along x, a multiple of 128
    Progress* progress = nullptr;
};

/// One slab's share of the mesh. Vertex v of the whole mesh is mesh.positions[v - vertexBase]; the
/// first `owned` are the slab's, the rest (ghosts) belong to the next slab, which hands them on.
/// Colours (if asked) are given for the owned vertices.
struct SlabPiece {
    const mesh::TriMesh& mesh;
    std::size_t owned;
    std::uint64_t vertexBase;
    std::int64_t x0, x1;  ///< index-space x range of the slab's blocks
};

struct SlabStats {
    std::size_t slabs = 0;  ///< slabs that were sampled (a slab with no top region is skipped)
    std::uint64_t leaves = 0, vertices = 0, triangles = 0;
    std::uint64_t blocks = 0;        ///< 8^3 blocks the mesher visited (the slab's, and the halo's)
    std::uint64_t maxSlabBytes = 0;  ///< the largest slab's grid and mesh, in memory at once
    double secondsSample = 0, secondsMesh = 0, secondsSink = 0;
};

/// Index-space x origins of the slabs sampleAndMeshBySlabs visits for `field`, first to last
/// (each slab is [origin, origin + slabWidth)).
std::vector<std::int64_t> slabOrigins(const implicit::Field& field, const SampleOptions& sample, int slabWidth);

/// Contiguous runs of the slabs of slabOrigins() for `parts` workers (the ranks of a distributed
/// job), balanced by the surface each slab may hold (surfaceRegionsByColumn): worker p takes slabs
/// [begin[p], begin[p + 1]). The same answer on every rank, whatever it runs on. Runs may be empty.
std::vector<std::size_t> partitionSlabs(const implicit::Field& field, const SampleOptions& sample, int slabWidth,
                                        int parts);

/// Samples and meshes `field` slab by slab, calling `sink` with each slab's piece in order.
/// @throw ResourceError when one slab outgrows options.sample.memoryLimit (the message says how far it got).
void meshBySlabs(const implicit::FieldPtr& field, const SlabOptions& options,
                 const std::function<void(const SlabPiece&)>& sink, SlabStats* stats = nullptr);

/// The same for a dense volume (medical files, raw): each slab's grid is the voxels toGrid() would
/// hold there (`grid` gives the background, the volume's minimum, and the tolerance), so the pieces are
/// the bytes of toGrid() then extractIsosurface(). The volume itself stays in memory.
/// @throw std::invalid_argument without grid.background (a slab's minimum is not the volume's)
void meshVolumeBySlabs(const VolumeView& volume, const ToGridOptions& grid, const SlabOptions& options,
                       const std::function<void(const SlabPiece&)>& sink, SlabStats* stats = nullptr);

/// The same for a volume file whose voxels stream past (volume/near_level.h): each pass over the file
/// builds the grid of the blocks near the iso-value (toGridNearLevel's) for a run of slabs, holding
/// thirteen slices at a time, and meshes them. A grid that outgrows `gridBudget` bytes drops its last
/// slabs, which the next pass takes; so a volume is read once unless its surface does not fit. The same
/// pieces as meshVolumeBySlabs on the whole volume (whose background is its minimum).
/// @throw ResourceError when one slab's grid alone outgrows the budget ("outgrew")
struct SourceSlabStats {
    std::size_t passes = 0;               ///< passes over the file
    std::uint64_t windowBytes = 0;        ///< the slices held while reading
    std::uint64_t gridBytes = 0;          ///< the largest pass's grid
    std::pair<float, float> range{0, 0};  ///< the volume's minimum and maximum
    double secondsRead = 0;               ///< reading the file and building the grids
};
void meshVolumeSourceBySlabs(const VoxelSource& source, const SlabOptions& options, std::uint64_t gridBudget,
                             const std::function<void(const SlabPiece&)>& sink, SlabStats* stats = nullptr,
                             SourceSlabStats* sourceStats = nullptr);

/// The slabs of a volume: x origins 0, slabWidth, ... below its width.
std::vector<std::int64_t> volumeSlabOrigins(const VolumeView& volume, int slabWidth);
/// One slab of a volume as meshVolumeBySlabs makes it (see meshSlab).
std::size_t meshVolumeSlab(const VolumeView& volume, const ToGridOptions& grid, const SlabOptions& options,
                           std::int64_t x0, std::int64_t x1, bool first, bool last, std::uint64_t vertexBase,
                           mesh::TriMesh& out, SlabStats* stats = nullptr);

/// One slab of a grid in memory that holds its blocks and their halo (8 voxels below, 16 above), as
/// meshVolumeSlab: a rank's run of slabs of a volume file (the MPI layer).
std::size_t meshGridSlab(const openvdb::FloatGrid::Ptr& grid, const SlabOptions& options, std::int64_t x0,
                         std::int64_t x1, bool first, bool last, std::uint64_t vertexBase, mesh::TriMesh& out,
                         SlabStats* stats = nullptr);

/// The same for a grid already in memory (a .vdb file): only the mesh is held a slab at a time.
void meshGridBySlabs(const openvdb::FloatGrid& grid, const SlabOptions& options,
                     const std::function<void(const SlabPiece&)>& sink, SlabStats* stats = nullptr);

/// The piece of the slab [x0, x1) of `field` (the first slab open below, the last open above): for a
/// range of slabs on one rank of a distributed job (the MPI layer), or one slab at a time.
/// @return the number of vertices the slab owns; `out` as SlabPiece describes
std::size_t meshSlab(const implicit::FieldPtr& field, const SlabOptions& options, std::int64_t x0, std::int64_t x1,
                     bool first, bool last, std::uint64_t vertexBase, mesh::TriMesh& out, SlabStats* stats = nullptr);

}  // namespace isoforge::volume
