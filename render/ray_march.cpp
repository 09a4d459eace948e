#include "render/ray_march.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include "render/shading.h"

namespace isoforge::render {

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

/// Entry and exit times of a ray through a box (slab test); nullopt if it misses.
std::optional<std::pair<float, float>> clipRay(const detail::Ray& r, const implicit::Box3& b) {
    float t0 = 0.f, t1 = kInf;
    for (int k = 0; k < 3; ++k) {
        const float inv = 1.f / r.dir[k];
        float a = (b.min[k] - r.origin[k]) * inv, c = (b.max[k] - r.origin[k]) * inv;
        if (std::isnan(a) || std::isnan(c)) {  // parallel to the slab, on its plane
            if (r.origin[k] < b.min[k] || r.origin[k] > b.max[k]) return std::nullopt;
            continue;
        }
        if (a > c) std::swap(a, c);
        t0 = std::max(t0, a);
        t1 = std::min(t1, c);
    }
    if (t0 > t1) return std::nullopt;
    return std::make_pair(t0, t1);
}

/// Finds the first zero crossing of a field along a ray.
class Marcher {
public:
    Marcher(const implicit::Field& f, const detail::RayGenerator& rays, float minStep)
        : f_(f), rays_(rays), distance_(f.isDistance()), minStep_(minStep) {}

    /// First t in (ta, tb] where the sign differs from the sign at ta; nullopt if none.
    std::optional<float> first(const detail::Ray& r, float ta, float tb) const {
        if (!(tb > ta)) return std::nullopt;
        const float va = value(r, ta);
        return distance_ ? sphereTrace(r, ta, tb, va) : subdivide(r, ta, tb, va, 0);
    }

private:
    float value(const detail::Ray& r, float t) const { return f_.value(r.origin + t * r.dir); }
    float eps(float t) const { return std::max(0.25f * rays_.pixelSize(t), minStep_); }

    std::optional<float> sphereTrace(const detail::Ray& r, float ta, float tb, float va) const {
        const float side = va < 0 ? -1.f : 1.f;
        float t = ta, v = va;
        for (int i = 0; i < 2048 && t <= tb; ++i) {
            const float d = side * v;
            if (d < 0) return refine(r, t - eps(t), t, side);  // stepped over: the field is not exact there
            // Close to the surface: a hit only where the sign changes within a small step, so that
            // rays grazing the silhouette pass by (exact silhouettes, no dilation by the epsilon).
            const float tn = t + std::max(d, 0.5f * eps(t));
            v = value(r, std::min(tn, tb));
            if (side * v < 0) return refine(r, t, std::min(tn, tb), side);
            t = tn;
        }
        return std::nullopt;
    }

    /// Interval subdivision: only segments whose bound may hold 0 are split, down to a quarter pixel.
    /// Every few levels the field is simplified to the segment's box (CSG pruning, tape pruning), so
    /// deep levels evaluate only the children that matter there.
    std::optional<float> subdivide(const detail::Ray& r, float ta, float tb, float va, int depth,
                                   const implicit::Field* g = nullptr) const {
        if (!g) g = &f_;
        const glm::vec3 a = r.origin + ta * r.dir, b = r.origin + tb * r.dir;
        const implicit::Box3 box{glm::min(a, b), glm::max(a, b)};
        implicit::FieldPtr local;
        if (depth % 3 == 0 && depth > 0)
            if ((local = g->simplify(box))) g = local.get();
        const implicit::Interval iv = g->bound(box);
        if (iv.lo > 0.f || iv.hi < 0.f) return std::nullopt;
        if (tb - ta <= eps(tb) || depth >= 48) {
            const float vb = g->value(r.origin + tb * r.dir);
            if ((va < 0) != (vb < 0)) return refine(*g, r, ta, tb, va < 0 ? -1.f : 1.f);
            return std::nullopt;
        }
        const float tm = 0.5f * (ta + tb), vm = g->value(r.origin + tm * r.dir);
        if ((va < 0) != (vm < 0)) {
            if (auto h = subdivide(r, ta, tm, va, depth + 1, g)) return h;
            return refine(*g, r, ta, tm, va < 0 ? -1.f : 1.f);  // a crossing the bound-driven search missed
        }
        if (auto h = subdivide(r, ta, tm, va, depth + 1, g)) return h;
        return subdivide(r, tm, tb, vm, depth + 1, g);
    }

    /// Bisection between a point on the starting side (ta) and one past the surface (tb).
    float refine(const implicit::Field& g, const detail::Ray& r, float ta, float tb, float side) const {
        for (int i = 0; i < 24 && tb - ta > 1e-7f * (1.f + tb); ++i) {
            const float tm = 0.5f * (ta + tb);
            if (side * g.value(r.origin + tm * r.dir) >= 0)
                ta = tm;
            else
                tb = tm;
        }
        return ta;  // the last point on the starting side: shading offsets from there stay outside
    }
    float refine(const detail::Ray& r, float ta, float tb, float side) const { return refine(f_, r, ta, tb, side); }

    const implicit::Field& f_;
    const detail::RayGenerator& rays_;
    bool distance_;
    float minStep_;
};

}  // namespace

Frame marchField(const implicit::FieldPtr& field, const implicit::Box3& bounds, const Look& look,
                 const RenderOptions& o, RenderStats* stats) {
    const auto t0 = std::chrono::steady_clock::now();
    if (o.width <= 0 || o.height <= 0) throw std::invalid_argument("image size must be positive");
    const detail::RayGenerator rays(look.camera, o.width, o.height);
    const detail::LightSet lights(look);
    const detail::Background background(look);
    const bool finite = !bounds.isEmpty() && bounds.isBounded();
    const float sceneSize = finite ? glm::length(bounds.size()) : 1.f;
    // Rays are clipped to a box a little larger than the bounds: a surface may lie on its own bounds
    // (a box's faces are), and a ray clipped exactly there would start on the surface, on whichever
    // side rounding puts it; one that starts inside finds the far side of the solid as its first hit.
    const glm::vec3 extent = glm::max(glm::abs(bounds.min), glm::abs(bounds.max));
    const float maxCoord = finite ? std::max({extent.x, extent.y, extent.z}) : 0.f;
    const implicit::Box3 region = finite ? bounds.expanded(1e-3f * sceneSize + 1e-5f * maxCoord) : bounds;
    const float eps = 1e-5f * sceneSize;
    const float aoReach = o.aoDistance > 0 ? o.aoDistance : 0.05f * sceneSize;
    // Per 16x16 tile: the field simplified to the box its rays cross (a thin frustum through the
    // scene), so each tile's rays evaluate only the objects they can meet; and simplified to the box
    // that the secondary rays of the tile's hits can cross (shadowField).
    const int tilesX = (o.width + detail::kTile - 1) / detail::kTile;
    const int tilesY = (o.height + detail::kTile - 1) / detail::kTile;
    std::vector<implicit::FieldPtr> tileField(static_cast<std::size_t>(tilesX) * static_cast<std::size_t>(tilesY));
    std::vector<implicit::FieldPtr> shadowField(tileField.size());
    // The region's nearest and farthest depths along the view, and its farthest point from the eye.
    float dmin = kInf, dmax = 0.f, farthest = 0.f;
    for (int c = 0; c < 8; ++c) {
        const glm::vec3 q(c & 1 ? region.max.x : region.min.x, c & 2 ? region.max.y : region.min.y,
                          c & 4 ? region.max.z : region.min.z);
        const float d = glm::dot(q - look.camera.eye, rays.forward());
        dmin = std::min(dmin, d);
        dmax = std::max(dmax, d);
        if (finite) farthest = std::max(farthest, glm::length(q - look.camera.eye));
    }
    dmin = std::max(dmin, 0.f);
    // Secondary rays start at most this far from a hit (half a pixel at the farthest point of the
    // region, see `origin` below), and go no farther than the region's diagonal.
    const float secondaryOffset = std::max(2.f * eps, 0.5f * rays.pixelSize(farthest));
    const float secondaryMargin = 2.f * secondaryOffset + (o.aoSamples > 0 ? aoReach : 0.f);
    const float across = finite ? glm::length(region.size()) : 0.f;
    tbb::parallel_for(std::size_t{0}, tileField.size(), [&](std::size_t k) {
        const int x0 = int(k % std::size_t(tilesX)) * detail::kTile, y0 = int(k / std::size_t(tilesX)) * detail::kTile;
        const float x1 = float(std::min(x0 + detail::kTile, o.width)),
                    y1 = float(std::min(y0 + detail::kTile, o.height));
        // The frustum slab between the region's nearest and farthest depths is inside the hull of the
        // four corner rays at those two depths.
        implicit::Box3 box;
        for (const glm::vec2 c :
             {glm::vec2(float(x0), float(y0)), glm::vec2(x1, float(y0)), glm::vec2(float(x0), y1), glm::vec2(x1, y1)}) {
            const detail::Ray r = rays(c.x, c.y);
            const float cosine = glm::dot(r.dir, rays.forward());
            for (float d : {dmin, dmax}) {
                const glm::vec3 p = r.origin + r.dir * (d / cosine);
                box = box.unite(implicit::Box3{p, p});
            }
        }
        box = box.intersect(region);
        tileField[k] = box.isEmpty() || !box.isBounded() ? field : implicit::simplified(field, box);
        // The tile's hits lie in `box`; their shadow rays start within secondaryMargin of it and run
        // towards a light: a directional one until they leave the region (the box swept along the
        // direction, whose bounding box is that of the box and its far copy), a point light up to it.
        shadowField[k] = field;
        if (!box.isEmpty() && box.isBounded()) {
            const implicit::Box3 from = box.expanded(secondaryMargin);
            implicit::Box3 swept = from;
            for (std::size_t i = 0; i < lights.size(); ++i)
                if (lights[i].point) {
                    swept = swept.unite(implicit::Box3{lights[i].vector, lights[i].vector});
                } else {
                    const glm::vec3 far = lights.towards(i, glm::vec3(0.f)) * across;
                    swept = swept.unite(implicit::Box3{from.min + far, from.max + far});
                }
            swept = swept.intersect(region);
            if (!swept.isEmpty()) shadowField[k] = implicit::simplified(field, swept);
        }
    });
    const implicit::Material plain;
    const bool inside = !region.isEmpty() && field->value(look.camera.eye) < 0.f;

    // Shadows come from opaque surfaces only: translucent layers let light through, as on the
    // Embree path (whose shadow rays see only the opaque objects).
    auto blockedIn = [&](const implicit::Field& f, const glm::vec3& origin, const glm::vec3& d, float tmax) {
        const detail::Ray r{origin, d};
        const auto span = clipRay(r, region);
        if (!span) return false;
        const float tb = std::min(span->second, tmax);
        const Marcher march(f, rays, eps);
        float t = span->first;
        for (int crossing = 0; crossing < 64; ++crossing) {
            const auto hit = march.first(r, t, tb);
            if (!hit) return false;
            const implicit::Material* m = f.materialAt(r.origin + *hit * r.dir);
            if (!m || m->color.a >= 1.f) return true;
            t = *hit + 2.f * std::max(eps, 0.25f * rays.pixelSize(*hit));  // past the translucent surface
        }
        return false;
    };
    auto trace = [&](const detail::Ray& ray, std::size_t pix, std::size_t s, float py) {
        const std::size_t px = pix % std::size_t(o.width), py0 = pix / std::size_t(o.width);
        const std::size_t tile = (py0 / detail::kTile) * std::size_t(tilesX) + px / detail::kTile;
        const implicit::FieldPtr& tf = tileField[tile];
        const implicit::Field& sf = *shadowField[tile];
        auto blocked = [&](const glm::vec3& origin, const glm::vec3& d, float tmax) {
            return blockedIn(sf, origin, d, tmax);
        };
        const Marcher tileMarch(*tf, rays, eps);
        detail::SampleResult out;
        glm::vec3 acc(0.f);
        float transmit = 1.f;
        const auto span = clipRay(ray, region);
        float t = span ? span->first : 0.f;
        for (int layer = 0; span && layer < 16 && transmit > 0.004f; ++layer) {
            const auto hit = tileMarch.first(ray, t, span->second);
            if (!hit) break;
            detail::Surface surf;
            surf.position = ray.origin + *hit * ray.dir;
            glm::vec3 n = tf->gradient(surf.position);
            const float nl = glm::length(n);
            n = nl > 0 ? n / nl : -ray.dir;
            if (glm::dot(n, ray.dir) > 0) n = -n;
            surf.normal = n;
            const implicit::Material* m = tf->materialAt(surf.position);
            if (!m) m = &plain;
            surf.albedo = srgbToLinear(glm::vec3(m->color));
            surf.setMaterial(*m);
            const glm::vec3 origin = surf.position + n * std::max(2.f * eps, 0.5f * rays.pixelSize(*hit));
            acc += transmit * surf.opacity *
                   detail::shadeHit(surf, origin, ray.dir, look, lights, o, aoReach,
                                    static_cast<std::uint32_t>(pix * 64u + s * 16u + static_cast<std::size_t>(layer)),
                                    blocked);
            if (!out.hit) {
                out.hit = true;
                out.depth = *hit;
                out.normal = n;
                out.id = 1.f;
            }
            transmit *= 1.f - surf.opacity;
            // Past the surface: step to the other side and look for the next crossing.
            t = *hit + 2.f * std::max(eps, 0.25f * rays.pixelSize(*hit));
        }
        out.color = acc + transmit * background.at(py, o.height);
        return out;
    };
    std::uint64_t hitPixels = 0;
    Frame f = detail::renderTiles(look, o, trace, hitPixels);
    if (stats) {
        stats->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        stats->primaryRays = f.pixels() * static_cast<std::size_t>(std::max(o.spp, 1));
        stats->hitPixels = hitPixels;
        if (inside) stats->warnings.push_back("the camera is inside an object: the view shows its inside surface");
        if (region.isEmpty()) stats->warnings.push_back("nothing to render: the scene is empty");
    }
    return f;
}

}  // namespace isoforge::render
