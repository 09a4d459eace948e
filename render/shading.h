#pragma once
/// @file Internal to render/: camera rays, the sample pattern, and the shading model shared by the
/// Embree and ray-marching renderers (so that the two paths give the same image for the same hits).

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>
#include <glm/vec2.hpp>

#include "core/progress.h"
#include "render/scene.h"

namespace isoforge::render::detail {

struct Ray {
    glm::vec3 origin, dir;  ///< dir is unit length
};

/// Up to 16 rays as structure of arrays (what Embree's packets take, and what loops over lanes
/// vectorize).
struct RayBlock {
    alignas(64) float ox[16], oy[16], oz[16];
    alignas(64) float dx[16], dy[16], dz[16];
    Ray operator[](int k) const { return {{ox[k], oy[k], oz[k]}, {dx[k], dy[k], dz[k]}}; }
};

/// Rays through pixel positions (x, y in pixels, y down, (0, 0) the top-left corner).
class RayGenerator {
public:
    RayGenerator(const Camera& c, int width, int height) : c_(c), w_(width), h_(height) {
        f_ = glm::normalize(c.target - c.eye);
        r_ = glm::cross(f_, c.up);
        if (glm::length(r_) < 1e-6f)
            r_ = glm::cross(f_, std::abs(f_.z) < 0.9f ? glm::vec3(0, 0, 1) : glm::vec3(1, 0, 0));
        r_ = glm::normalize(r_);
        u_ = glm::cross(r_, f_);
        aspect_ = float(width) / float(height);
        half_ = c.orthographic
                    ? 0.5f * (c.orthoHeight > 0
                                  ? c.orthoHeight
                                  : 2.f * glm::length(c.target - c.eye) * std::tan(glm::radians(c.fov) * 0.5f))
                    : std::tan(glm::radians(c.fov) * 0.5f);
        halfX_ = half_ * aspect_;
        sxScale_ = 2.f / float(width);
        syScale_ = 2.f / float(height);
    }
    Ray operator()(float x, float y) const {
        const float sx = (x * sxScale_ - 1.f) * halfX_, sy = (1.f - y * syScale_) * half_;
        const glm::vec3 a = sx * r_, b = sy * u_;
        if (c_.orthographic) return {c_.eye + a + b, f_};
        const glm::vec3 d = f_ + a + b;
        return {c_.eye, d * (1.f / std::sqrt(glm::dot(d, d)))};
    }
    /// The rays through 16 pixel positions, as operator() gives them one by one (the same
    /// operations in the same order, in loops over the lanes that the compiler vectorizes).
    void block(const float* x, const float* y, RayBlock& out) const {
        alignas(64) float sx[16], sy[16];
        for (int k = 0; k < 16; ++k) {
            sx[k] = (x[k] * sxScale_ - 1.f) * halfX_;
            sy[k] = (1.f - y[k] * syScale_) * half_;
        }
        if (c_.orthographic) {
            for (int k = 0; k < 16; ++k) {
                out.ox[k] = c_.eye.x + sx[k] * r_.x + sy[k] * u_.x;
                out.oy[k] = c_.eye.y + sx[k] * r_.y + sy[k] * u_.y;
                out.oz[k] = c_.eye.z + sx[k] * r_.z + sy[k] * u_.z;
                out.dx[k] = f_.x;
                out.dy[k] = f_.y;
                out.dz[k] = f_.z;
            }
            return;
        }
        for (int k = 0; k < 16; ++k) {
            const float dx = f_.x + sx[k] * r_.x + sy[k] * u_.x, dy = f_.y + sx[k] * r_.y + sy[k] * u_.y,
                        dz = f_.z + sx[k] * r_.z + sy[k] * u_.z;
            const float inv = 1.f / std::sqrt(dx * dx + dy * dy + dz * dz);
            out.ox[k] = c_.eye.x;
            out.oy[k] = c_.eye.y;
            out.oz[k] = c_.eye.z;
            out.dx[k] = dx * inv;
            out.dy[k] = dy * inv;
            out.dz[k] = dz * inv;
        }
    }
    /// World size of a pixel at distance t along a ray (for epsilons and step limits).
    float pixelSize(float t) const {
        return (c_.orthographic ? 2.f * half_ : 2.f * half_ * std::max(t, 1e-6f)) / float(h_);
    }
    const glm::vec3& forward() const { return f_; }
    const glm::vec3& right() const { return r_; }
    const glm::vec3& up() const { return u_; }
    const Camera& camera() const { return c_; }
    /// Pixel x = centreX + scaleX * (view x / view depth), y = centreY - scaleY * (view y / view
    /// depth) for perspective cameras; without the division for orthographic ones.
    void projection(float& centreX, float& centreY, float& scaleX, float& scaleY) const {
        centreX = 0.5f * float(w_);
        centreY = 0.5f * float(h_);
        scaleX = 0.5f * float(w_) / (half_ * aspect_);
        scaleY = 0.5f * float(h_) / half_;
    }
    /// Pixel position (x, y) and view depth (along forward()) of a world point; false when the
    /// point is not in front of a perspective camera.
    bool project(const glm::vec3& p, float& x, float& y, float& depth) const {
        const glm::vec3 d = p - c_.eye;
        depth = glm::dot(d, f_);
        if (!c_.orthographic && depth <= 1e-6f) return false;
        const float scale = c_.orthographic ? 1.f : depth;
        const float sx = glm::dot(d, r_) / (scale * half_ * aspect_), sy = glm::dot(d, u_) / (scale * half_);
        x = 0.5f * (sx + 1.f) * float(w_);
        y = 0.5f * (1.f - sy) * float(h_);
        return true;
    }

private:
    Camera c_;
    int w_, h_;
    glm::vec3 f_, r_, u_;
    float aspect_, half_, halfX_, sxScale_, syScale_;
};

/// Sub-pixel offsets: the R2 low-discrepancy sequence (Roberts), the first one at the centre.
inline std::vector<glm::vec2> samplePattern(int spp) {
    std::vector<glm::vec2> s;
    for (int k = 0; k < std::max(spp, 1); ++k) {
        const double a = 0.5 + k * 0.7548776662466927, b = 0.5 + k * 0.5698402909980532;
        s.emplace_back(float(a - std::floor(a)), float(b - std::floor(b)));
    }
    return s;
}

inline float srgbToLinear1(float c) {
    return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}

/// A smooth (interpolated) normal `n`, already on the side of the surface that the ray along `dir`
/// sees, may still lean away from the viewer: at a crease of a mesh, vertex normals belong to the
/// other face. Shaded as it is, such a pixel comes out as dark as a face turned from the light (dark
/// specks along the crease); bent towards the viewer until it is just front-facing, it shades like
/// its neighbours. Normals that face the viewer are unchanged. Lanes and single rays both use this.
/// Selects, no branches: it runs inside the loops over a packet's lanes, which the compiler vectorizes.
inline void bendTowardsViewer(float& x, float& y, float& z, float dx, float dy, float dz) {
    const float d = x * dx + y * dy + z * dz;
    const float b = d > 0.f ? d + 0.01f : 0.f;
    x -= b * dx, y -= b * dy, z -= b * dz;
    const float l = std::sqrt(x * x + y * y + z * z);
    const float scale = d > 0.f && l > 0.f ? 1.f / l : 1.f;  // unbent normals stay exactly as they were
    x *= scale, y *= scale, z *= scale;
}
inline glm::vec3 bendTowardsViewer(glm::vec3 n, const glm::vec3& dir) {
    bendTowardsViewer(n.x, n.y, n.z, dir.x, dir.y, dir.z);
    return n;
}

/// What a hit needs to be shaded.
struct Surface {
    glm::vec3 position, normal;  ///< normal: unit, facing the viewer
    glm::vec3 albedo;            ///< linear
    float opacity = 1.f;
    float diffuse = 0.9f, specular = 0.25f, shininess = 40.f;
    /// Opacity and Phong terms from a material (the albedo is set by the caller: vertex colours).
    void setMaterial(const implicit::Material& m) {
        opacity = m.color.a;
        diffuse = m.diffuse;
        specular = m.specular;
        shininess = m.shininess;
    }
};

/// The frame's lights as shading uses them: the look's lights (or the default rig), with the unit
/// vector towards each directional light and each light's radiance computed once per frame.
class LightSet {
public:
    explicit LightSet(const Look& look) : lights_(look.lights.empty() ? defaultLights(look.camera) : look.lights) {
        for (const Light& l : lights_) {
            towards_.push_back(l.point ? glm::vec3(0.f) : -glm::normalize(l.vector));
            radiance_.push_back(l.color * l.intensity);
        }
    }
    std::size_t size() const { return lights_.size(); }
    const Light& operator[](std::size_t i) const { return lights_[i]; }
    /// Unit vector from p towards light i.
    glm::vec3 towards(std::size_t i, const glm::vec3& p) const {
        return lights_[i].point ? glm::normalize(lights_[i].vector - p) : towards_[i];
    }
    /// How far a shadow ray from p towards light i goes (infinity for directional lights).
    float reach(std::size_t i, const glm::vec3& p) const {
        return lights_[i].point ? glm::length(lights_[i].vector - p) : std::numeric_limits<float>::infinity();
    }
    const glm::vec3& radiance(std::size_t i) const { return radiance_[i]; }

private:
    std::vector<Light> lights_;
    std::vector<glm::vec3> towards_, radiance_;
};

/// Whole exponents up to this are raised by repeated squaring (a few multiplications instead of
/// powf); others go through std::pow.
constexpr float kMaxIntegerShininess = 1024.f;

/// x^e for the specular lobe (x in [0, 1]): by squaring when e is a whole number up to
/// kMaxIntegerShininess (materials' usual 10, 40, 100), else std::pow. The two agree to a few ulps.
inline float specularPower(float x, float e) {
    if (!(e >= 0.f && e <= kMaxIntegerShininess && e == std::floor(e))) return std::pow(x, e);
    float r = 1.f;
    for (unsigned n = static_cast<unsigned>(e); n; n >>= 1) {
        if (n & 1u) r *= x;
        x *= x;
    }
    return r;
}

/// Blinn-Phong with a hemispherical ambient term; `visible(l, L)` tells whether light l (unit vector
/// L towards it) reaches the point (shadows), `ambientOcclusion` scales the ambient term.
template <class Visible>
glm::vec3 shade(const Surface& s, const glm::vec3& viewDir, const LightSet& lights, float ambient,
                float ambientOcclusion, Visible&& visible) {
    const glm::vec3 v = -viewDir;
    const float hemi = 0.6f + 0.4f * s.normal.z;  // sky above (+z up), ground below
    glm::vec3 c = s.albedo * (ambient * hemi * ambientOcclusion);
    for (std::size_t i = 0; i < lights.size(); ++i) {
        const glm::vec3 L = lights.towards(i, s.position);
        const float nl = glm::dot(s.normal, L);
        if (nl <= 0.f) continue;
        if (!visible(i, L)) continue;
        const glm::vec3 h = glm::normalize(L + v);
        const float spec = s.specular * specularPower(std::max(glm::dot(s.normal, h), 0.f), s.shininess);
        c += lights.radiance(i) * (s.albedo * (s.diffuse * nl) + glm::vec3(spec));
    }
    return c;
}

/// Up to 16 opaque hits as structure of arrays, for shadeLanes. Lanes without a hit (on[k] == 0)
/// hold harmless values (clear() sets them), so that loops may run over all 16.
struct HitLanes {
    alignas(64) int on[16];                    ///< -1 for lanes holding a hit, else 0
    alignas(64) float px[16], py[16], pz[16];  ///< hit positions
    alignas(64) float nx[16], ny[16], nz[16];  ///< unit normals, facing the viewer
    alignas(64) float qx[16], qy[16], qz[16];  ///< where secondary rays start (just off the surface)
    alignas(64) float ar[16], ag[16], ab[16];  ///< albedo, linear
    alignas(64) float kd[16], ks[16], shin[16];
    alignas(64) float ao[16];  ///< ambient occlusion factor (1: none)
    void clear() {
        std::fill_n(on, 16, 0);
        for (float* a : {px, py, pz, nx, ny, qx, qy, qz, ar, ag, ab, kd, ks}) std::fill_n(a, 16, 0.f);
        for (float* a : {nz, shin, ao}) std::fill_n(a, 16, 1.f);
    }
    void setMaterial(int k, const glm::vec3& albedo, const implicit::Material& m) {
        ar[k] = albedo.x, ag[k] = albedo.y, ab[k] = albedo.z;
        kd[k] = m.diffuse, ks[k] = m.specular, shin[k] = m.shininess;
    }
};

/// Blinn-Phong with the hemispherical ambient term for every lane of `h`, as shade() computes it
/// one hit at a time (the same operations, in loops over the lanes that the compiler vectorizes):
/// colours into r, g, b. For each light, `shadow(li, lx, ly, lz, reach, lit)` is given the unit
/// vectors towards light li, how far it is, and the lanes it would light (lit[k] == -1); it sets
/// lit[k] = 0 where something blocks the way.
template <class Shadow>
void shadeLanes(const HitLanes& h, const RayBlock& rays, const LightSet& lights, float ambient, Shadow&& shadow,
                float* r, float* g, float* b) {
    for (int k = 0; k < 16; ++k) {
        const float a = ambient * (0.6f + 0.4f * h.nz[k]) * h.ao[k];
        r[k] = h.ar[k] * a, g[k] = h.ag[k] * a, b[k] = h.ab[k] * a;
    }
    // One whole specular exponent for every lane (one material, or several alike): raised by
    // squaring across the lanes; otherwise lane by lane.
    float exponent = 0.f;
    bool first = true, oneExponent = true;
    for (int k = 0; k < 16; ++k)
        if (h.on[k]) {
            if (first) exponent = h.shin[k], first = false;
            oneExponent = oneExponent && h.shin[k] == exponent;
        }
    const bool wholeExponent =
        oneExponent && exponent >= 0.f && exponent <= kMaxIntegerShininess && exponent == std::floor(exponent);
    constexpr float kInf = std::numeric_limits<float>::infinity();
    for (std::size_t li = 0; li < lights.size(); ++li) {
        alignas(64) float lx[16], ly[16], lz[16], reach[16], nl[16];
        const Light& light = lights[li];
        if (light.point) {
            for (int k = 0; k < 16; ++k) {
                const float dx = light.vector.x - h.px[k], dy = light.vector.y - h.py[k], dz = light.vector.z - h.pz[k];
                const float l = std::sqrt(dx * dx + dy * dy + dz * dz);
                const float d = l > 0.f ? l : 1.f;
                lx[k] = dx / d, ly[k] = dy / d, lz[k] = dz / d;
                const float rx = light.vector.x - h.qx[k], ry = light.vector.y - h.qy[k], rz = light.vector.z - h.qz[k];
                reach[k] = std::sqrt(rx * rx + ry * ry + rz * rz);
            }
        } else {
            const glm::vec3 L = lights.towards(li, glm::vec3(0.f));
            for (int k = 0; k < 16; ++k) lx[k] = L.x, ly[k] = L.y, lz[k] = L.z, reach[k] = kInf;
        }
        for (int k = 0; k < 16; ++k) nl[k] = h.nx[k] * lx[k] + h.ny[k] * ly[k] + h.nz[k] * lz[k];
        alignas(64) int lit[16];
        int litCount = 0;
        for (int k = 0; k < 16; ++k) {
            lit[k] = h.on[k] & (nl[k] > 0.f ? -1 : 0);
            litCount -= lit[k];
        }
        if (litCount == 0) continue;
        shadow(li, lx, ly, lz, reach, lit);
        alignas(64) float nh[16], spec[16];
        for (int k = 0; k < 16; ++k) {
            const float hx = lx[k] - rays.dx[k], hy = ly[k] - rays.dy[k], hz = lz[k] - rays.dz[k];
            const float l = std::sqrt(hx * hx + hy * hy + hz * hz);
            const float d = l > 0.f ? l : 1.f;
            nh[k] = std::max((h.nx[k] * hx + h.ny[k] * hy + h.nz[k] * hz) / d, 0.f);
        }
        if (wholeExponent) {
            for (int k = 0; k < 16; ++k) spec[k] = 1.f;
            for (unsigned e = static_cast<unsigned>(exponent); e; e >>= 1) {
                if (e & 1u)
                    for (int k = 0; k < 16; ++k) spec[k] *= nh[k];
                for (int k = 0; k < 16; ++k) nh[k] *= nh[k];
            }
        } else {
            for (int k = 0; k < 16; ++k) spec[k] = h.on[k] ? specularPower(nh[k], h.shin[k]) : 0.f;
        }
        const glm::vec3 rad = lights.radiance(li);
        for (int k = 0; k < 16; ++k) {
            const float dnl = h.kd[k] * nl[k], sp = h.ks[k] * spec[k];
            r[k] += lit[k] ? rad.x * (h.ar[k] * dnl + sp) : 0.f;
            g[k] += lit[k] ? rad.y * (h.ag[k] * dnl + sp) : 0.f;
            b[k] += lit[k] ? rad.z * (h.ab[k] * dnl + sp) : 0.f;
        }
    }
}

/// The background gradient in linear light, converted once per frame.
class Background {
public:
    explicit Background(const Look& look)
        : top_(srgbToLinear1(look.backgroundTop.x), srgbToLinear1(look.backgroundTop.y),
               srgbToLinear1(look.backgroundTop.z)),
          bottom_(srgbToLinear1(look.backgroundBottom.x), srgbToLinear1(look.backgroundBottom.y),
                  srgbToLinear1(look.backgroundBottom.z)) {}
    /// Colour at pixel row y (fractional) of an image `height` rows high.
    glm::vec3 at(float y, int height) const {
        return glm::mix(top_, bottom_, glm::clamp(y / float(std::max(height, 1)), 0.f, 1.f));
    }

private:
    glm::vec3 top_, bottom_;
};

/// Splits the image into 16x16 tiles for parallel rendering.
constexpr int kTile = 16;

/// What tracing one camera sample gives.
struct SampleResult {
    glm::vec3 color{0.f};  ///< linear, background included where the ray ends on it
    bool hit = false;
    float depth = 0.f;
    glm::vec3 normal{0.f};
    float id = 0.f;
};

/// Four samples' colours and coverage (a row of a block) to a 64-byte aligned line of a frame's
/// colour buffer: streaming stores where the target has them (the frame is not read while it is
/// rendered, so fetching its lines into the cache first would be wasted), then finishLines() before
/// the frame is handed on.
inline void writeLine(float* line, const SampleResult* r) {
#if defined(__SSE2__)
    for (int i = 0; i < 4; ++i)
        _mm_stream_ps(line + 4 * i, _mm_setr_ps(r[i].color.x, r[i].color.y, r[i].color.z, r[i].hit ? 1.f : 0.f));
#else
    for (int i = 0; i < 4; ++i) {
        line[4 * i] = r[i].color.x, line[4 * i + 1] = r[i].color.y, line[4 * i + 2] = r[i].color.z;
        line[4 * i + 3] = r[i].hit ? 1.f : 0.f;
    }
#endif
}
/// Orders the streaming stores of writeLine before what follows (other threads then see them).
inline void finishLines() {
#if defined(__SSE2__)
    _mm_sfence();
#endif
}

/// The tile loop all renderers share: TBB over 16x16 tiles, each cut into 4x4 blocks; per block and
/// sample index, `traceBlock(rays, count, pixelIndices, sampleIndex, yPixels, results)` traces up to
/// 16 camera samples at once (a RayBlock: Embree packets), filling `results`. AOVs come from the
/// first sample, progress is reported per tile. Every pixel is computed alone, so the frame does not
/// depend on the thread count. Every pixel of the colour buffer is written by its tile (no serial
/// clearing of the frame first).
template <class TraceBlock>
Frame renderBlocks(const Look& look, const RenderOptions& o, TraceBlock&& traceBlock, std::uint64_t& hitPixels) {
    Frame f;
    f.width = o.width;
    f.height = o.height;
    f.color.resize(f.pixels());  // uninitialized: each tile writes its pixels
    if (o.depth) f.depth.assign(f.pixels(), std::numeric_limits<float>::infinity());
    if (o.normal) f.normal.assign(f.pixels(), glm::vec3(0.f));
    if (o.objectId) f.objectId.assign(f.pixels(), 0.f);
    const RayGenerator rays(look.camera, o.width, o.height);
    const auto pattern = samplePattern(o.spp);
    const int tilesX = (o.width + kTile - 1) / kTile, tilesY = (o.height + kTile - 1) / kTile;
    const bool anyAov = o.depth || o.normal || o.objectId;
    // Rows of 4 pixels from a column multiple of 4 are whole cache lines when rows are whole lines.
    const bool wholeLines =
        o.width % 4 == 0 &&
        reinterpret_cast<std::uintptr_t>(f.color.data()) % UninitializedAllocator<glm::vec4>::kAlignment == 0;
    std::atomic<std::uint64_t> hits{0};
    std::atomic<std::size_t> tilesDone{0};
    if (o.progress) o.progress->begin("rendering");
    tbb::parallel_for(tbb::blocked_range<int>(0, tilesX * tilesY, 1), [&](const tbb::blocked_range<int>& range) {
        std::uint64_t localHits = 0;
        RayBlock blockRays;
        alignas(64) float blockX[16], blockY[16];
        std::size_t blockPix[16];
        alignas(64) int blockPx[16], blockPy[16];
        SampleResult results[16];
        glm::vec3 sum[16];
        float coverage[16];
        for (int tile = range.begin(); tile != range.end(); ++tile) {
            const int tx = (tile % tilesX) * kTile, ty = (tile / tilesX) * kTile;
            for (int by = ty; by < std::min(ty + kTile, o.height); by += 4)
                for (int bx = tx; bx < std::min(tx + kTile, o.width); bx += 4) {
                    int n = 0;
                    for (int y = by; y < std::min(by + 4, o.height); ++y)
                        for (int x = bx; x < std::min(bx + 4, o.width); ++x) {
                            blockPix[n] = static_cast<std::size_t>(y) * static_cast<std::size_t>(o.width) +
                                          static_cast<std::size_t>(x);
                            blockPx[n] = x;
                            blockPy[n] = y;
                            ++n;
                        }
                    for (int k = n; k < 16; ++k) blockPx[k] = blockPx[0], blockPy[k] = blockPy[0];  // unused lanes
                    for (std::size_t s = 0; s < pattern.size(); ++s) {
                        const float jx = pattern[s].x, jy = pattern[s].y;
                        for (int k = 0; k < 16; ++k) {
                            blockX[k] = float(blockPx[k]) + jx;
                            blockY[k] = float(blockPy[k]) + jy;
                        }
                        for (int k = 0; k < n; ++k) results[k] = SampleResult{};
                        rays.block(blockX, blockY, blockRays);
                        traceBlock(blockRays, n, blockPix, s, blockY, results);
                        if (pattern.size() == 1) {  // the colour is the sample's
                            if (n == 16 && wholeLines) {
                                // Each row of the block is one aligned cache line of the frame: written
                                // by streaming stores, without reading the line first.
                                for (int row = 0; row < 4; ++row)
                                    writeLine(&f.color[blockPix[4 * row]].x, &results[4 * row]);
                            } else {
                                for (int k = 0; k < n; ++k)
                                    f.color[blockPix[k]] = glm::vec4(results[k].color, results[k].hit ? 1.f : 0.f);
                            }
                            for (int k = 0; k < n; ++k) localHits += results[k].hit;
                        } else {
                            for (int k = 0; k < n; ++k) {
                                if (s == 0) sum[k] = glm::vec3(0.f), coverage[k] = 0.f;
                                sum[k] += results[k].color;
                                coverage[k] += results[k].hit ? 1.f : 0.f;
                            }
                        }
                        if (s == 0 && anyAov)
                            for (int k = 0; k < n; ++k)
                                if (results[k].hit) {
                                    if (o.depth) f.depth[blockPix[k]] = results[k].depth;
                                    if (o.normal) f.normal[blockPix[k]] = results[k].normal;
                                    if (o.objectId) f.objectId[blockPix[k]] = results[k].id;
                                }
                    }
                    if (pattern.size() > 1) {
                        const float inv = 1.f / float(pattern.size());
                        for (int k = 0; k < n; ++k) {
                            f.color[blockPix[k]] = glm::vec4(sum[k] * inv, coverage[k] * inv);
                            localHits += coverage[k] > 0;
                        }
                    }
                }
            if (o.progress) o.progress->update(++tilesDone, static_cast<std::size_t>(tilesX * tilesY));
        }
        finishLines();
        hits += localHits;
    });
    if (o.progress) o.progress->end();
    hitPixels = hits;
    return f;
}

/// renderBlocks with a tracer of one sample at a time: `trace(ray, pixelIndex, sampleIndex, yPixel)`.
template <class Trace>
Frame renderTiles(const Look& look, const RenderOptions& o, Trace&& trace, std::uint64_t& hitPixels) {
    return renderBlocks(
        look, o,
        [&](const RayBlock& rays, int n, const std::size_t* pix, std::size_t s, const float* py, SampleResult* out) {
            for (int k = 0; k < n; ++k) out[k] = trace(rays[k], pix[k], s, py[k]);
        },
        hitPixels);
}

/// Deterministic per-pixel random numbers (ambient occlusion).
inline float hashToUnit(std::uint32_t x) {
    x ^= x >> 16;
    x *= 0x7feb352dU;
    x ^= x >> 15;
    x *= 0x846ca68bU;
    x ^= x >> 16;
    return float(x >> 8) * (1.f / 16777216.f);
}

/// Ambient occlusion: the fraction of `samples` cosine-weighted directions around n that `open(d)`
/// says are free, with a fixed hash of (pixel, sample, layer) for the directions.
template <class Open>
float ambientOcclusion(const glm::vec3& n, int samples, std::uint32_t seed, Open&& open) {
    if (samples <= 0) return 1.f;
    const glm::vec3 t1 =
        glm::normalize(std::abs(n.x) < 0.9f ? glm::cross(n, glm::vec3(1, 0, 0)) : glm::cross(n, glm::vec3(0, 1, 0)));
    const glm::vec3 t2 = glm::cross(n, t1);
    int free = 0;
    for (int k = 0; k < samples; ++k) {
        const auto h = seed * 131u + static_cast<std::uint32_t>(k) * 7919u;
        const float r1 = hashToUnit(h), r2 = hashToUnit(h ^ 0x9e3779b9u);
        const float r = std::sqrt(r1), phi = 6.2831853f * r2;
        free += open(r * std::cos(phi) * t1 + r * std::sin(phi) * t2 + std::sqrt(std::max(0.f, 1.f - r1)) * n) ? 1 : 0;
    }
    return float(free) / float(samples);
}

/// A hit shaded as every renderer does: shadow rays to each light and ambient-occlusion rays start at
/// `origin` (just off the surface); `blocked(origin, direction, tmax)` answers whether something is hit.
template <class Blocked>
glm::vec3 shadeHit(const Surface& s, const glm::vec3& origin, const glm::vec3& viewDir, const Look& look,
                   const LightSet& lights, const RenderOptions& o, float aoReach, std::uint32_t seed,
                   Blocked&& blocked) {
    auto visible = [&](std::size_t li, const glm::vec3& L) {
        if (!o.shadows) return true;
        return !blocked(origin, L, lights.reach(li, origin));
    };
    const float ao =
        ambientOcclusion(s.normal, o.aoSamples, seed, [&](const glm::vec3& d) { return !blocked(origin, d, aoReach); });
    return shade(s, viewDir, lights, look.ambient, ao, visible);
}

}  // namespace isoforge::render::detail
