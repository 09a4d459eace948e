#include "render/scene.h"

#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>

#include "render/shading.h"

namespace isoforge::render {

Camera frameBox(const implicit::Box3& box, float aspect, glm::vec3 from, float fov) {
    Camera c;
    c.fov = fov;
    const glm::vec3 centre = box.centre();
    const float radius = std::max(0.5f * glm::length(box.size()), 1e-6f);
    // The bounding sphere fits the narrower of the two fields of view.
    const float halfV = glm::radians(fov) * 0.5f;
    const float halfH = std::atan(std::tan(halfV) * aspect);
    const float dist = radius / std::sin(std::min(halfV, halfH)) * 1.02f;
    c.target = centre;
    c.eye = centre - glm::normalize(from) * dist;
    c.up = glm::vec3(0, 0, 1);
    c.orthoHeight = 2.04f * radius * std::max(1.f, 1.f / aspect);
    return c;
}

std::vector<Light> defaultLights(const Camera& camera) {
    const glm::vec3 f = glm::normalize(camera.target - camera.eye);
    glm::vec3 r = glm::cross(f, camera.up);
    r = glm::length(r) > 1e-6f ? glm::normalize(r) : glm::vec3(1, 0, 0);
    const glm::vec3 u = glm::normalize(glm::cross(r, f));
    Light key;  // from above the camera's left shoulder
    key.vector = glm::normalize(f - 0.6f * r - 0.9f * u);
    key.intensity = 0.95f;
    Light fill;  // soft, from the right, no strong highlight
    fill.vector = glm::normalize(f + 0.9f * r + 0.2f * u);
    fill.intensity = 0.3f;
    fill.color = glm::vec3(0.9f, 0.95f, 1.f);
    return {key, fill};
}

glm::vec3 srgbToLinear(glm::vec3 c) {
    return {detail::srgbToLinear1(c.x), detail::srgbToLinear1(c.y), detail::srgbToLinear1(c.z)};
}

Image toImage(const Frame& f) {
    std::vector<std::string> names{"R", "G", "B", "A"};
    if (!f.depth.empty()) names.push_back("Z");
    if (!f.normal.empty()) names.insert(names.end(), {"N.x", "N.y", "N.z"});
    if (!f.objectId.empty()) names.push_back("id");
    Image img(f.width, f.height, static_cast<int>(names.size()));
    img.channelNames = names;
    for (std::size_t i = 0; i < f.pixels(); ++i) {
        float* p = img.pixels.data() + i * names.size();
        for (int k = 0; k < 4; ++k) *p++ = f.color[i][k];
        if (!f.depth.empty()) *p++ = f.depth[i];
        if (!f.normal.empty())
            for (int k = 0; k < 3; ++k) *p++ = f.normal[i][k];
        if (!f.objectId.empty()) *p++ = f.objectId[i];
    }
    return img;
}

Image toDisplayImage(const Frame& f) {
    Image img(f.width, f.height, 3);
    for (std::size_t i = 0; i < f.pixels(); ++i)
        for (int k = 0; k < 3; ++k)
            img.pixels[i * 3 + static_cast<std::size_t>(k)] = std::clamp(f.color[i][k], 0.f, 1.f);
    return img;
}

std::vector<bool> silhouette(const Frame& f) {
    std::vector<bool> s(f.pixels());
    for (std::size_t i = 0; i < f.pixels(); ++i) s[i] = f.color[i].a >= 0.5f;
    return s;
}

}  // namespace isoforge::render
