#pragma once
/// @file A convex polytope as a field: what hull() makes, and each convex piece of a minkowski().

#include "implicit/field.h"
#include "mesh/convex_hull.h"

namespace isoforge::csg {

/// The field of a convex hull: the largest signed distance to the planes of its faces. Exact
/// inside, a lower bound of the distance outside (1-Lipschitz either way). Its simplify(box) keeps
/// only the planes that can be the largest in the box, so that a hull of thousands of faces costs
/// a few planes per point where the surface is sampled.
/// @throw std::invalid_argument for an empty hull.
implicit::FieldPtr makeConvexPolytope(const mesh::ConvexHull& hull, std::string what = "hull");

}  // namespace isoforge::csg
