#pragma once
/// @file Self-intersection test of a triangle mesh: pairs of triangles that meet other than along
/// an edge or at a vertex they share.

#include <array>
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

/// The pair test of selfIntersections for two triangles given by their points and vertex ids (equal
/// ids are a shared vertex). False when either is degenerate (collinear).
bool trianglesIntersect(const std::array<glm::vec3, 3>& pa, const std::array<unsigned, 3>& a,
                        const std::array<glm::vec3, 3>& pb, const std::array<unsigned, 3>& b);

}  // namespace isoforge::mesh
