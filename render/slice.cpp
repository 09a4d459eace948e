#include "render/slice.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <vector>

#include <tbb/parallel_for.h>
#include <glm/common.hpp>

namespace isoforge::render {

namespace {

constexpr int kLeaf = 8;  // tiles evaluated point by point
constexpr int kTop = 64;  // tiles handed to threads

struct Slicer {
    const SliceOptions& o;
    Image& img;
    float step;
    std::atomic<std::uint64_t> points{0}, filled{0}, bounds{0};

    glm::vec3 world(float u, float v) const {
        switch (o.axis) {
            case 0:
                return {o.offset, u, v};
            case 1:
                return {u, o.offset, v};
            default:
                return {u, v, o.offset};
        }
    }
    float u(int px) const { return o.lo + (px + 0.5f) * step; }
    float v(int py) const { return o.hi - (py + 0.5f) * step; }

    static void colour(float value, float scale, float* rgb) {
        if (std::isnan(value)) {
            rgb[0] = 1.f, rgb[1] = 0.f, rgb[2] = 1.f;
            return;
        }
        const float d = value / scale;
        const float base[2][3] = {{0.65f, 0.85f, 1.0f}, {0.9f, 0.6f, 0.3f}};
        const float* c = base[d > 0];
        const float shade = (1.f - std::exp(-4.f * std::abs(d))) * (0.8f + 0.2f * std::cos(60.f * d));
        const float line = std::clamp(std::abs(d) * 150.f, 0.f, 1.f);  // white iso-line at 0
        for (int k = 0; k < 3; ++k) rgb[k] = 1.f + (c[k] * shade - 1.f) * line;
    }

    void fill(int x0, int y0, int w, float value) {
        for (int y = y0; y < std::min(y0 + w, o.size); ++y)
            for (int x = x0; x < std::min(x0 + w, o.size); ++x) {
                float* p = img.at(x, y);
                p[0] = p[1] = p[2] = value;
            }
    }

    void visit(int x0, int y0, int w, const implicit::FieldPtr& f) {
        if (x0 >= o.size || y0 >= o.size) return;
        const int x1 = std::min(x0 + w, o.size) - 1, y1 = std::min(y0 + w, o.size) - 1;
        const glm::vec3 a = world(u(x0), v(y1)), b = world(u(x1), v(y0));
        const implicit::Box3 box{glm::min(a, b), glm::max(a, b)};
        if (o.sign) {
            const implicit::Interval r = f->bound(box);
            ++bounds;
            if (r.lo > 0.f || r.hi < 0.f) {
                fill(x0, y0, w, r.lo > 0.f ? 1.f : 0.f);
                ++filled;
                return;
            }
        }
        if (w <= kLeaf) {
            glm::vec3 pts[kLeaf * kLeaf];
            float vals[kLeaf * kLeaf];
            int n = 0;
            for (int y = y0; y <= y1; ++y)
                for (int x = x0; x <= x1; ++x) pts[n++] = world(u(x), v(y));
            f->values(std::span<const glm::vec3>(pts, static_cast<std::size_t>(n)),
                      std::span<float>(vals, static_cast<std::size_t>(n)));
            points += static_cast<std::uint64_t>(n);
            n = 0;
            const float scale = 0.25f * (o.hi - o.lo);
            for (int y = y0; y <= y1; ++y)
                for (int x = x0; x <= x1; ++x, ++n) {
                    float* p = img.at(x, y);
                    if (o.sign)
                        p[0] = p[1] = p[2] = vals[n] < 0.f ? 0.f : 1.f;
                    else
                        colour(vals[n], scale, p);
                }
            return;
        }
        const implicit::FieldPtr g = implicit::simplified(f, box);
        const int h = w / 2;
        visit(x0, y0, h, g);
        visit(x0 + h, y0, h, g);
        visit(x0, y0 + h, h, g);
        visit(x0 + h, y0 + h, h, g);
    }
};

}  // namespace

Image sliceField(const implicit::FieldPtr& field, const SliceOptions& o, SliceStats* stats) {
    if (o.size < 1 || o.size > 32768) throw std::invalid_argument("slice size must be between 1 and 32768 pixels");
    if (!(o.hi > o.lo)) throw std::invalid_argument("slice range must have lo < hi");
    if (o.axis < 0 || o.axis > 2) throw std::invalid_argument("slice axis must be x, y or z");
    const auto t0 = std::chrono::steady_clock::now();
    Image img(o.size, o.size, 3);
    Slicer s{o, img, (o.hi - o.lo) / static_cast<float>(o.size)};
    const int tiles = (o.size + kTop - 1) / kTop;
    tbb::parallel_for(0, tiles * tiles, [&](int t) { s.visit((t % tiles) * kTop, (t / tiles) * kTop, kTop, field); });
    if (stats) {
        stats->pointsEvaluated = s.points;
        stats->tilesFilled = s.filled;
        stats->boundsEvaluated = s.bounds;
        stats->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }
    return img;
}

}  // namespace isoforge::render
