#include "render/ray_march.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include "render/field_grid.h"
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

/// How finely a ray is marched: steps of a quarter of a pixel's footprint at t (t from the eye for
/// camera rays), no shorter than the scene's rounding.
struct Precision {
    float minStep;    ///< the smallest step (the scene's rounding)
    float refine;     ///< crossings are found to within this many steps
    bool resimplify;  ///< simplify the field again as interval subdivision narrows down
};

/// Finds the first zero crossing of a field along a ray.
class Marcher {
public:
    Marcher(const implicit::Field& f, const detail::RayGenerator& rays, const Precision& p)
        : f_(f), rays_(rays), p_(p) {
        const float L = f.gradientBound();
        distance_ = L < std::numeric_limits<float>::infinity();
        invL_ = L > 0.f ? 1.f / L : 1.f;
    }

    /// First t in (ta, tb] where the sign differs from the sign at ta; nullopt if none.
    std::optional<float> first(const detail::Ray& r, float ta, float tb) const {
        if (!(tb > ta)) return std::nullopt;
        float vb;
        return from(r, ta, tb, value(r, ta), vb);
    }
    /// The same, given the value at ta; `vb` is the value at tb where the march took it, else NaN.
    std::optional<float> from(const detail::Ray& r, float ta, float tb, float va, float& vb) const {
        vb = std::numeric_limits<float>::quiet_NaN();
        if (!(tb > ta)) return std::nullopt;
        return distance_ ? sphereTrace(r, ta, tb, va, vb) : subdivide(r, ta, tb, va, 0);
    }

private:
    float value(const detail::Ray& r, float t) const { return f_.value(r.origin + t * r.dir); }
    float eps(float t) const { return std::max(0.25f * rays_.pixelSize(t), p_.minStep); }

    std::optional<float> sphereTrace(const detail::Ray& r, float ta, float tb, float va, float& vb) const {
        const float side = va < 0 ? -1.f : 1.f;
        float t = ta, v = va;
        for (int i = 0; i < 2048 && t <= tb; ++i) {
            // Close to the surface: a hit only where the sign changes within a small step, so that
            // rays grazing the silhouette pass by (exact silhouettes, no dilation by the epsilon).
            const float tn = std::min(t + std::max(side * v * invL_, 0.5f * eps(t)), tb);
            const float vn = value(r, tn);
            if (side * vn < 0) return refine(f_, r, t, tn, side, v, vn);
            if (tn >= tb) {
                vb = vn;
                break;
            }
            t = tn, v = vn;
        }
        return std::nullopt;
    }

    /// Interval subdivision: only segments whose bound may hold 0 are split, down to a quarter pixel.
    /// Every few levels the field is simplified to the segment's box (CSG pruning, tape pruning), so
    /// deep levels evaluate only the children that matter there; not in a grid cell, whose field is
    /// simplified to the cell already (doing it again cost 3.5% more instructions than it saved).
    std::optional<float> subdivide(const detail::Ray& r, float ta, float tb, float va, int depth,
                                   const implicit::Field* g = nullptr) const {
        if (!g) g = &f_;
        const glm::vec3 a = r.origin + ta * r.dir, b = r.origin + tb * r.dir;
        const implicit::Box3 box{glm::min(a, b), glm::max(a, b)};
        implicit::FieldPtr local;
        if (p_.resimplify && depth % 3 == 0 && depth > 0)
            if ((local = g->simplify(box))) g = local.get();
        const implicit::Interval iv = g->bound(box);
        if (iv.lo > 0.f || iv.hi < 0.f) return std::nullopt;
        if (tb - ta <= eps(tb) || depth >= 48) {
            const float vb = g->value(r.origin + tb * r.dir);
            if ((va < 0) != (vb < 0)) return refine(*g, r, ta, tb, va < 0 ? -1.f : 1.f, va, vb);
            return std::nullopt;
        }
        const float tm = 0.5f * (ta + tb), vm = g->value(r.origin + tm * r.dir);
        if ((va < 0) != (vm < 0)) {
            if (auto h = subdivide(r, ta, tm, va, depth + 1, g)) return h;
            return refine(*g, r, ta, tm, va < 0 ? -1.f : 1.f, va, vm);  // a crossing the bound-driven search missed
        }
        if (auto h = subdivide(r, ta, tm, va, depth + 1, g)) return h;
        return subdivide(r, tm, tb, vm, depth + 1, g);
    }

    /// Between a point on the starting side (ta, value va) and one past the surface (tb, vb): the
    /// Illinois variant of regula falsi (a bracket kept, the end that stays put has its value
    /// halved), down to `refine` marching steps or to float resolution.
    float refine(const implicit::Field& g, const detail::Ray& r, float ta, float tb, float side, float va,
                 float vb) const {
        float fa = side * va, fb = side * vb;  // fa >= 0 > fb
        const float tol = std::max(p_.refine * eps(tb), 1e-7f * (1.f + std::abs(tb)));
        int last = 0;
        for (int i = 0; i < 48 && tb - ta > tol && fa > 0.f; ++i) {
            float tm = ta + fa / (fa - fb) * (tb - ta);
            if (!(tm > ta && tm < tb)) tm = 0.5f * (ta + tb);
            const float fm = side * g.value(r.origin + tm * r.dir);
            if (fm >= 0.f) {
                ta = tm, fa = fm;
                if (last > 0) fb *= 0.5f;
                last = 1;
            } else {
                tb = tm, fb = fm;
                if (last < 0) fa *= 0.5f;
                last = -1;
            }
        }
        return ta;  // the last point on the starting side: shading offsets from there stay outside
    }

    const implicit::Field& f_;
    const detail::RayGenerator& rays_;
    bool distance_;  ///< L-Lipschitz with a known L: sphere tracing with steps |value| / L
    float invL_;
    Precision p_;
};

/// A crossing along a ray and the field that holds there (simplified to its cell).
struct Hit {
    float t;
    const implicit::Field* field;
};

/// How close to the surface a crossing is found, in marching steps (a quarter pixel): where camera
/// rays hit, the surface is shaded; a shadow ray needs only the surface it met (and its material).
constexpr float kPrimaryRefine = 0.01f, kShadowRefine = 0.25f;

/// Cells along the longest side of the region in the grid rays walk (render/field_grid.h).
constexpr int kGridCells = 64;

/// The first t in (ta, tb] where the sign differs from the sign at ta, walking the grid: cells whose
/// bound excludes 0 are skipped, the others marched with their own field.
std::optional<Hit> firstInGrid(const detail::FieldGrid& grid, const implicit::Field& whole, const detail::Ray& r,
                               float ta, float tb, const detail::RayGenerator& rays, const Precision& precision,
                               bool opaqueOnly) {
    float side = 0.f;
    float carry = std::numeric_limits<float>::quiet_NaN();  // the value where the last cell's march ended
    std::optional<Hit> hit;
    grid.walk(r.origin, r.dir, ta, tb, [&](std::int32_t code, float c0, float c1) {
        if (code < 0) {
            const float s = code == detail::FieldGrid::kOutside ? 1.f : -1.f;
            if (side == 0.f) side = s;
            carry = std::numeric_limits<float>::quiet_NaN();
            if (s == side) return false;
            hit = Hit{c0, &whole};  // the sign changed on the cell's face
            return true;
        }
        if (opaqueOnly && grid.seeThrough(code)) {  // what happens in there does not matter
            side = 0.f;
            carry = std::numeric_limits<float>::quiet_NaN();
            return false;
        }
        const implicit::Field& f = grid.field(code);
        // Cells share their faces and every cell's field equals the whole field in its cell: where the
        // last cell's march ended, this one starts with the same value.
        const float va = std::isnan(carry) ? f.value(r.origin + c0 * r.dir) : carry;
        const float s = va < 0.f ? -1.f : 1.f;
        if (side == 0.f) side = s;
        if (s != side) {
            hit = Hit{c0, &f};
            return true;
        }
        if (auto t = Marcher(f, rays, precision).from(r, c0, c1, va, carry)) {
            hit = Hit{*t, &f};
            return true;
        }
        return false;
    });
    return hit;
}

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
    // The field cut into cells, each classified by its bound or simplified to itself: every ray,
    // primary or secondary, walks the cells and marches only where the surface may be, with the
    // few nodes that matter there.
    const detail::FieldGrid grid = finite ? detail::FieldGrid(field, region, kGridCells) : detail::FieldGrid();
    const double setupSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    // The first crossing in [ta, tb] (the sign differs from the sign at ta) and the field that
    // holds there (for the normal and the material).
    auto firstHit = [&](const detail::Ray& r, float ta, float tb, bool shadow) -> std::optional<Hit> {
        const Precision precision{eps, shadow ? kShadowRefine : kPrimaryRefine, !finite};
        if (!finite) {
            if (auto t = Marcher(*field, rays, precision).first(r, ta, tb)) return Hit{*t, field.get()};
            return std::nullopt;
        }
        return firstInGrid(grid, *field, r, ta, tb, rays, precision, shadow);
    };
    const implicit::Material plain;
    const bool inside = !region.isEmpty() && field->value(look.camera.eye) < 0.f;

    // Shadows come from opaque surfaces only: translucent layers let light through, as on the
    // Embree path (whose shadow rays see only the opaque objects).
    auto blocked = [&](const glm::vec3& origin, const glm::vec3& d, float tmax) {
        const detail::Ray r{origin, d};
        const auto span = clipRay(r, region);
        if (!span) return false;
        const float tb = std::min(span->second, tmax);
        float t = span->first;
        for (int crossing = 0; crossing < 64; ++crossing) {
            const auto hit = firstHit(r, t, tb, true);
            if (!hit) return false;
            const implicit::Material* m = hit->field->materialAt(r.origin + hit->t * r.dir);
            if (!m || m->color.a >= 1.f) return true;
            t = hit->t + 2.f * std::max(eps, 0.25f * rays.pixelSize(hit->t));  // past the translucent surface
        }
        return false;
    };
    auto trace = [&](const detail::Ray& ray, std::size_t pix, std::size_t s, float py) {
        detail::SampleResult out;
        glm::vec3 acc(0.f);
        float transmit = 1.f;
        const auto span = clipRay(ray, region);
        float t = span ? span->first : 0.f;
        for (int layer = 0; span && layer < 16 && transmit > 0.004f; ++layer) {
            const auto hit = firstHit(ray, t, span->second, false);
            if (!hit) break;
            const implicit::Field& tf = *hit->field;
            detail::Surface surf;
            surf.position = ray.origin + hit->t * ray.dir;
            glm::vec3 n = tf.gradient(surf.position);
            const float nl = glm::length(n);
            n = nl > 0 ? n / nl : -ray.dir;
            if (glm::dot(n, ray.dir) > 0) n = -n;
            surf.normal = n;
            const implicit::Material* m = tf.materialAt(surf.position);
            if (!m) m = &plain;
            surf.albedo = srgbToLinear(glm::vec3(m->color));
            surf.setMaterial(*m);
            const glm::vec3 origin = surf.position + n * std::max(2.f * eps, 0.5f * rays.pixelSize(hit->t));
            acc += transmit * surf.opacity *
                   detail::shadeHit(surf, origin, ray.dir, look, lights, o, aoReach,
                                    static_cast<std::uint32_t>(pix * 64u + s * 16u + static_cast<std::size_t>(layer)),
                                    blocked);
            if (!out.hit) {
                out.hit = true;
                out.depth = hit->t;
                out.normal = n;
                out.id = 1.f;
            }
            transmit *= 1.f - surf.opacity;
            // Past the surface: step to the other side and look for the next crossing.
            t = hit->t + 2.f * std::max(eps, 0.25f * rays.pixelSize(hit->t));
        }
        out.color = acc + transmit * background.at(py, o.height);
        return out;
    };
    std::uint64_t hitPixels = 0;
    Frame f = detail::renderTiles(look, o, trace, hitPixels);
    if (stats) {
        stats->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        stats->setupSeconds = setupSeconds;
        stats->primaryRays = f.pixels() * static_cast<std::size_t>(std::max(o.spp, 1));
        stats->hitPixels = hitPixels;
        if (inside) stats->warnings.push_back("the camera is inside an object: the view shows its inside surface");
        if (region.isEmpty()) stats->warnings.push_back("nothing to render: the scene is empty");
    }
    return f;
}

}  // namespace isoforge::render
