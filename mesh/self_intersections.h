#pragma once
/// @file Self-intersection test of a triangle mesh: pairs of triangles that meet other than along
/// an edge or at a vertex they share.

#include <cstddef>
#include <utility>

#include "mesh/trimesh.h"

namespace isoforge::mesh {

struct SelfIntersections {
    std::size_t pairs = 0;                            ///< intersecting pairs (counted up to the limit)
    std::pair<std::size_t, std::size_t> first{0, 0};  ///< the pair of smallest indices, when pairs > 0
    bool limited = false;                             ///< counting stopped at the limit
};

/// Counts intersecting pairs of triangles: CGAL's box intersection over the triangles' bounding
/// boxes, then CGAL's exact predicates for each candidate pair (Epick). Triangles sharing an edge
/// intersect when they fold onto each other (coplanar, on the same side of the edge); sharing a vertex,
/// when the opposite edge of one meets the other. Repeated-index and zero-area triangles are skipped
/// (mesh::check counts them). Deterministic; O(T log T + K) for K candidate pairs.
SelfIntersections selfIntersections(const TriMesh& mesh, std::size_t limit = ~std::size_t{0});

}  // namespace isoforge::mesh
