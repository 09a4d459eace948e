#pragma once
/// @file Ray casting of triangle meshes with Embree 3: smooth shading from vertex normals,
/// per-object materials (colour or vertex colours, Phong terms, opacity for translucent layers),
/// hard shadows by occlusion rays, optional ambient occlusion, supersampling, TBB over tiles.

#include <string>
#include <vector>

#include "implicit/field.h"
#include "mesh/trimesh.h"
#include "render/scene.h"

namespace isoforge::render {

struct MeshObject {
    const mesh::TriMesh* mesh = nullptr;  ///< not owned; must outlive the call
    implicit::Material material;          ///< colour sRGB; alpha = opacity
    bool vertexColors = true;             ///< use mesh->colors (sRGB) where present
};

/// Renders the objects. Same pixels whatever the thread count.
/// @throw std::runtime_error if Embree cannot be initialized.
Frame renderMeshes(const std::vector<MeshObject>& objects, const Look& look, const RenderOptions& options,
                   RenderStats* stats = nullptr);

}  // namespace isoforge::render
