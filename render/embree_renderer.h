#pragma once
/// @file Ray casting of triangle meshes with Embree 3: smooth shading from vertex normals,
/// per-object materials (colour or vertex colours, Phong terms, opacity for translucent layers),
/// hard shadows by occlusion rays, optional ambient occlusion, supersampling, TBB over tiles.

#include <memory>
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

/// A scene's mesh split into one mesh per material (the field's materialAt at each triangle's centre),
/// as Embree objects want them; `materials` gets one entry per mesh, in order of first use
/// (deterministic); triangles without a material get the default one.
std::vector<mesh::TriMesh> splitByMaterial(const mesh::TriMesh& m, const implicit::Field& field,
                                           std::vector<implicit::Material>& materials);

/// The objects' Embree scene (BVH), vertex normals and materials, built once for any number of
/// views (a turntable, AOV passes). The meshes are not owned and must outlive it.
/// @throw std::runtime_error if Embree cannot be initialized.
class PreparedMeshes {
public:
    explicit PreparedMeshes(const std::vector<MeshObject>& objects);
    ~PreparedMeshes();
    PreparedMeshes(const PreparedMeshes&) = delete;
    PreparedMeshes& operator=(const PreparedMeshes&) = delete;

    /// One frame. Same pixels whatever the thread count; no triangles gives the background and a warning.
    Frame render(const Look& look, const RenderOptions& options, RenderStats* stats = nullptr) const;
    /// Seconds the constructor took (mostly the BVH build).
    double setupSeconds() const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

/// Renders the objects (a PreparedMeshes used once: stats->setupSeconds holds the BVH build, included
/// in stats->seconds). Same pixels whatever the thread count.
/// @throw std::runtime_error if Embree cannot be initialized.
Frame renderMeshes(const std::vector<MeshObject>& objects, const Look& look, const RenderOptions& options,
                   RenderStats* stats = nullptr);

}  // namespace isoforge::render
