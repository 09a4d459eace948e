#include "volume/leaf_sampler.h"

#include <cmath>
#include <limits>

namespace isoforge::volume {

namespace {

glm::vec3 leafPoint(const openvdb::math::Coord& c, int i, float voxel) {
    return glm::vec3(c.x() + (i >> 6), c.y() + ((i >> 3) & 7), c.z() + (i & 7)) * voxel;
}

/// Coarse neighbours of coordinate x in 0..7 on the lattice 0, 2, 4, 6 (indices 0..3): itself when
/// even; the two around it when odd (one for 7).
int coarseAround(int x, int out[2]) {
    if (x % 2 == 0) {
        out[0] = x / 2;
        return 1;
    }
    out[0] = x / 2;
    if (x == 7) return 1;
    out[1] = x / 2 + 1;
    return 2;
}

}  // namespace

LeafSampler::LeafSampler(float voxel, float band, bool distance)
    : voxel_(voxel),
      band_(band),
      distance_(distance),
      points_(512),
      coarsePoints_(64),
      values_(512),
      coarseValues_(64),
      missingValues_(512) {
    missing_.reserve(512);
    for (int k = 0; k < 4; ++k) gap_[k] = voxel * std::sqrt(float(k));
}

std::span<const float> LeafSampler::sample(const implicit::Field& field, const openvdb::math::Coord& c) {
    if (!distance_) {
        for (int i = 0; i < 512; ++i) points_[i] = leafPoint(c, i, voxel_);
        field.values(points_, values_);
        evaluated_ += 512;
        return values_;
    }
    for (int k = 0; k < 64; ++k)
        coarsePoints_[k] = leafPoint(c, ((k >> 4) << 7) | (((k >> 2) & 3) << 4) | ((k & 3) << 1), voxel_);
    field.values(coarsePoints_, coarseValues_);
    // A margin for rounding: a thousandth of a voxel and the band's last bits.
    const float margin = 1e-3f * voxel_ + 8.f * std::numeric_limits<float>::epsilon() * band_;
    missing_.clear();
    for (int i = 0; i < 512; ++i) {
        const int x = i >> 6, y = (i >> 3) & 7, z = i & 7;
        if (x % 2 == 0 && y % 2 == 0 && z % 2 == 0) {
            values_[i] = coarseValues_[((x / 2) << 4) | ((y / 2) << 2) | (z / 2)];
            continue;
        }
        int ax[2], ay[2], az[2];
        const int nx = coarseAround(x, ax), ny = coarseAround(y, ay), nz = coarseAround(z, az);
        bool known = false;
        for (int a = 0; a < nx && !known; ++a)
            for (int b = 0; b < ny && !known; ++b)
                for (int d = 0; d < nz && !known; ++d) {
                    const float v = coarseValues_[(ax[a] << 4) | (ay[b] << 2) | az[d]];
                    // Offsets are 0 or 1 voxel per axis: the distance by how many are 1.
                    const int steps = (x != 2 * ax[a]) + (y != 2 * ay[b]) + (z != 2 * az[d]);
                    if (std::abs(v) >= band_ + gap_[steps] + margin) {  // false for NaN
                        values_[i] = v < 0.f ? -band_ : band_;
                        known = true;
                    }
                }
        if (!known) missing_.push_back(i);
    }
    evaluated_ += 64 + missing_.size();
    if (missing_.empty()) return values_;
    const std::size_t n = missing_.size();
    for (std::size_t k = 0; k < n; ++k) points_[k] = leafPoint(c, missing_[k], voxel_);
    field.values(std::span(points_).first(n), std::span(missingValues_).first(n));
    for (std::size_t k = 0; k < n; ++k) values_[missing_[k]] = missingValues_[k];
    return values_;
}

}  // namespace isoforge::volume
