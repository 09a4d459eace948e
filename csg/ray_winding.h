/// @file The winding number of a closed chain of triangles at a point, counted along a ray: the signed
/// crossings of a ray from the point to infinity. Where the generalized winding number sums the solid
/// angle of every triangle near the point (hundreds, on the surface), a ray meets a few nodes of the
/// hierarchy and a few triangles. Exact only off edges and vertices: a ray that passes within rounding of
/// one, or runs along a triangle's plane, is refused, and the caller tries another ray or the solid angles.
#pragma once

#include <cstdint>
#include <optional>
#include <span>

#include <glm/vec3.hpp>

namespace isoforge::csg {

/// A node of a bounding volume hierarchy over triangles: a leaf holds triangles order[first, first +
/// count); an inner node (count 0) has its children at first and first + 1.
struct MeshBvhNode {
    glm::vec3 lo, hi;
    std::uint32_t first, count;
};

struct MeshBvhView {
    std::span<const MeshBvhNode> nodes;
    std::span<const std::uint32_t> order;
    std::span<const glm::uvec3> triangles;
    std::span<const glm::vec3> points;
};

/// The sum over the triangles that the ray q + t dir (t > 0) crosses of +1 or -1 by the side it leaves
/// through (the winding number of q when the triangles close up, its sign a convention); nothing when
/// the ray passes within rounding of an edge or a vertex, runs parallel to a triangle (within rounding) of a
/// leaf it visits, or starts on a triangle.
std::optional<int> windingAlongRay(const MeshBvhView& bvh, const glm::dvec3& q, const glm::dvec3& dir);

/// Whether |winding number| >= 1 at q, from up to three fixed rays; nothing when all three are refused.
std::optional<bool> insideByRays(const MeshBvhView& bvh, const glm::vec3& q);

}  // namespace isoforge::csg
