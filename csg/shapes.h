#pragma once
/// @file Shapes the scene language needs beyond implicit/: polyhedra (exact distance to a triangle
/// mesh, inside by winding number), 2D shapes (fields of x and y, infinite along z) and their
/// linear and rotational extrusions, and OpenSCAD's faceted primitives for $fn > 0.

#include <vector>

#include <string>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "implicit/field.h"

namespace isoforge::csg {

using implicit::FieldPtr;

/// A closed polyhedron; faces are polygons of point indices, either orientation.
/// @throw std::invalid_argument for bad indices or fewer than 4 faces.
FieldPtr makePolyhedron(std::vector<glm::vec3> points, const std::vector<std::vector<int>>& faces);
/// Whether every directed edge of the faces (points merged by position) is used once and its
/// reverse once: a closed polyhedron with consistently oriented faces, inward or outward. OpenSCAD
/// drops a polyhedron that fails this from every boolean operation ("The given mesh is not closed!").
/// With `manifoldVertices`, also each point's faces must make one fan (CGAL's polyhedron builder,
/// which OpenSCAD's conversion uses, refuses two cones meeting at their apex).
bool facesPairUp(const std::vector<glm::vec3>& points, const std::vector<std::vector<int>>& faces,
                 bool manifoldVertices = false);
/// The exact signed distance to a triangle mesh: distance through a bounding volume hierarchy.
/// Sign: by default from the generalized winding number, evaluated hierarchically (Barill et al.
/// 2018): right for closed meshes, self-intersecting ones and meshes with small holes. With
/// `trusted` (generated geometry known not to self-intersect) and a closed, edge-manifold mesh,
/// from angle-weighted pseudonormals instead (faster). The orientation is made consistent and
/// outward first where the mesh is closed. Points at the same position are merged.
/// `closed` (if given) says whether the mesh was closed and edge-manifold.
/// @throw std::invalid_argument for indices out of range, non-finite points, < 4 usable triangles.
FieldPtr makeTriangleMeshField(std::vector<glm::vec3> points, std::vector<glm::uvec3> triangles,
                               std::string what = "mesh", bool* closed = nullptr, bool trusted = false);

/// 2D shapes (the sign of x, y; constant along z).
FieldPtr makeCircle2D(float r);
FieldPtr makeRectangle2D(glm::vec2 min, glm::vec2 max);
/// Polygon with optional holes: paths index points; without paths, the points in order. Even-odd rule.
FieldPtr makePolygon2D(std::vector<glm::vec2> points, std::vector<std::vector<int>> paths = {});
/// A regular n-gon of circumradius r with a vertex on +x (OpenSCAD's circle($fn = n)), as a field
/// in O(1) per point (the distance to the edge of the point's sector).
/// `phase` turns it: the first vertex at that angle (radians) from +x.
FieldPtr makeRegularPolygon2D(float r, int n, double phase = 0.0);

/// 2D child extruded from z = 0 to height (or centred), as OpenSCAD does: turned by -twist * t
/// degrees and scaled by lerp(1, scale, t) at height fraction t (the value is then a conservative
/// distance: divided by the map's Lipschitz factor).
FieldPtr makeLinearExtrude(FieldPtr child2d, float height, bool center, float twistDeg = 0.f,
                           glm::vec2 scale = glm::vec2(1.f));
/// 2D child (x >= 0 half-plane) revolved about the z axis; (x, y) of the child become (radius, z).
/// |angle| < 360: only the wedge from the +x axis turning by `angle` degrees (counter-clockwise when positive).
/// With `segments` > 0, faceted as OpenSCAD does ($fn): that many flat segments over the angle, the
/// first from the +x axis. `mirrored`: the profile lies on the x <= 0 side (OpenSCAD takes it mirrored).
FieldPtr makeRotateExtrude(FieldPtr child2d, float angleDeg = 360.f, int segments = 0, bool mirrored = false);

/// OpenSCAD's faceted sphere and cylinder for $fn = n > 0 (the same vertices and faces OpenSCAD
/// makes), as faceted revolves and prisms of regular polygons: analytic, O(1) per point whatever n.
FieldPtr makeFacetedSphere(float r, int n);
FieldPtr makeFacetedCylinder(float r1, float r2, float h, bool center, int n);

}  // namespace isoforge::csg
