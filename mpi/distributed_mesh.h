#pragma once
/// @file One rank's share of a distributed meshing job: a contiguous run of the slabs of
/// volume/bricked.h, chosen by partitionSlabs, meshed with TBB inside the rank. The ranks exchange
/// only counts: each samples a three-block-column halo around its run itself (volume/bricked.h), so no
/// voxel or vertex crosses the network, and the vertex numbers follow from an exclusive scan of the
/// ranks' vertex counts.

#include <cstdint>
#include <string>
#include <vector>

#include <mpi.h>

#include "implicit/field.h"
#include "mesh/trimesh.h"
#include "volume/bricked.h"
#include "volume/dense_volume.h"
#include "volume/voxel_source.h"

namespace isoforge::mpi {

/// One slab of a rank's run, kept as the slab made it (no copy into one big mesh): its vertices,
/// then the ghosts its triangles use (the next slab's first ones); triangles numbered as in the whole
/// mesh once the rank is numbered. Colours for the owned vertices, if the job has them.
struct SlabPart {
    mesh::TriMesh mesh;
    std::size_t owned = 0;
    std::uint64_t vertexBase = 0;  ///< the whole mesh's number of the slab's first vertex
};

/// A rank's part of the whole mesh.
struct RankPiece {
    std::vector<SlabPart> slabs;
    std::uint64_t vertices = 0, triangles = 0;       ///< the rank's own
    std::uint64_t vertexBase = 0, triangleBase = 0;  ///< where the rank's part starts in the whole mesh
    std::uint64_t totalVertices = 0, totalTriangles = 0;
    std::size_t firstSlab = 0;  ///< the rank's run of slabs starts here
    volume::SlabStats stats;
    double secondsMpi = 0;             ///< time in MPI calls (the scans)
    std::uint64_t bytesExchanged = 0;  ///< bytes this rank sent in them
    double secondsRead = 0;            ///< reading a volume file and building its slabs' grid
    std::uint64_t bytesRead = 0;       ///< the slices held meanwhile, and that grid
};

/// What the ranks mesh: a field (sampled a slab at a time), a volume file of which each rank keeps the
/// blocks near the iso-value in the x range of its own slabs (and their halo), or a dense volume every
/// rank holds (a DICOM series).
struct SlabSource {
    implicit::FieldPtr field;
    const volume::VoxelSource* file = nullptr;
    const volume::DenseVolume* volume = nullptr;
};

/// Meshes this rank's slabs and numbers them in the whole mesh (collective over `comm`). A field's
/// slabs are split by the surface they may hold (volume::partitionSlabs), a volume's evenly.
RankPiece meshRankSlabs(const SlabSource& source, const volume::SlabOptions& options, MPI_Comm comm);

}  // namespace isoforge::mpi
