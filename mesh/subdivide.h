#pragma once
/// @file Subdivision surfaces (the seed's §3.8). Loop's scheme (approximating): every triangle becomes
/// four; new edge vertices 3/8 (a + b) + 1/8 (c + d), old vertices (1 - k beta) v + beta sum(ring) with
/// Loop's beta = (5/8 - (3/8 + 1/4 cos(2 pi / k))^2) / k; on the boundary, the cubic B-spline rules
/// (edge midpoints, 3/4 v + 1/8 of the two boundary neighbours), so boundaries stay curves. Creases
/// (Hoppe et al. 1994) follow the same rules: an edge whose faces meet at more than the crease angle is
/// sharp, and so are its halves at every later level; a vertex on two sharp edges moves along them,
/// one on three or more (a corner) stays fixed, one on a single sharp edge (a dart) is smooth.

#include <vector>

#include <glm/vec2.hpp>

#include "mesh/trimesh.h"

namespace isoforge::mesh {

/// `levels` levels of Loop subdivision; creaseAngleDegrees in (0, 180) marks the edges whose face
/// normals differ by more than that angle as creases (0: no creases, a smooth limit surface).
/// @throw std::invalid_argument for non-manifold input (see HalfEdgeMesh).
TriMesh loopSubdivide(const TriMesh& mesh, int levels = 1, double creaseAngleDegrees = 0.0);

/// One level of the modified butterfly scheme (Zorin, Schröder and Sweldens 1996; interpolating: old
/// vertices stay where they are). Edge vertices between two valence-6 vertices use the 8-point
/// butterfly (1/2, 1/8, -1/16); an extraordinary endpoint of valence k uses Zorin's weights (k = 3:
/// 5/12, -1/12, -1/12; k = 4: 3/8, 0, -1/8, 0; k >= 5: (1/4 + cos(2 pi j/k) + 1/2 cos(4 pi j/k))/k),
/// both extraordinary: the average. Boundary edges use the 4-point scheme (-1/16, 9/16, 9/16, -1/16);
/// interior edges whose stencil reaches the boundary fall back to the 4-point rule across the edge
/// (a simplification of Zorin's boundary cases). @throw std::invalid_argument for non-manifold input.
TriMesh butterflySubdivide(const TriMesh& mesh);

/// Curve subdivision for 2D profiles (the polygons that extrusions sweep), `levels` times.
/// Chaikin's corner cutting (approximating, converges to the quadratic B-spline): every edge a-b gives
/// 3/4 a + 1/4 b and 1/4 a + 3/4 b. The 4-point scheme of Dyn, Levin and Gregory (interpolating:
/// the old points stay): a new point -1/16 (p0 + p3) + 9/16 (p1 + p2) in each edge p1-p2. A closed
/// polygon wraps around; an open polyline keeps its end points (Chaikin) or mirrors its ends (4-point).
std::vector<glm::vec2> chaikin(std::vector<glm::vec2> points, int levels, bool closed = true);
std::vector<glm::vec2> fourPoint(std::vector<glm::vec2> points, int levels, bool closed = true);

}  // namespace isoforge::mesh
