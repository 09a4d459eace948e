#pragma once
/// @file Creases across cells for feature vertices (sharpen.cpp, step 3): fan triangles of neighbouring
/// cells flipped so that a crease runs from feature vertex to feature vertex (docs/marching-cubes.md).

#include <cstddef>
#include <cstdint>
#include <vector>

#include <glm/vec3.hpp>

#include "volume/sharpen.h"

namespace isoforge::volume {

/// Follows creases across cells (Kobbelt et al.'s edge flip): two fan triangles (c1, a, b) and
/// (c2, b, a) of face-neighbouring cells, with feature vertices c1 and c2, become (c1, a, c2) and
/// (c1, c2, b) when the field's normals at their centres agree better with the new pair. Both new
/// triangles lie in the box of the two cells and meet its boundary only at a or b, so only the
/// triangles of those two cells (and earlier flips into them) can cross them: each flip is tested
/// against those with exact predicates and skipped if any pair intersects, or if c1-c2 is already an
/// edge (the mesh would stop being manifold). Edges in a fixed order, each triangle flipped once.
/// `P` are the mesh's positions (index space), `tris` its triangles (changed in place), `cellOf` each
/// triangle's cell (its index, -1 for none), vertices from `firstApex` on the fans' apexes and
/// `reachingApex[v - firstApex]` whether apex v's fan reaches beyond its cell (never flipped). Returns the
/// number of flips.
std::size_t flipCreases(const std::vector<glm::vec3>& P, std::vector<glm::uvec3>& tris,
                        const std::vector<std::int64_t>& cellOf, unsigned firstApex, std::size_t cellCount,
                        const IndexField& field, const std::vector<char>& reachingApex);

}  // namespace isoforge::volume
