#pragma once
/// @file The bytes of the mesh formats isoforge writes, a run of vertices or triangles at a time:
/// writeMesh (mesh/io.h) and the streaming writer (mesh/stream_writer.h) both build their files from
/// these, so that a mesh written whole and one written piece by piece are the same bytes.

#include <cstdint>
#include <functional>
#include <span>
#include <string>

#include <glm/vec3.hpp>

namespace isoforge::mesh::records {

/// The PLY header: "element vertex" with x y z [nx ny nz] [red green blue], "element face".
std::string plyHeader(std::uint64_t vertices, std::uint64_t triangles, bool normals, bool colors, bool ascii);
/// PLY vertex records; `normals` and `colors` empty or as long as `positions`.
void appendPlyVertices(std::string& out, std::span<const glm::vec3> positions, std::span<const glm::vec3> normals,
                       std::span<const glm::vec3> colors, bool ascii);
/// PLY face records "3 a b c".
void appendPlyFaces(std::string& out, std::span<const glm::uvec3> triangles, bool ascii);

/// OBJ: the first line; "v" lines; "vn" lines; "f" lines (1-based, "a//a" when there are normals).
inline constexpr const char* kObjHeader = "# made by isoforge\n";
void appendObjPositions(std::string& out, std::span<const glm::vec3> positions);
void appendObjNormals(std::string& out, std::span<const glm::vec3> normals);
void appendObjFaces(std::string& out, std::span<const glm::uvec3> triangles, bool normals);

/// Binary STL: the 80-byte header and the triangle count; then 50-byte records, each with the
/// facet normal computed from the corners `position(index)`.
std::string stlHeader(std::uint32_t triangles);
void appendStlTriangles(std::string& out, std::span<const glm::uvec3> triangles,
                        const std::function<const glm::vec3&(std::uint32_t)>& position);

}  // namespace isoforge::mesh::records
