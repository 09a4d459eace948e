#pragma once
/// @file Vertex normals that keep creases crisp: a vertex whose triangles meet across an edge at more than a
/// crease angle gets one copy per side, each with its side's normal, as glTF, PLY and every renderer
/// expect (a normal is per vertex). The surface is unchanged; only the indexing is: copies share their
/// position, so the mesh is closed by position, not by index (isoforge check welds such copies back).

#include <cstddef>

#include "mesh/trimesh.h"

namespace isoforge::mesh {

/// Splits `mesh`'s vertices at creases, in place. Around each vertex, triangles that share an edge with it
/// belong to one side when their face normals are at most `angleDegrees` apart; a vertex with one side keeps
/// its index and its normal, a vertex with several keeps its index for the side of its first triangle and
/// gets a copy (appended, with its colour) for each other side, in the order of their first triangles; every
/// side of a split vertex takes the angle-weighted mean of its face normals (Thürmer and Wüthrich).
/// Deterministic, whatever the thread count. Does nothing where the mesh has no normals, or for an angle of
/// 180 or more. Returns the number of vertices added.
std::size_t splitNormalsAtCreases(TriMesh& mesh, double angleDegrees);

}  // namespace isoforge::mesh
