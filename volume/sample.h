#pragma once
/// @file Sampling implicit fields into sparse OpenVDB grids.

#include <cstdint>
#include <utility>
#include <vector>

#include <openvdb/openvdb.h>

#include "core/progress.h"
#include "implicit/field.h"
#include "volume/machine_memory.h"

namespace isoforge::volume {

struct SampleOptions {
    float voxelSize = 0.f;  ///< voxel edge length, world units (> 0)
    float halfWidth = 3.f;  ///< narrow-band half-width in voxels, for distance fields (>= 1)
    implicit::Box3 clip = implicit::Box3::everything();  ///< intersected with the field's bounds
    std::uint64_t memoryLimit = 0;                       ///< bytes; 0: half of this machine's memory
    /// Only the voxels with index-space x in [xBegin, xEnd), multiples of 8 (a slab, volume/bricked.h):
    /// their leaves are exactly the whole grid's, an inside tile the slab cuts becomes 8^3 tiles within
    /// it, and beyond the slab the grid is background. The up-front estimate is then not refused (the
    /// memory limit still stops sampling that outgrows it).
    std::int64_t xBegin = -(std::int64_t{1} << 40), xEnd = std::int64_t{1} << 40;
    Progress* progress = nullptr;
};

struct SampleStats {
    std::uint64_t boundsEvaluated = 0;  ///< region bounds computed top-down
    std::uint64_t leaves = 0;           ///< 8^3 blocks sampled point by point
    std::uint64_t tiles = 0;            ///< inside regions filled as tiles
    std::uint64_t pointsEvaluated = 0;
    std::uint64_t estimatedBytes = 0;  ///< the estimate the request was checked against
    bool distance = true;              ///< sampled as a narrow-band level set
    double seconds = 0;
};

/// Samples `field` into a sparse grid, visiting the tree top-down from 128^3 regions and skipping
/// every region whose conservative bound proves the surface is not there: work grows with the
/// surface, and no thin feature is lost. Inside regions become tiles of the inside value.
///  - Distance fields: a narrow-band level set (class LEVEL_SET, background halfWidth * voxelSize),
///    voxels within the band active with their distance.
///  - Other fields (blobby, algebraic, .vm models): the values in every 8^3 block the surface may
///    cross, and its neighbours; inside tiles -1, outside background 1; metadata
///    "isoforge_inside" = "below" so that meshing takes values below 0 as inside.
/// @throw std::invalid_argument if the field is unbounded and no clip box is given, or the voxel
///        size is not positive.
/// @throw ResourceError if the estimated memory exceeds the limit (the message gives the estimate),
///        or if sampling outgrows the limit on its way.
openvdb::FloatGrid::Ptr sample(const implicit::FieldPtr& field, const SampleOptions& options,
                               SampleStats* stats = nullptr);

/// Index-space x range [first, last] of the voxels sample() considers for `field` (the domain and a margin).
std::pair<std::int64_t, std::int64_t> sampleIndexRangeX(const implicit::Field& field, const SampleOptions& options);

/// The bytes sample() expects the grid to take (a surface like the domain's box, as thick as the band):
/// the estimate it refuses requests with.
double estimateSampleBytes(const implicit::Field& field, const SampleOptions& options);
/// The area, in voxel faces, of the surface those estimates assume (the domain's box): about the
/// number of vertices of its mesh, and half the number of triangles.
double estimateSurfaceVoxels(const implicit::Field& field, const SampleOptions& options);

/// For each column of 128^3 top regions along x (its index-space x origin), how many of its regions
/// the surface may cross (the sampler's first test): where the work of sampling and meshing lies,
/// for balancing slabs across the ranks of a distributed job.
std::vector<std::pair<std::int64_t, std::uint64_t>> surfaceRegionsByColumn(const implicit::Field& field,
                                                                           const SampleOptions& options);

/// The region sampled for `field` under `clip` (bounds ∩ clip).
implicit::Box3 sampleDomain(const implicit::Field& field, const implicit::Box3& clip);

/// Voxel size giving `n` voxels along the longest side of `domain`.
float voxelSizeForResolution(const implicit::Box3& domain, int n);

}  // namespace isoforge::volume
