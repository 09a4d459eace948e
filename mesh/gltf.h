#pragma once
/// @file Internal to mesh/: glTF 2.0 binary (.glb) encoding through tinygltf.

#include <string>

#include "mesh/trimesh.h"

namespace isoforge::mesh::detail {

/// The bytes of a .glb holding one mesh: POSITION (with its bounds), NORMAL where the mesh has normals,
/// COLOR_0 where it has colours (converted from the sRGB that TriMesh stores to the linear RGB glTF
/// requires), 32-bit indices, and a rough non-metallic material so viewers show the vertex colours.
std::string encodeGlb(const TriMesh& mesh);

}  // namespace isoforge::mesh::detail
