#include "render/depth_prepass.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <glm/geometric.hpp>

namespace isoforge::render::detail {

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

}  // namespace

DepthSpans depthPrepass(const openvdb::FloatGrid& grid, const std::vector<openvdb::CoordBBox>& boxes,
                        const RayGenerator& gen, const RenderOptions& o) {
    const auto& xform = grid.transform();
    const std::size_t width = static_cast<std::size_t>(o.width);
    const std::size_t pixels = width * static_cast<std::size_t>(o.height);
    // Index space to view space (right, up, forward from the eye) as one affine map, so that a box's
    // eight corners are its first corner plus sums of three edge vectors.
    const openvdb::Mat4d m = xform.baseMap()->getAffineMap()->getMat4();  // row vectors: world = index * m
    const glm::dvec3 axes[3] = {glm::dvec3(gen.right()), glm::dvec3(gen.up()), glm::dvec3(gen.forward())};
    const glm::dvec3 eyeD(gen.camera().eye);
    double lin[3][3], off[3];  // view_k = sum_j lin[k][j] * index_j + off[k]
    for (int k = 0; k < 3; ++k) {
        for (int j = 0; j < 3; ++j) lin[k][j] = axes[k].x * m(j, 0) + axes[k].y * m(j, 1) + axes[k].z * m(j, 2);
        off[k] = axes[k].x * (m(3, 0) - eyeD.x) + axes[k].y * (m(3, 1) - eyeD.y) + axes[k].z * (m(3, 2) - eyeD.z);
    }
    float cx, cy, sx, sy;
    gen.projection(cx, cy, sx, sy);
    const bool ortho = gen.camera().orthographic;
    const bool centreOnly = o.spp <= 1;

    // Pass 1: each box's rectangle of pixels (x0 > x1 when it covers none) and depth range.
    struct Rect {
        int x0, x1, y0, y1;
        float dmin, dmax;
    };
    std::unique_ptr<Rect[]> rects(new Rect[boxes.size()]);
    std::atomic<bool> behind{false};
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, boxes.size(), 1024), [&](const auto& r) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
            Rect& out = rects[i];
            out.x0 = 1;
            out.x1 = 0;
            const openvdb::CoordBBox& box = boxes[i];
            const double b0[3] = {double(box.min().x()), double(box.min().y()), double(box.min().z())};
            const double e[3] = {double(box.max().x()) - b0[0], double(box.max().y()) - b0[1],
                                 double(box.max().z()) - b0[2]};
            double corner[8][3];
            for (int k = 0; k < 3; ++k) {
                corner[0][k] = lin[k][0] * b0[0] + lin[k][1] * b0[1] + lin[k][2] * b0[2] + off[k];
                corner[1][k] = corner[0][k] + lin[k][0] * e[0];
                corner[2][k] = corner[0][k] + lin[k][1] * e[1];
                corner[3][k] = corner[1][k] + lin[k][1] * e[1];
                for (int c = 0; c < 4; ++c) corner[c + 4][k] = corner[c][k] + lin[k][2] * e[2];
            }
            float x0 = kInf, y0 = kInf, x1 = -kInf, y1 = -kInf, dmin = kInf, dmax = -kInf;
            for (const double* v : corner) {
                if (!ortho && v[2] <= 1e-6) {
                    behind = true;
                    return;
                }
                const double inv = ortho ? 1.0 : 1.0 / v[2];
                const float px = cx + sx * float(v[0] * inv), py = cy - sy * float(v[1] * inv), d = float(v[2]);
                x0 = std::min(x0, px);
                x1 = std::max(x1, px);
                y0 = std::min(y0, py);
                y1 = std::max(y1, py);
                dmin = std::min(dmin, d);
                dmax = std::max(dmax, d);
            }
            // The pixels whose samples may fall in the box's projection: with one sample per pixel,
            // those whose centre it covers; with several (jittered in the pixel), those it overlaps.
            // A hundredth of a pixel of slack covers rounding.
            constexpr float kSlack = 0.01f;
            const float W = float(o.width), H = float(o.height);
            if (x1 < -1.f || y1 < -1.f || x0 > W + 1.f || y0 > H + 1.f) continue;
            x0 = std::max(x0, -2.f) - kSlack;
            y0 = std::max(y0, -2.f) - kSlack;
            x1 = std::min(x1, W + 2.f) + kSlack;
            y1 = std::min(y1, H + 2.f) + kSlack;
            out.x0 = std::max(0, centreOnly ? -floorInt(0.5 - x0) : floorInt(x0));
            out.y0 = std::max(0, centreOnly ? -floorInt(0.5 - y0) : floorInt(y0));
            out.x1 = std::min(o.width - 1, floorInt(centreOnly ? x1 - 0.5 : x1));
            out.y1 = std::min(o.height - 1, floorInt(centreOnly ? y1 - 0.5 : y1));
            if (out.y0 > out.y1) out.x0 = out.x1 + 1;
            out.dmin = dmin;
            out.dmax = dmax;
        }
    });
    if (behind) return {};

    // Pass 2: rectangles listed per band of rows (counting sort), then the bands filled in parallel.
    constexpr int kBandRows = 8;
    const int bands = (o.height + kBandRows - 1) / kBandRows;
    std::vector<std::uint32_t> start(static_cast<std::size_t>(bands) + 1, 0);
    for (std::size_t i = 0; i < boxes.size(); ++i)
        if (rects[i].x0 <= rects[i].x1)
            for (int b = rects[i].y0 / kBandRows; b <= rects[i].y1 / kBandRows; ++b) ++start[std::size_t(b) + 1];
    for (int b = 0; b < bands; ++b) start[std::size_t(b) + 1] += start[std::size_t(b)];
    std::vector<std::uint32_t> list(start.back()), fill(start.begin(), start.end() - 1);
    for (std::size_t i = 0; i < boxes.size(); ++i)
        if (rects[i].x0 <= rects[i].x1)
            for (int b = rects[i].y0 / kBandRows; b <= rects[i].y1 / kBandRows; ++b)
                list[fill[std::size_t(b)]++] = static_cast<std::uint32_t>(i);
    DepthSpans depth(pixels);
    tbb::parallel_for(0, bands, [&](int b) {
        const int r0 = b * kBandRows, r1 = std::min(o.height, r0 + kBandRows) - 1;
        for (std::size_t i = std::size_t(r0) * width; i < std::size_t(r1 + 1) * width; ++i) depth[i] = {kInf, -kInf};
        for (std::uint32_t k = start[std::size_t(b)]; k < start[std::size_t(b) + 1]; ++k) {
            const Rect& rc = rects[list[k]];
            for (int y = std::max(rc.y0, r0); y <= std::min(rc.y1, r1); ++y) {
                DepthSpan* row = &depth[std::size_t(y) * width];
                for (int x = rc.x0; x <= rc.x1; ++x) {
                    row[x].near = std::min(row[x].near, rc.dmin);
                    row[x].far = std::max(row[x].far, rc.dmax);
                }
            }
        }
    });
    return depth;
}

std::optional<LightView> LightView::make(const openvdb::FloatGrid& grid, const std::vector<openvdb::CoordBBox>& boxes,
                                         const glm::vec3& shining) {
    const auto& xform = grid.transform();
    if (boxes.empty() || !xform.isLinear()) return std::nullopt;
    openvdb::CoordBBox all;
    for (const openvdb::CoordBBox& b : boxes) all.expand(b);
    glm::vec3 lo(kInf), hi(-kInf);
    for (int c = 0; c < 8; ++c) {
        const openvdb::Vec3d w = xform.indexToWorld(openvdb::Vec3d(c & 1 ? all.max().x() : all.min().x(),
                                                                   c & 2 ? all.max().y() : all.min().y(),
                                                                   c & 4 ? all.max().z() : all.min().z()));
        lo = glm::min(lo, glm::vec3(w.x(), w.y(), w.z()));
        hi = glm::max(hi, glm::vec3(w.x(), w.y(), w.z()));
    }
    const glm::vec3 centre = 0.5f * (lo + hi);
    const float radius = 0.5f * glm::length(hi - lo) + float(grid.voxelSize()[0]);
    Camera cam;
    cam.orthographic = true;
    cam.eye = centre - glm::normalize(shining) * (2.f * radius);
    cam.target = centre;
    cam.orthoHeight = 2.f * radius;
    const int size = std::clamp(int(std::ceil(2.f * radius / float(4.0 * grid.voxelSize()[0]))), 16, 1024);
    RenderOptions o;
    o.width = o.height = size;
    o.spp = 2;  // a box covers every pixel it overlaps, not only those whose centre it covers
    const RayGenerator gen(cam, size, size);
    DepthSpans spans = depthPrepass(grid, boxes, gen, o);
    if (spans.empty()) return std::nullopt;
    return LightView(gen, size, std::move(spans));
}

std::optional<float> LightView::reach(const glm::vec3& p) const {
    float x = 0.f, y = 0.f, depth = 0.f;
    if (!gen_.project(p, x, y, depth)) return std::nullopt;
    const int px = floorInt(x), py = floorInt(y);
    if (px < 0 || py < 0 || px >= size_ || py >= size_) return std::nullopt;
    const DepthSpan& s = spans_[std::size_t(py) * std::size_t(size_) + std::size_t(px)];
    if (!(s.near <= s.far)) return 0.f;  // no box along this light pixel
    return std::max(depth - s.near, 0.f);
}

}  // namespace isoforge::render::detail
