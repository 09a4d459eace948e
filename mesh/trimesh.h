#pragma once
/// @file The indexed triangle mesh, the exchange type between modules.

#include <cstdint>
#include <vector>

#include <glm/vec3.hpp>

namespace isoforge::mesh {

/// An indexed triangle mesh: flat arrays, a plain value.
/// Triangles are counter-clockwise seen from outside, so that (b - a) x (c - a) points outward.
struct TriMesh {
    std::vector<glm::vec3> positions;
    std::vector<glm::vec3> normals;  ///< empty, or one unit normal per position
    std::vector<glm::vec3> colors;  ///< empty, or one RGB colour in [0, 1] per position, sRGB-encoded as files store it
    std::vector<glm::uvec3> triangles;  ///< indices into positions

    std::size_t vertexCount() const { return positions.size(); }
    std::size_t triangleCount() const { return triangles.size(); }
    bool empty() const { return triangles.empty(); }
};

/// Axis-aligned bounds of the positions; min > max when the mesh has no vertices.
struct Bounds {
    glm::vec3 min{1.f}, max{-1.f};
    bool isEmpty() const { return min.x > max.x; }
};
Bounds bounds(const TriMesh& mesh);

/// Total area and signed enclosed volume (positive for a closed mesh with outward normals).
double area(const TriMesh& mesh);
double signedVolume(const TriMesh& mesh);

/// Merges vertices with bit-identical positions (as STL files need), keeping first occurrences
/// in order. Returns the number of vertices removed.
std::size_t weldIdenticalPositions(TriMesh& mesh);

}  // namespace isoforge::mesh
