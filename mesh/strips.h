#pragma once
/// @file Triangle strips (the seed's §3.4): an indexed mesh sent as strips, where each triangle after
/// a strip's first costs one vertex instead of three. Built with meshoptimizer (vertex-cache order,
/// then stripification), checked by expanding back.

#include <cstdint>
#include <filesystem>
#include <vector>

#include "mesh/trimesh.h"

namespace isoforge::mesh {

struct Strips {
    static constexpr std::uint32_t kRestart = 0xFFFFFFFFu;
    std::vector<std::uint32_t> indices;  ///< strips separated by kRestart; winding alternates as usual
    std::size_t stripCount = 0;
    std::size_t triangleCount = 0;  ///< of the mesh they came from
    /// Vertices sent per triangle (restart markers not counted): 3 for a triangle list, 1 + 2/m for
    /// strips of m triangles.
    double verticesPerTriangle() const;
};

/// Strips of the mesh's triangles (degenerate triangles in the input are not allowed).
Strips makeStrips(const TriMesh& mesh);

/// The triangles the strips stand for, each counter-clockwise as in the mesh (degenerate strip
/// joints dropped).
std::vector<glm::uvec3> expandStrips(const Strips& strips);

/// True when `a` and `b` hold the same oriented triangles (each up to rotation), in any order.
bool sameTriangles(std::vector<glm::uvec3> a, std::vector<glm::uvec3> b);

/// Writes positions and strips as text ("v x y z" lines, then one "s i j k ..." line per strip,
/// 0-based), atomically. @throw IoError.
void writeStrips(const std::filesystem::path& path, const TriMesh& mesh, const Strips& strips);

}  // namespace isoforge::mesh
