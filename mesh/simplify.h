#pragma once
/// @file Simplification of closed triangle meshes by edge collapse (`isoforge mesh --max-error`),
/// keeping them closed, manifold, oriented and free of self-intersections.

#include <cstddef>

#include "mesh/trimesh.h"

namespace isoforge::mesh {

struct SimplifyStats {
    std::size_t collapses = 0;
    std::size_t rejectedTopology = 0;  ///< the link condition would fail (the surface would stop being a manifold)
    std::size_t rejectedFlip = 0;      ///< a triangle would turn over or become degenerate
    std::size_t rejectedError = 0;     ///< an original vertex would end farther than maxError from the surface
    std::size_t rejectedCrossing = 0;  ///< a new triangle would cross another (exact predicates)
};

/// Collapses edges in order of quadric error (Garland and Heckbert; plus a hundredth of the edge's squared
/// length, so that flat regions go shortest edge first) while every original vertex stays
/// within `maxError` (world units) of the simplified surface, measured to the triangles that replaced
/// its own, and the new vertex lies within maxError of the original triangles around the collapsed ones.
/// Each collapse must keep the link condition, turn no triangle over (by 90 degrees or more) nor make one
/// degenerate, and create no intersecting pair (tested with exact predicates against the triangles
/// near it, through a loose octree). Colours and normals are kept for the vertices that remain.
/// Deterministic (one thread, ties broken by edge). The mesh must be closed, manifold and oriented.
SimplifyStats simplify(TriMesh& mesh, double maxError);

}  // namespace isoforge::mesh
