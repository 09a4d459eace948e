#pragma once
/// @file The signed distance of a centred box and its gradient, shared by the box primitive and by
/// unions of boxes (implicit/box_union.h), so that both give the same bits.

#include <algorithm>
#include <cmath>

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

namespace isoforge::implicit {

/// Distance from p to the box of half sizes h (negative inside), in the order of operations of
/// glm::length(glm::max(|p| - h, 0)) + min(max(q), 0).
inline float boxDistance(float px, float py, float pz, float hx, float hy, float hz) {
    const float qx = std::abs(px) - hx, qy = std::abs(py) - hy, qz = std::abs(pz) - hz;
    const float ox = qx < 0.f ? 0.f : qx, oy = qy < 0.f ? 0.f : qy, oz = qz < 0.f ? 0.f : qz;
    const float len = std::sqrt(ox * ox + oy * oy + oz * oz);
    return len + std::min(std::max(qx, std::max(qy, qz)), 0.f);
}

inline float boxDistance(const glm::vec3& p, const glm::vec3& half) {
    return boxDistance(p.x, p.y, p.z, half.x, half.y, half.z);
}

/// boxDistance(p, half) - rounding, with its gradient in g: exact on either side of an edge
/// (outside, towards the nearest point; inside, the nearest face's normal).
inline float boxValueAndGradient(const glm::vec3& p, const glm::vec3& half, float rounding, glm::vec3& g) {
    const glm::vec3 q = glm::abs(p) - half;
    const glm::vec3 side(p.x < 0 ? -1.f : 1.f, p.y < 0 ? -1.f : 1.f, p.z < 0 ? -1.f : 1.f);
    const glm::vec3 out = glm::max(q, glm::vec3(0.f));
    const float len = glm::length(out);
    const float inside = std::min(std::max(q.x, std::max(q.y, q.z)), 0.f);
    if (len > 0) {
        g = side * out / len;
    } else {
        const int k = q.x >= q.y && q.x >= q.z ? 0 : (q.y >= q.z ? 1 : 2);
        g = glm::vec3(0.f);
        g[k] = side[k];
    }
    return len + inside - rounding;
}

}  // namespace isoforge::implicit
