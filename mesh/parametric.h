#pragma once
/// @file Parametric curves and surfaces (the seed's §3.4): Bézier curves and tensor-product patches
/// evaluated by de Casteljau's algorithm, B-splines and NURBS evaluated by de Boor's algorithm in
/// homogeneous coordinates (so conics are exact: a NURBS circle's points lie on the circle to float
/// precision), surfaces of revolution, Newell's teapot patch format (.bpt), and tessellation into
/// indexed triangle meshes whose shared patch edges, seams and poles are welded, so a closed patch set
/// gives a watertight mesh.
///
/// Orientation: a patch's outward side is the side of dS/du x dS/dv; triangles are wound so that
/// their normals point that way.

#include <filesystem>
#include <span>
#include <vector>

#include <glm/vec3.hpp>

#include "mesh/trimesh.h"

namespace isoforge::mesh {

/// The point of the Bézier curve with these control points at t (de Casteljau; t in [0, 1]).
glm::dvec3 bezierPoint(std::span<const glm::dvec3> control, double t);

/// A tensor-product Bézier patch: (degreeV + 1) rows of (degreeU + 1) control points, row by row.
struct BezierPatch {
    int degreeU = 3, degreeV = 3;
    std::vector<glm::dvec3> points;
    const glm::dvec3& at(int i, int j) const { return points[std::size_t(j) * std::size_t(degreeU + 1) + i]; }
    glm::dvec3 evaluate(double u, double v) const;  ///< de Casteljau along u in each row, then along v
};

/// Reads a Bézier patch file (.bpt, the format of Newell's teapot as distributed by Eric Haines): the
/// number of patches, then for each patch its degrees in u and v and (degreeU + 1)(degreeV + 1) points
/// "x y z", row by row. @throw IoError with file:line:column on malformed, truncated or hostile files.
std::vector<BezierPatch> readBezierPatches(const std::filesystem::path& path);

/// A NURBS curve: degree p, n control points with weights (empty = all 1, a non-rational B-spline),
/// and n + p + 1 non-decreasing knots. The curve is defined on [knots[p], knots[n]].
struct NurbsCurve {
    int degree = 3;
    std::vector<double> knots;
    std::vector<glm::dvec3> points;
    std::vector<double> weights;

    /// @throw std::invalid_argument saying what is wrong (counts, order of knots, weights <= 0, ...).
    void validate() const;
    double domainBegin() const { return knots[std::size_t(degree)]; }
    double domainEnd() const { return knots[points.size()]; }
    glm::dvec3 evaluate(double t) const;  ///< de Boor; t is clamped to the domain
};

/// A NURBS surface: countV rows of countU control points (row by row, u varying fastest), their
/// weights (empty = all 1), and knot vectors of countU + degreeU + 1 and countV + degreeV + 1 values.
struct NurbsSurface {
    int degreeU = 3, degreeV = 3;
    int countU = 0, countV = 0;
    std::vector<double> knotsU, knotsV;
    std::vector<glm::dvec3> points;
    std::vector<double> weights;

    void validate() const;  ///< @throw std::invalid_argument
    glm::dvec3 evaluate(double u, double v) const;
};

/// Knot vectors: clamped (end knots repeated degree + 1 times, so the curve starts and ends at its end
/// control points) with uniform interior knots, and fully uniform (0, 1, 2, ...).
std::vector<double> clampedUniformKnots(int count, int degree);
std::vector<double> uniformKnots(int count, int degree);

/// The exact circle of radius r in the xy plane around the origin, counter-clockwise from +x: degree 2,
/// nine control points, weights 1 and sqrt(2)/2.
NurbsCurve nurbsCircle(double r);
/// The profile (x, ., z) revolved once around the z axis: u runs around the axis counter-clockwise
/// seen from +z, v along the profile. A profile from bottom to top on the +x side faces outward.
NurbsSurface revolve(const NurbsCurve& profile);
/// Exact sphere (a revolved half circle) and torus (a revolved circle), outward-facing.
NurbsSurface nurbsSphere(double r);
NurbsSurface nurbsTorus(double majorRadius, double minorRadius);

/// Tessellation: each patch becomes a grid of `resolution` x `resolution` quads (two triangles each),
/// evaluated at uniform parameters; positions shared by patches, seams and collapsed edges (poles) are
/// welded, and triangles that collapse are dropped. Deterministic.
TriMesh tessellate(std::span<const BezierPatch> patches, int resolution);
TriMesh tessellate(const NurbsSurface& surface, int resolution);

}  // namespace isoforge::mesh
