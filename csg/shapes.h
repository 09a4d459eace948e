#pragma once
/// @file Shapes the scene language needs beyond implicit/: polyhedra (exact distance to a triangle
/// mesh, inside by winding number), 2D shapes (fields of x and y, infinite along z) and their
/// linear and rotational extrusions, and OpenSCAD's faceted primitives for $fn > 0.

#include <vector>

#include <glm/vec2.hpp>

#include "implicit/field.h"

namespace isoforge::csg {

using implicit::FieldPtr;

/// A closed polyhedron; faces are polygons of point indices, either orientation.
/// @throw std::invalid_argument for bad indices or fewer than 4 faces.
FieldPtr makePolyhedron(std::vector<glm::vec3> points, const std::vector<std::vector<int>>& faces);

/// 2D shapes (the sign of x, y; constant along z).
FieldPtr makeCircle2D(float r);
FieldPtr makeRectangle2D(glm::vec2 min, glm::vec2 max);
/// Polygon with optional holes: paths index points; without paths, the points in order. Even-odd rule.
FieldPtr makePolygon2D(std::vector<glm::vec2> points, std::vector<std::vector<int>> paths = {});
/// A regular n-gon of circumradius r with a vertex on +x (OpenSCAD's circle($fn = n)).
std::vector<glm::vec2> regularPolygon(float r, int n);

/// 2D child extruded from z = 0 to height (or centred).
FieldPtr makeLinearExtrude(FieldPtr child2d, float height, bool center);
/// 2D child (x >= 0 half-plane) revolved about the z axis; (x, y) of the child become (radius, z).
FieldPtr makeRotateExtrude(FieldPtr child2d);

/// OpenSCAD's faceted sphere and cylinder for $fn = n > 0 (the same vertices OpenSCAD makes).
FieldPtr makeFacetedSphere(float r, int n);
FieldPtr makeFacetedCylinder(float r1, float r2, float h, bool center, int n);

}  // namespace isoforge::csg
