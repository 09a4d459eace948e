#pragma once
/// @file Writing a mesh a piece at a time, when the whole mesh does not fit in memory (out-of-core and
/// distributed meshing, volume/bricked.h): the file is the same bytes that writeMesh (mesh/io.h) writes
/// for the whole mesh. PLY (binary or ASCII) and OBJ keep their vertices and triangles in scratch files
/// beside the output until commit() writes the header and the records; binary STL is written as it
/// comes and its count patched at the end. The output appears atomically, on commit() only.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <span>

#include <glm/vec3.hpp>

#include "core/atomic_file.h"
#include "core/scratch_file.h"

namespace isoforge::mesh {

struct StreamOptions {
    bool ascii = false;    ///< PLY: ASCII instead of binary little-endian
    bool normals = false;  ///< addVertices gets one normal per vertex
    /// addVertices gets one colour per vertex; the file has colours only if some vertex is not white
    /// (as the scene mesher keeps them: volume/surface.h)
    bool colors = false;
};

class MeshStreamWriter {
public:
    /// @throw IoError for a format that cannot be streamed (.glb: its header holds the bounds of every
    ///        accessor) or an unwritable directory.
    MeshStreamWriter(std::filesystem::path path, const StreamOptions& options);
    ~MeshStreamWriter();  ///< without commit(), no file is left

    /// Appends vertices, numbered on from the ones before; normals and colours as the options say.
    void addVertices(std::span<const glm::vec3> positions, std::span<const glm::vec3> normals,
                     std::span<const glm::vec3> colors);
    /// Appends triangles; `position(i)` gives vertex i's position (STL writes positions, not indices):
    /// the vertices a triangle uses may come later than it.
    void addTriangles(std::span<const glm::uvec3> triangles,
                      const std::function<const glm::vec3&(std::uint32_t)>& position);
    /// Writes the file. @throw IoError on a failed write; no file is then left.
    void commit();

    std::uint64_t vertexCount() const { return vertices_; }
    std::uint64_t triangleCount() const { return triangles_; }

    /// True for the formats that can be streamed: .ply, .obj, .stl.
    static bool canStream(const std::filesystem::path& path);

private:
    enum class Format { Ply, Obj, Stl };
    std::filesystem::path path_;
    StreamOptions options_;
    Format format_;
    std::unique_ptr<AtomicFile> stl_;
    std::unique_ptr<ScratchFile> positions_, normals_, colors_, faces_;
    std::uint64_t vertices_ = 0, triangles_ = 0;
    bool anyColor_ = false;
};

}  // namespace isoforge::mesh
