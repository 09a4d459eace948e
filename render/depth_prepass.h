#pragma once
/// @file The grid marcher's depth pre-pass (render/grid_march.cpp): the boxes that hold every crossed cell,
/// rasterized from the camera (where each pixel's rays may cross a surface) and from each directional light
/// (where its shadow rays may meet one). Internal to render/.

#include <memory>
#include <optional>
#include <vector>

#include <openvdb/openvdb.h>

#include "render/scene.h"
#include "render/shading.h"

namespace isoforge::render::detail {

/// floor() for index and pixel positions (std::floor is a library call without SSE4.1), clamped to a
/// billion either way (NaN to the low end) so that the conversion stays defined for any camera.
inline int floorInt(double x) {
    if (!(x > -1e9)) x = -1e9;
    if (x > 1e9) x = 1e9;
    const int i = static_cast<int>(x);
    return i - (x < double(i));
}

/// View depths between which a pixel's rays may cross a surface (near > far: none).
struct DepthSpan {
    float near, far;
};

/// The pre-pass's result: one span per pixel, or none (the pre-pass does not apply).
class DepthSpans {
public:
    DepthSpans() = default;
    explicit DepthSpans(std::size_t pixels) : spans_(new DepthSpan[pixels]) {}  // filled by the caller
    bool empty() const { return !spans_; }
    DepthSpan& operator[](std::size_t i) { return spans_[i]; }
    const DepthSpan& operator[](std::size_t i) const { return spans_[i]; }

private:
    std::unique_ptr<DepthSpan[]> spans_;
};

/// Depth pre-pass: per pixel, the nearest and farthest view depths of the boxes that hold every
/// crossed cell of every layer (volume::crossedCellBoxes) and cover the pixel's samples. Every
/// crossing along the pixel's rays lies in such a box, so marching need only cover that span, and
/// pixels no box covers see the background. Empty when a box is not wholly in front of a perspective
/// camera. Two parallel passes: the boxes' pixel rectangles, then bands of rows, each filling its
/// rows from the rectangles that reach them (no per-thread image buffers to merge).
DepthSpans depthPrepass(const openvdb::FloatGrid& grid, const std::vector<openvdb::CoordBBox>& boxes,
                        const RayGenerator& gen, const RenderOptions& o);

/// The boxes seen from a directional light: an orthographic view looking along it, framing every box, in
/// light pixels of about four voxels, each box covering every pixel it overlaps. A shadow ray from p runs
/// along one light pixel (parallel to the view), so every surface it can meet lies between the pixel's
/// nearest box depth and p.
class LightView {
public:
    /// Empty (std::nullopt) where it does not apply: no boxes, or a transform that is not affine.
    static std::optional<LightView> make(const openvdb::FloatGrid& grid, const std::vector<openvdb::CoordBBox>& boxes,
                                         const glm::vec3& shining);
    /// How far (world units) a shadow ray from p towards the light must go to pass every box on its
    /// way: 0 when there is none; std::nullopt when p is outside the view (march the whole ray).
    std::optional<float> reach(const glm::vec3& p) const;

private:
    LightView(const RayGenerator& gen, int size, DepthSpans spans) : gen_(gen), size_(size), spans_(std::move(spans)) {}
    RayGenerator gen_;
    int size_;
    DepthSpans spans_;
};

}  // namespace isoforge::render::detail
