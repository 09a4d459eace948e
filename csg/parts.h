#pragma once
/// @file The polyhedral geometry OpenSCAD hands to hull() and minkowski(): an object as a union of
/// parts, with OpenSCAD's vertices for its faceted primitives. A part is convex (the hull of its
/// points), or a solid (its field) together with convex polygons that cover its boundary and lie
/// inside it: a polyhedron or an extrusion (its triangles), a difference of convex parts (the
/// faces of each operand clipped to what is left). That is what both operations need:
/// - hull(X) is the hull of the points of the convex parts and of the covering polygons;
/// - X + C for convex C is (X moved by a point c0 of C) united with (each covering polygon + C):
///   for x = a + c, walking from c0 to c inside C moves x - c from x - c0 to a; either x - c0 is
///   in X, or the walk crosses the boundary of X, at a point p of some polygon, and x is in p + C.
///   Two convex parts give the hull of the sums of their points.
/// The evaluator keeps these parts beside the fields of the objects that have them.

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include "implicit/field.h"
#include "mesh/convex_hull.h"

namespace isoforge::csg {

struct Part {
    std::vector<glm::dvec3> points;              ///< a convex part: its hull is the part
    std::vector<std::vector<glm::dvec3>> cover;  ///< otherwise: convex planar polygons over its boundary
    implicit::FieldPtr solid;                    ///< otherwise: the part as a field
    /// A convex part's hull when it is known (`points` are then its vertices): the hulls that made a
    /// part are not computed again for its field or its clipping; a transform drops it.
    std::shared_ptr<const mesh::ConvexHull> hull;
    bool convex() const { return !solid; }
};
struct Parts {
    std::vector<Part> parts;
};

/// Fragments of smooth spheres and cylinders ($fn, $fa and $fs not given: our own scenes) when a
/// hull() or minkowski() takes them.
inline constexpr int kSmoothFragments = 64;

/// OpenSCAD's cube, its sphere of `fragments` (rings of regular polygons) and its cylinder or cone
/// (regular polygons at both ends; a zero radius is one point).
Parts cubeParts(glm::dvec3 size, bool center);
Parts sphereParts(double r, int fragments);
Parts cylinderParts(double r1, double r2, double h, bool center, int fragments);
/// A closed polyhedron or generated mesh (`solid` is its field): a convex part when the mesh is the
/// boundary of its own hull, else a solid covered by its triangles.
Parts meshParts(std::vector<glm::dvec3> points, const std::vector<glm::uvec3>& triangles, implicit::FieldPtr solid);
/// Points only (a polyhedron OpenSCAD cannot use as a solid, whose points a hull still takes).
Parts pointParts(std::vector<glm::dvec3> points);

Parts transformParts(Parts p, const glm::dmat4& m);
Parts uniteParts(const std::vector<const Parts*>& kids);
/// The difference of the first and the rest (`solid` is its field); nothing when a subtracted part
/// is not convex, or a part of the first is not convex while something is subtracted.
std::optional<Parts> differenceParts(const std::vector<const Parts*>& kids, implicit::FieldPtr solid);
/// The intersection: convex parts intersected pairwise; nothing when a part is not convex.
std::optional<Parts> intersectionParts(const std::vector<const Parts*>& kids);

/// hull(): the hull of every point; empty when they do not span a solid.
mesh::ConvexHull hullOfParts(const Parts& p);
/// minkowski() of two objects, pair of parts by pair of parts (see the file comment).
/// @throw std::invalid_argument for two parts that are both not convex, past `maxHulls` hulls, or
/// past maxMinkowskiSums() point sums of two convex parts.
Parts minkowskiParts(const Parts& a, const Parts& b, std::size_t maxHulls = 200000);
/// Point sums of two convex parts past which minkowski() is refused: 25 million. The scene fuzzer lowers
/// it at start-up (a mutated $fn or a fourth child multiplies the sums; 10^5 of them hulled take seconds
/// under ASan), as it lowers maxExtrusionTriangles().
std::size_t& maxMinkowskiSums();

/// The solid of the parts: convex polytopes and the parts' own fields, united; nullptr when no
/// part has a volume.
implicit::FieldPtr partsField(const Parts& p, const std::string& what);

}  // namespace isoforge::csg
