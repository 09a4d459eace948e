#pragma once
/// @file The 512 values of one 8^3 leaf of a sampled grid (volume/sample.cpp's inner loop).

#include <cstdint>
#include <span>
#include <vector>

#include <openvdb/math/Coord.h>

#include "implicit/field.h"

namespace isoforge::volume {

/// Samples leaves one after another, reusing its buffers (one per thread).
/// A distance field (1-Lipschitz, Field::isDistance) is sampled coarse to fine: first the 64 points
/// with even coordinates, then only the points that none of them proves to be beyond the band:
/// |f(p)| >= band + |p - q| gives |f(q)| >= band with the sign of f(p), and such a point is
/// stored as +-band, as the band clamps it anyway. Two thirds of a leaf's points lie beyond the band
/// in a typical narrow band, and they are the dearest (a polyhedron's closest triangle is farther).
/// The values are those of evaluating every point, except where the field breaks its contract.
class LeafSampler {
public:
    LeafSampler(float voxel, float band, bool distance);
    /// The values at origin + (i >> 6, (i >> 3) & 7, i & 7) voxels, i < 512; valid until the next call.
    std::span<const float> sample(const implicit::Field& field, const openvdb::math::Coord& origin);
    /// Points evaluated so far.
    std::uint64_t evaluated() const { return evaluated_; }

private:
    float voxel_, band_;
    float gap_[4];  ///< from a point to a coarse neighbour 0, 1, 2 or 3 axis steps away (voxel * sqrt(k))
    bool distance_;
    std::vector<glm::vec3> points_, coarsePoints_;
    std::vector<float> values_, coarseValues_, missingValues_;
    std::vector<int> missing_;
    std::uint64_t evaluated_ = 0;
};

}  // namespace isoforge::volume
