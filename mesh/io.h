#pragma once
/// @file Mesh files: PLY (ASCII and binary, either endianness), Wavefront OBJ, STL (binary and ASCII),
/// OFF (input), glTF 2.0 binary .glb (output, with vertex colours).
/// The format is chosen by the file extension. Readers accept files made by other tools
/// (polygons are fan-triangulated, STL's unshared vertices are welded) and report problems with
/// the file name and position (line:column for text, byte offset for binary). Writers are atomic.

#include <filesystem>
#include <string>

#include "mesh/trimesh.h"

namespace isoforge::mesh {

struct WriteOptions {
    bool ascii = false;  ///< PLY only: ASCII instead of binary little-endian
};

/// Reads a mesh; the format comes from the extension (.ply .obj .stl .off).
/// @throw IoError naming file and position on unreadable, malformed, truncated or hostile files.
TriMesh readMesh(const std::filesystem::path& path);

/// Writes a mesh atomically; the format comes from the extension (.ply .obj .stl .glb).
/// Normals are written where the format can hold them (PLY, OBJ, glTF), colours likewise (PLY, glTF).
/// @throw IoError on an unknown extension or a failed write (no partial file is left).
void writeMesh(const std::filesystem::path& path, const TriMesh& mesh, const WriteOptions& options = {});

/// The bytes of the .glb that writeMesh would write (what `isoforge view` sends to the browser).
std::string glbBytes(const TriMesh& mesh);

/// True if the extension names a mesh format we can write (.ply .obj .stl .glb).
bool isMeshPath(const std::filesystem::path& path);
/// True if the extension names a mesh format we can read (.ply .obj .stl .off).
bool isReadableMeshPath(const std::filesystem::path& path);

}  // namespace isoforge::mesh
