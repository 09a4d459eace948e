#pragma once
/// @file Subdivision surfaces (the seed's §3.8). Loop's scheme (approximating): every triangle becomes
/// four; new edge vertices 3/8 (a + b) + 1/8 (c + d), old vertices (1 - k beta) v + beta sum(ring) with
/// Loop's beta = (5/8 - (3/8 + 1/4 cos(2 pi / k))^2) / k; on the boundary, the cubic B-spline rules
/// (edge midpoints, 3/4 v + 1/8 of the two boundary neighbours), so boundaries stay curves.

#include "mesh/trimesh.h"

namespace isoforge::mesh {

/// One level of Loop subdivision. @throw std::invalid_argument for non-manifold input (see HalfEdgeMesh).
TriMesh loopSubdivide(const TriMesh& mesh);

/// One level of the modified butterfly scheme (Zorin, Schröder and Sweldens 1996; interpolating: old
/// vertices stay where they are). Edge vertices between two valence-6 vertices use the 8-point
/// butterfly (1/2, 1/8, -1/16); an extraordinary endpoint of valence k uses Zorin's weights (k = 3:
/// 5/12, -1/12, -1/12; k = 4: 3/8, 0, -1/8, 0; k >= 5: (1/4 + cos(2 pi j/k) + 1/2 cos(4 pi j/k))/k),
/// both extraordinary: the average. Boundary edges use the 4-point scheme (-1/16, 9/16, 9/16, -1/16);
/// interior edges whose stencil reaches the boundary fall back to the 4-point rule across the edge
/// (a simplification of Zorin's boundary cases). @throw std::invalid_argument for non-manifold input.
TriMesh butterflySubdivide(const TriMesh& mesh);

}  // namespace isoforge::mesh
