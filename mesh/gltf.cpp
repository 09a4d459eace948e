#include "mesh/gltf.h"

#include <cmath>
#include <cstring>
#include <sstream>

#include <tiny_gltf.h>
#include <glm/common.hpp>

#include "core/error.h"

namespace isoforge::mesh::detail {

namespace {

float srgbToLinear(float c) {
    return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}

/// Appends `bytes` to the single buffer (4-byte aligned) as a new buffer view; returns its index.
int addView(tinygltf::Model& model, const void* bytes, std::size_t size, int target) {
    std::vector<unsigned char>& data = model.buffers[0].data;
    while (data.size() % 4) data.push_back(0);
    tinygltf::BufferView view;
    view.buffer = 0;
    view.byteOffset = data.size();
    view.byteLength = size;
    view.target = target;
    const auto* b = static_cast<const unsigned char*>(bytes);
    data.insert(data.end(), b, b + size);
    model.bufferViews.push_back(view);
    return static_cast<int>(model.bufferViews.size()) - 1;
}

int addVec3Accessor(tinygltf::Model& model, const std::vector<glm::vec3>& values, bool bounds) {
    tinygltf::Accessor a;
    a.bufferView = addView(model, values.data(), values.size() * sizeof(glm::vec3), TINYGLTF_TARGET_ARRAY_BUFFER);
    a.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
    a.type = TINYGLTF_TYPE_VEC3;
    a.count = values.size();
    if (bounds && !values.empty()) {  // required for POSITION
        glm::vec3 lo = values[0], hi = values[0];
        for (const glm::vec3& v : values) {
            lo = glm::min(lo, v);
            hi = glm::max(hi, v);
        }
        a.minValues = {lo.x, lo.y, lo.z};
        a.maxValues = {hi.x, hi.y, hi.z};
    }
    model.accessors.push_back(a);
    return static_cast<int>(model.accessors.size()) - 1;
}

}  // namespace

std::string encodeGlb(const TriMesh& mesh) {
    tinygltf::Model model;
    model.asset.version = "2.0";
    model.asset.generator = "isoforge";
    model.buffers.emplace_back();

    tinygltf::Primitive prim;
    prim.mode = TINYGLTF_MODE_TRIANGLES;
    prim.attributes["POSITION"] = addVec3Accessor(model, mesh.positions, true);
    if (!mesh.normals.empty() && mesh.normals.size() == mesh.positions.size())
        prim.attributes["NORMAL"] = addVec3Accessor(model, mesh.normals, false);
    if (!mesh.colors.empty() && mesh.colors.size() == mesh.positions.size()) {
        std::vector<glm::vec3> linear(mesh.colors.size());
        for (std::size_t i = 0; i < linear.size(); ++i)
            for (int c = 0; c < 3; ++c) linear[i][c] = srgbToLinear(mesh.colors[i][c]);
        prim.attributes["COLOR_0"] = addVec3Accessor(model, linear, false);
    }
    tinygltf::Accessor idx;
    idx.bufferView = addView(model, mesh.triangles.data(), mesh.triangles.size() * sizeof(glm::uvec3),
                             TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
    idx.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
    idx.type = TINYGLTF_TYPE_SCALAR;
    idx.count = mesh.triangles.size() * 3;
    model.accessors.push_back(idx);
    prim.indices = static_cast<int>(model.accessors.size()) - 1;

    tinygltf::Material material;
    material.name = "isoforge";
    material.pbrMetallicRoughness.metallicFactor = 0.0;
    material.pbrMetallicRoughness.roughnessFactor = 0.6;
    material.doubleSided = false;
    model.materials.push_back(material);
    prim.material = 0;

    tinygltf::Mesh m;
    m.name = "isoforge";
    m.primitives.push_back(prim);
    model.meshes.push_back(m);
    tinygltf::Node node;
    node.mesh = 0;
    model.nodes.push_back(node);
    tinygltf::Scene scene;
    scene.nodes.push_back(0);
    model.scenes.push_back(scene);
    model.defaultScene = 0;

    std::ostringstream out;
    tinygltf::TinyGLTF writer;
    if (!writer.WriteGltfSceneToStream(&model, out, false, true))
        throw IoError("glTF: tinygltf could not encode the mesh");
    return std::move(out).str();
}

}  // namespace isoforge::mesh::detail
