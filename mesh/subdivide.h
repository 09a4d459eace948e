#pragma once
/// @file Subdivision surfaces (the seed's §3.8). Loop's scheme (approximating): every triangle becomes
/// four; new edge vertices 3/8 (a + b) + 1/8 (c + d), old vertices (1 - k beta) v + beta sum(ring) with
/// Loop's beta = (5/8 - (3/8 + 1/4 cos(2 pi / k))^2) / k; on the boundary, the cubic B-spline rules
/// (edge midpoints, 3/4 v + 1/8 of the two boundary neighbours), so boundaries stay curves.

#include "mesh/trimesh.h"

namespace isoforge::mesh {

/// One level of Loop subdivision. @throw std::invalid_argument for non-manifold input (see HalfEdgeMesh).
TriMesh loopSubdivide(const TriMesh& mesh);

}  // namespace isoforge::mesh
