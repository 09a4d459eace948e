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

/// Triangles covering a region of the xy plane: an outer loop and loops of holes inside it
/// (indices into `points`, all at one z), in the outer loop's orientation. Each hole is joined
/// to the outer loop by a bridge from its point of largest x to a point of the loop it sees (Eberly's
/// method, as in earcut), rightmost hole first; the one loop is then ear-clipped (triangulateFace).
/// A hole that no ray reaches (not inside the loop) is left out.
std::vector<glm::uvec3> triangulateRegionXY(std::span<const glm::vec3> points, std::span<const int> outer,
                                            const std::vector<std::vector<int>>& holes);

}  // namespace isoforge::mesh
