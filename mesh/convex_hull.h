#pragma once
/// @file The convex hull of a point set in 3D (CGAL's convex_hull_3), what OpenSCAD's hull() and
/// minkowski() compute on the vertices of their children.

#include <span>
#include <vector>

#include <glm/vec3.hpp>

namespace isoforge::mesh {

/// A convex polytope: its vertices and its boundary as triangles, counter-clockwise seen from
/// outside (several coplanar triangles where a face has more than three vertices).
struct ConvexHull {
    std::vector<glm::dvec3> points;
    std::vector<glm::uvec3> triangles;
    bool empty() const { return triangles.empty(); }
};

/// The convex hull of the points; empty when they do not span three dimensions (fewer than four
/// points, or all of them on one plane or line, decided with exact predicates). Deterministic:
/// the same points in the same order give the same hull.
ConvexHull convexHull(std::span<const glm::dvec3> points);

/// Volume of a hull (0 for an empty one).
double volume(const ConvexHull& h);

}  // namespace isoforge::mesh
