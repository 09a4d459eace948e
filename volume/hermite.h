#pragma once
/// @file What feature vertices (sharpen.cpp) and crease flips (crease_flips.cpp) share: the field's gradient
/// at points (its own, or central differences), boxes grown point by point, and batches of neighbours.
/// Internal to the volume module.

#include <cstddef>
#include <limits>
#include <span>
#include <vector>

#include <glm/common.hpp>
#include <glm/vec3.hpp>

#include "volume/sharpen.h"

namespace isoforge::volume::hermite {

constexpr float kStep = 1e-3f;  // central differences of the field, in voxels

/// The six points of the central differences at p, appended to `out`.
inline void appendStencil(const glm::vec3& p, std::vector<glm::vec3>& out) {
    for (int k = 0; k < 3; ++k) {
        glm::vec3 a = p, b = p;
        a[k] -= kStep;
        b[k] += kStep;
        out.push_back(a);
        out.push_back(b);
    }
}

/// The gradient from the values at appendStencil's six points.
inline glm::vec3 stencilGradient(const float* v) {
    return glm::vec3(v[1] - v[0], v[3] - v[2], v[5] - v[4]) / (2.f * kStep);
}

/// The field's gradient at each point: its own where it gives one (the active branch of a min or
/// max, exactly), else central differences of its values.
inline void gradientsAt(const IndexValues& f, std::span<const glm::vec3> p, std::vector<glm::vec3>& out) {
    out.resize(p.size());
    if (f.gradients) {
        f.gradients(p, out);
        return;
    }
    std::vector<glm::vec3> pts;
    pts.reserve(6 * p.size());
    for (const glm::vec3& q : p) appendStencil(q, pts);
    std::vector<float> v(pts.size());
    f(pts, v);
    for (std::size_t i = 0; i < p.size(); ++i) out[i] = stencilGradient(&v[6 * i]);
}

/// An index-space box grown point by point.
struct Bounds {
    glm::vec3 lo{std::numeric_limits<float>::infinity()}, hi{-std::numeric_limits<float>::infinity()};
    void add(const glm::vec3& p) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
    }
    /// The field there, with room for the central differences around every point added.
    IndexValues of(const IndexField& field) const { return field(lo - 4.f * kStep, hi + 4.f * kStep); }
};

/// Batches: vertices, cells and crease candidates are taken this many at a time, neighbours in the
/// mesh's order (marching cubes writes block by block), so that each batch asks for a small box.
constexpr std::size_t kBatch = 64;

inline std::size_t batchCount(std::size_t n) {
    return (n + kBatch - 1) / kBatch;
}

}  // namespace isoforge::volume::hermite
