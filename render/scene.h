#pragma once
/// @file What the renderers draw and how: camera, lights, background, options, and the frame they
/// produce (colour plus optional depth, normal and object-id channels). Plain values: the app fills
/// them from a scene file, a grid or a mesh; `render` never parses.

#include <cstdint>
#include <memory>
#include <new>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "implicit/field.h"
#include "render/image.h"

namespace isoforge {
class Progress;
}

namespace isoforge::render {

struct Camera {
    glm::vec3 eye{0.f, -5.f, 3.f}, target{0.f}, up{0.f, 0.f, 1.f};
    float fov = 40.f;  ///< vertical field of view, degrees (perspective)
    bool orthographic = false;
    float orthoHeight = 0.f;  ///< height of the view in world units (orthographic); 0: as fov sees the target
};

struct Light {
    bool point = false;  ///< point light at `vector`; else directional, shining along `vector`
    glm::vec3 vector{-1.f, -1.f, -2.f};
    glm::vec3 color{1.f};
    float intensity = 1.f;
};

/// Everything about the look that is not geometry.
struct Look {
    Camera camera;
    std::vector<Light> lights;  ///< empty: a key and a fill light from the camera's side
    glm::vec3 backgroundTop{0.85f, 0.9f, 1.f}, backgroundBottom{0.55f, 0.6f, 0.7f};  ///< sRGB; top to bottom
    float ambient = 0.22f;                                                           ///< hemispherical ambient light
};

/// A camera looking at `box` from direction `from` (towards the box), framing it with a margin.
Camera frameBox(const implicit::Box3& box, float aspect, glm::vec3 from = glm::vec3(-0.55f, 1.f, -0.45f),
                float fov = 35.f);
/// The lights used when a scene gives none: a key light over the camera's shoulder and a soft fill.
std::vector<Light> defaultLights(const Camera& camera);

struct RenderOptions {
    int width = 1024, height = 768;
    int spp = 1;             ///< samples per pixel (a fixed low-discrepancy pattern: deterministic)
    bool shadows = true;     ///< occlusion rays to each light
    int aoSamples = 0;       ///< ambient-occlusion rays per hit (0: off)
    float aoDistance = 0.f;  ///< reach of those rays (0: 5% of the scene's size)
    bool depth = false, normal = false, objectId = false;  ///< extra channels (AOVs)
    Progress* progress = nullptr;
};

struct RenderStats {
    double seconds = 0;       ///< the whole call
    double setupSeconds = 0;  ///< of which building acceleration structures (Embree's BVH)
    std::uint64_t primaryRays = 0;
    std::uint64_t hitPixels = 0;
    std::vector<std::string> warnings;
};

/// An allocator that leaves elements default-initialized rather than value-initialized, on 64-byte
/// (cache line) boundaries: resizing a frame's colour buffer (16 MB at 1024x1024) costs no serial zero
/// fill, since the renderers write every pixel from their parallel tiles, and rows of 4 pixels can be
/// written as whole cache lines.
template <class T>
struct UninitializedAllocator : std::allocator<T> {
    static constexpr std::size_t kAlignment = 64;
    template <class U>
    struct rebind {
        using other = UninitializedAllocator<U>;
    };
    UninitializedAllocator() = default;
    template <class U>
    UninitializedAllocator(const UninitializedAllocator<U>&) noexcept {}
    T* allocate(std::size_t n) {
        if (n > std::size_t(-1) / sizeof(T)) throw std::bad_array_new_length();
        return static_cast<T*>(::operator new(n * sizeof(T), std::align_val_t(kAlignment)));
    }
    void deallocate(T* p, std::size_t) noexcept { ::operator delete(p, std::align_val_t(kAlignment)); }
    template <class U, class... Args>
    void construct(U* p, Args&&... args) {
        ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
    }
    template <class U>
    void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
        ::new (static_cast<void*>(p)) U;
    }
};

/// Linear-light colour per pixel (row 0 at the top), alpha = coverage, and the AOVs asked for:
/// depth (distance along the ray to the first surface, +inf on background), world normal of the
/// first surface, object id (+1; 0 on background).
struct Frame {
    int width = 0, height = 0;
    std::vector<glm::vec4, UninitializedAllocator<glm::vec4>> color;
    std::vector<float> depth;
    std::vector<glm::vec3> normal;
    std::vector<float> objectId;
    std::size_t pixels() const { return static_cast<std::size_t>(width) * static_cast<std::size_t>(height); }
};

/// The frame as an image: R, G, B, A, then Z, N.x, N.y, N.z, id where present (EXR keeps them all;
/// 8-bit formats take the colour only: see toDisplayImage).
Image toImage(const Frame& frame);
/// Colour only, composited over nothing (alpha dropped): for PNG and JPEG.
Image toDisplayImage(const Frame& frame);

/// sRGB-encoded [0, 1] to linear light, and back.
glm::vec3 srgbToLinear(glm::vec3 c);

/// Fraction of pixels whose coverage (alpha) is at least 0.5: for silhouettes.
std::vector<bool> silhouette(const Frame& frame);

}  // namespace isoforge::render
