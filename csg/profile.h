#pragma once
/// @file 2D profiles as OpenSCAD holds them: polygons (outlines with a positive or hole flag) from
/// circle, square and polygon, moved by 2D transforms and combined by Clipper (the library and the
/// fixed-point scale OpenSCAD 2021.01 uses). Only what an extrusion needs to build OpenSCAD's own
/// polyhedron; everywhere else 2D shapes are fields (csg/shapes.h).

#include <vector>

#include <glm/mat4x4.hpp>
#include <glm/vec2.hpp>

#include "mesh/trimesh.h"

namespace isoforge::csg {

/// One closed outline; `positive` for solid, false for a hole.
struct Outline2 {
    std::vector<glm::dvec2> points;
    bool positive = true;
};

/// A 2D object as a set of outlines. `sanitized`: the outlines are simple and oriented (positive
/// counter-clockwise, holes clockwise), as Clipper leaves them; a polygon() as given is not.
struct Profile {
    std::vector<Outline2> outlines;
    bool sanitized = true;
};

/// OpenSCAD's sin and cos of degrees (degree_trig.cc): exact at multiples of 30 and 45 degrees,
/// so that a turn by 90 or 180 degrees moves points exactly, as in OpenSCAD's meshes.
double sinDegrees(double x);
double cosDegrees(double x);

/// OpenSCAD's circle with n fragments (a vertex on +x), square, and polygon (sanitized by Clipper:
/// even-odd rule, each path counter-clockwise first). `paths` may be empty: the points in order.
Profile circleProfile(double r, int n);
Profile squareProfile(glm::dvec2 size, bool center);
Profile polygonProfile(const std::vector<glm::dvec2>& points, const std::vector<std::vector<int>>& paths);

/// The 2D part of `m` applied (as OpenSCAD does to a 2D object); a mirrored result is sanitized again.
Profile transformProfile(Profile p, const glm::dmat4& m);

enum class ProfileOp { Union, Intersection, Difference };
/// Clipper's boolean of the children (difference: the first minus the rest), as OpenSCAD's
/// applyToChildren2D: one child is returned as it is.
Profile combineProfiles(const std::vector<const Profile*>& children, ProfileOp op);

/// The union of the profiles by Clipper (non-zero rule), even of one: OpenSCAD's ClipperUtils::apply.
Profile uniteProfiles(const std::vector<const Profile*>& children);
/// offset(): r (round joins), delta (mitred) or delta with chamfer (square), as OpenSCAD's
/// ClipperUtils::applyOffset; arcTolerance = |delta| (1 - cos(180 / fragments)) for round joins.
enum class OffsetJoin { Round, Miter, Square };
Profile offsetProfile(const Profile& p, double delta, OffsetJoin join, double arcTolerance);
/// hull() of 2D children: the convex hull of all their vertices (OpenSCAD's applyHull2D).
Profile hullProfile(const std::vector<const Profile*>& children);
/// minkowski() of 2D children, as OpenSCAD's ClipperUtils::applyMinkowski builds it with Clipper.
Profile minkowskiProfile(const std::vector<const Profile*>& children);

/// OpenSCAD 2021.01's linear_extrude of a sanitized profile with twist and scale: `slices` bands of
/// triangulated walls (each quad split along its shorter diagonal, as OpenSCAD's add_slice), capped
/// below and above (no top cap when a scale is 0). `slices` <= 0: OpenSCAD's own count from $fn, $fa
/// and $fs. Vertices are shared between bands, so a well-formed profile gives a closed mesh.
struct ExtrudeParams {
    double height = 1, twistDeg = 0;
    glm::dvec2 scale{1.0};
    bool center = false;
    int slices = 0;
    double fn = 0, fa = 12, fs = 2;
};
/// @throw std::length_error past maxExtrusionTriangles() wall triangles (a hostile slice count).
mesh::TriMesh extrudeProfile(const Profile& p, const ExtrudeParams& e);
/// Wall triangles past which an export keeps the continuous twist (with a warning): 4 million. The scene
/// fuzzer lowers it at start-up, so that a mutated slice count stays within its time limit under ASan.
double& maxExtrusionTriangles();
inline constexpr int kMaxSlices = 10'000'000;

/// Slices OpenSCAD gives an extrusion without an explicit `slices` (Calc::get_helix_slices,
/// get_conical_helix_slices, get_diagonal_slices).
int openscadSlices(const Profile& p, const ExtrudeParams& e);

}  // namespace isoforge::csg
