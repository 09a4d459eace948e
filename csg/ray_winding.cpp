#include "csg/ray_winding.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include <glm/geometric.hpp>

namespace isoforge::csg {

namespace {

/// Whether the ray meets the box grown by a margin (a box the ray grazes is opened: a missed box would
/// lose a crossing, an opened one costs a few tests).
bool rayMeetsBox(const MeshBvhNode& n, const glm::dvec3& q, const glm::dvec3& inv, double margin) {
    double t0 = 0, t1 = HUGE_VAL;
    for (int k = 0; k < 3; ++k) {
        const double lo = double(n.lo[k]) - margin, hi = double(n.hi[k]) + margin;
        if (std::isinf(inv[k])) {  // parallel to the slab
            if (q[k] < lo || q[k] > hi) return false;
            continue;
        }
        double a = (lo - q[k]) * inv[k], b = (hi - q[k]) * inv[k];
        if (a > b) std::swap(a, b);
        t0 = std::max(t0, a);
        t1 = std::min(t1, b);
        if (t0 > t1) return false;
    }
    return true;
}

}  // namespace

std::optional<int> windingAlongRay(const MeshBvhView& bvh, const glm::dvec3& q, const glm::dvec3& dir) {
    if (bvh.nodes.empty()) return 0;
    const glm::dvec3 inv(1.0 / dir.x, 1.0 / dir.y, 1.0 / dir.z);
    const MeshBvhNode& root = bvh.nodes[0];
    const double scale = 1.0 + glm::length(glm::dvec3(root.hi) - glm::dvec3(root.lo)) + glm::length(q);
    const double margin = 1e-6 * scale;
    // Barycentric coordinates within this of an edge, or a crossing within this of q (relative to the
    // triangle), are too close to call.
    constexpr double kEdge = 1e-9;
    int winding = 0;
    std::uint32_t stack[64];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
        const MeshBvhNode& n = bvh.nodes[stack[--top]];
        if (!rayMeetsBox(n, q, inv, margin)) continue;
        if (n.count == 0) {
            stack[top++] = n.first;
            stack[top++] = n.first + 1;
            continue;
        }
        for (std::uint32_t i = n.first; i < n.first + n.count; ++i) {
            const glm::uvec3& tri = bvh.triangles[bvh.order[i]];
            const glm::dvec3 a(bvh.points[tri.x]), b(bvh.points[tri.y]), c(bvh.points[tri.z]);
            const glm::dvec3 e1 = b - a, e2 = c - a;
            const glm::dvec3 p = glm::cross(dir, e2);
            const double det = glm::dot(e1, p);
            const double area = glm::length(glm::cross(e1, e2));
            if (!(area > 0)) continue;  // a degenerate triangle bounds nothing
            // Along the triangle's plane, or within rounding of it: where it would cross is too close to call.
            if (std::abs(det) <= 1e-9 * area) return {};
            const glm::dvec3 s = q - a;
            const double u = glm::dot(s, p) / det;
            const glm::dvec3 qv = glm::cross(s, e1);
            const double v = glm::dot(dir, qv) / det;
            const double w = 1.0 - u - v;
            if (u < -kEdge || v < -kEdge || w < -kEdge) continue;  // clearly outside the triangle
            const double t = glm::dot(e2, qv) / det;
            const double tEps = 1e-9 * (glm::length(e1) + glm::length(e2) + glm::length(s));
            if (t < -tEps) continue;                                             // behind q
            if (u <= kEdge || v <= kEdge || w <= kEdge || t <= tEps) return {};  // an edge, a vertex, or q on it
            winding += det < 0 ? 1 : -1;
        }
    }
    return winding;
}

std::optional<bool> insideByRays(const MeshBvhView& bvh, const glm::vec3& q) {
    // Directions far from the axes and from each other, so that a ray rarely runs along a grid's edges,
    // faces or OpenSCAD's axis-aligned facets.
    static const glm::dvec3 kDirs[] = {glm::normalize(glm::dvec3(0.5377, 0.8123, 0.2251)),
                                       glm::normalize(glm::dvec3(-0.7071, 0.3173, 0.6315)),
                                       glm::normalize(glm::dvec3(0.2913, -0.5261, -0.7989))};
    for (const glm::dvec3& d : kDirs)
        if (const auto w = windingAlongRay(bvh, glm::dvec3(q), d)) return *w != 0;
    return {};
}

}  // namespace isoforge::csg
