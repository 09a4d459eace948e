#pragma once
/// @file Triangulation of one polygon face in space (planar or nearly so, convex or concave), as
/// polyhedron faces and mesh files give them: ear clipping in the plane of the face's Newell normal.

#include <span>
#include <vector>

#include <glm/vec3.hpp>

namespace isoforge::mesh {

/// Triangles (indices into `points`, in the loop's own orientation) covering the polygon `loop`.
/// Works on the projection onto the plane most parallel to the face (the Newell normal), so it
/// takes concave faces and faces whose points lie slightly off one plane. Every point of the loop
/// is a corner of some triangle (collinear points included), so faces sharing an edge that one of
/// them splits stay joined. Repeated points are skipped; a loop that crosses itself, or one with no
/// area, still gets triangles (a fan over what is left) so that no face is lost. Loops of fewer
/// than 3 distinct points give none. Indices must be valid (the caller checks them).
std::vector<glm::uvec3> triangulateFace(std::span<const glm::vec3> points, std::span<const int> loop);

}  // namespace isoforge::mesh
