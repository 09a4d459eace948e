#include "render/grid_march.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>

#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/RayIntersector.h>
#include <tbb/enumerable_thread_specific.h>
#include <glm/geometric.hpp>

#include "render/shading.h"

namespace isoforge::render {

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
using Intersector = openvdb::tools::VolumeRayIntersector<openvdb::FloatGrid, 0>;  // spans of leaf nodes
using Accessor = openvdb::FloatGrid::ConstAccessor;
using IndexRay = openvdb::math::Ray<double>;

struct ThreadState {
    Intersector inter;
    Accessor acc;
};

struct Crossing {
    double t;     ///< index-ray time of the last sample on the near side
    int layer;    ///< which iso-surface
    bool inward;  ///< entering the inside of that layer
};

class GridMarcher {
public:
    GridMarcher(const openvdb::FloatGrid& g, const std::vector<IsoLayer>& layers, bool below)
        : g_(g), layers_(layers), below_(below), levelSet_(g.getGridClass() == openvdb::GRID_LEVEL_SET) {
        voxel_ = g.voxelSize()[0];
        // OpenVDB maps row vectors (world = index * M), so the world gradient is M^-1 times the index one.
        affine_ = g.transform().isLinear();
        if (affine_) {
            const openvdb::Mat3d j = g.transform().baseMap()->getAffineMap()->getMat4().getMat3();
            const openvdb::Mat3d inv = j.inverse();
            for (int r = 0; r < 3; ++r)
                for (int c = 0; c < 3; ++c) inv_[r][c] = inv(r, c);
        }
    }

    /// Trilinear value at index position p. When the eight corners lie in one leaf (7 cells in 8
    /// per axis), they are read straight from its buffer; otherwise through the accessor.
    float sample(Accessor& acc, const openvdb::Vec3d& p) const {
        float c[8];
        const openvdb::Vec3d f = corners(acc, p, c);
        return trilinear(c, f);
    }
    static float trilinear(const float* c, const openvdb::Vec3d& f) {
        const float fx = float(f.x()), fy = float(f.y()), fz = float(f.z());
        const float x00 = c[0] + (c[4] - c[0]) * fx, x01 = c[1] + (c[5] - c[1]) * fx;
        const float x10 = c[2] + (c[6] - c[2]) * fx, x11 = c[3] + (c[7] - c[3]) * fx;
        const float y0 = x00 + (x10 - x00) * fy, y1 = x01 + (x11 - x01) * fy;
        return y0 + (y1 - y0) * fz;
    }
    /// The eight corner values (index i = dx * 4 + dy * 2 + dz) of the cell holding p, and p's
    /// fractional position in it.
    static openvdb::Vec3d corners(Accessor& acc, const openvdb::Vec3d& p, float* c) {
        const openvdb::Coord ijk = openvdb::Coord::floor(p);
        const openvdb::Vec3d f = p - ijk.asVec3d();
        const int lx = ijk.x() & 7, ly = ijk.y() & 7, lz = ijk.z() & 7;
        if (lx < 7 && ly < 7 && lz < 7) {
            if (const auto* leaf = acc.probeConstLeaf(ijk)) {
                const float* d = leaf->buffer().data() + ((lx << 6) | (ly << 3) | lz);
                c[0] = d[0];
                c[1] = d[1];
                c[2] = d[8];
                c[3] = d[9];
                c[4] = d[64];
                c[5] = d[65];
                c[6] = d[72];
                c[7] = d[73];
                return f;
            }
        }
        for (int i = 0; i < 8; ++i) c[i] = acc.getValue(ijk.offsetBy(i >> 2, (i >> 1) & 1, i & 1));
        return f;
    }
    unsigned insideMask(float v) const {
        unsigned m = 0;
        for (std::size_t i = 0; i < layers_.size(); ++i)
            if (below_ ? v < layers_[i].iso : v > layers_[i].iso) m |= 1u << i;
        return m;
    }

    /// The first crossing of any layer along the index ray, after time tStart.
    std::optional<Crossing> first(ThreadState& st, const IndexRay& ray, double tStart, double tEnd) const {
        if (!st.inter.setIndexRay(ray)) return std::nullopt;
        double t0 = 0, t1 = 0, prevT = -1;
        unsigned prevMask = 0;
        bool havePrev = false;
        while (st.inter.march(t0, t1)) {
            if (t1 < tStart) continue;
            if (t0 > tEnd) break;
            // Across a gap between spans (inactive values), the samples either side still bracket a crossing.
            double t = std::max(t0, tStart);
            const double end = std::min(t1, tEnd);
            for (;;) {
                const float v = sample(st.acc, ray(t));
                const unsigned mask = insideMask(v);
                if (havePrev && mask != prevMask) return refine(st.acc, ray, prevT, t, prevMask, mask);
                havePrev = true;
                prevT = t;
                prevMask = mask;
                if (t >= end) break;
                // Half a voxel at least (a crossing between two samples is found by its sign change);
                // in a level set, the distance to the nearest iso-value allows longer steps.
                double step = 0.5;
                if (levelSet_) {
                    float near = kInf;
                    for (const IsoLayer& l : layers_) near = std::min(near, std::abs(v - l.iso));
                    step = std::max(0.9 * double(near) / voxel_, 0.5);
                }
                t = std::min(t + step, end);
            }
        }
        return std::nullopt;
    }

    /// The first crossing in [ta, tb] by plain stepping (no tree traversal): for rays started next to
    /// the surface by the depth pre-pass. The side at ta must be the outside of every layer.
    std::optional<Crossing> near(Accessor& acc, const IndexRay& ray, double ta, double tb, bool& startInside) const {
        startInside = false;
        double t = ta, prevT = ta;
        float prevV = 0.f;
        unsigned prevMask = 0;
        bool havePrev = false;
        while (t <= tb) {
            const float v = sample(acc, ray(t));
            const unsigned mask = insideMask(v);
            if (!havePrev && mask != 0) {  // not outside here: let the full path decide, from the eye
                startInside = true;
                return std::nullopt;
            }
            if (havePrev && mask != prevMask) {
                if (layers_.size() > 1 || t - prevT > 1.0) return refine(acc, ray, prevT, t, prevMask, mask);
                // One level-set layer bracketed within a voxel: its values are distances, near-linear
                // along the ray, so the two samples' interpolation is the crossing (no more samples).
                const double x =
                    prevT + (t - prevT) * std::clamp(double(prevV - layers_[0].iso) / double(prevV - v), 0.0, 1.0);
                return Crossing{std::max(prevT, x - 1e-3), 0, true};
            }
            havePrev = true;
            prevT = t;
            prevV = v;
            prevMask = mask;
            float near = kInf;
            for (const IsoLayer& l : layers_) near = std::min(near, std::abs(v - l.iso));
            t += std::max(0.9 * double(near) / voxel_, 0.5);
        }
        return std::nullopt;
    }

    /// Bisection on the first layer whose side changes between ta (mask ma) and tb (mask mb).
    Crossing refine(Accessor& acc, const IndexRay& ray, double ta, double tb, unsigned ma, unsigned mb) const {
        Crossing best{tb, 0, false};
        for (std::size_t i = 0; i < layers_.size(); ++i) {
            const unsigned bit = 1u << i;
            if ((ma & bit) == (mb & bit)) continue;
            // Two bisections, then the linear interpolation of the bracket (trilinear values are
            // close to linear within a tenth of a voxel): sub-voxel precision for a few samples.
            const float iso = layers_[i].iso;
            double a = ta, b = tb;
            for (int k = 0; k < 2; ++k) {
                const double m = 0.5 * (a + b);
                if ((insideMask(sample(acc, ray(m))) & bit) == (ma & bit))
                    a = m;
                else
                    b = m;
            }
            const double fa = sample(acc, ray(a)) - iso, fb = sample(acc, ray(b)) - iso;
            if (fa != fb) {
                const double x = a + (b - a) * std::clamp(fa / (fa - fb), 0.0, 1.0);
                // Keep the answer on the near side: step back a hair if the interpolation crossed.
                a = (insideMask(sample(acc, ray(x))) & bit) == (ma & bit) ? x : a + 0.999 * (x - a);
            }
            if (a < best.t || best.t == tb) best = {a, static_cast<int>(i), (mb & bit) != 0};
        }
        return best;
    }

    /// Outward normal (world) at index position p: the gradient of the trilinear interpolant of the
    /// cell holding p (one fetch of its eight corners), mapped to world space.
    glm::vec3 normal(Accessor& acc, const openvdb::Vec3d& p) const {
        float c[8];
        const openvdb::Vec3d f = corners(acc, p, c);
        const double fx = f.x(), fy = f.y(), fz = f.z();
        auto lerp = [](double a, double b, double t) { return a + (b - a) * t; };
        // d/dx: difference of the x = 1 and x = 0 faces, bilinear in (y, z); likewise for y and z.
        const double gx = lerp(lerp(c[4] - c[0], c[6] - c[2], fy), lerp(c[5] - c[1], c[7] - c[3], fy), fz);
        const double gy = lerp(lerp(c[2] - c[0], c[6] - c[4], fx), lerp(c[3] - c[1], c[7] - c[5], fx), fz);
        const double gz = lerp(lerp(c[1] - c[0], c[5] - c[4], fx), lerp(c[3] - c[2], c[7] - c[6], fx), fy);
        const openvdb::Vec3d g(gx, gy, gz);
        openvdb::Vec3d w = affine_ ? openvdb::Vec3d(inv_[0][0] * g.x() + inv_[0][1] * g.y() + inv_[0][2] * g.z(),
                                                    inv_[1][0] * g.x() + inv_[1][1] * g.y() + inv_[1][2] * g.z(),
                                                    inv_[2][0] * g.x() + inv_[2][1] * g.y() + inv_[2][2] * g.z())
                                   : g_.transform().baseMap()->applyIJT(g, p);
        if (!below_) w = -w;
        const double len = w.length();
        return len > 0 ? glm::vec3(w.x() / len, w.y() / len, w.z() / len) : glm::vec3(0, 0, 1);
    }

private:
    const openvdb::FloatGrid& g_;
    const std::vector<IsoLayer>& layers_;
    bool below_, levelSet_, affine_ = false;
    double voxel_;
    double inv_[3][3] = {};
};

}  // namespace

Frame marchGrid(const openvdb::FloatGrid& grid, const std::vector<IsoLayer>& layers, bool insideBelow, const Look& look,
                const RenderOptions& o, RenderStats* stats) {
    const auto start = std::chrono::steady_clock::now();
    if (o.width <= 0 || o.height <= 0) throw std::invalid_argument("image size must be positive");
    if (layers.empty() || layers.size() > 16) throw std::invalid_argument("give 1 to 16 iso-surfaces");
    if (!grid.hasUniformVoxels())
        throw std::invalid_argument("the grid's voxels are not cubes: render it with --method mesh");
    const std::vector<Light> lights = look.lights.empty() ? defaultLights(look.camera) : look.lights;
    const detail::Background background(look);
    std::uint64_t hitPixels = 0;
    if (grid.tree().activeVoxelCount() == 0 && grid.tree().activeTileCount() == 0) {
        Frame f = detail::renderTiles(
            look, o,
            [&](const detail::Ray&, std::size_t, std::size_t, float py) {
                detail::SampleResult r;
                r.color = background.at(py, o.height);
                return r;
            },
            hitPixels);
        if (stats) stats->warnings.push_back("the grid has no active values: nothing to render");
        return f;
    }
    const Intersector master(grid);
    tbb::enumerable_thread_specific<ThreadState> states([&] { return ThreadState{master, Accessor(grid.tree())}; });
    const GridMarcher marcher(grid, layers, insideBelow);
    const auto& xform = grid.transform();
    const double voxel = grid.voxelSize()[0];

    auto toIndexRay = [&](const glm::vec3& o3, const glm::vec3& d3) {
        const IndexRay w(openvdb::Vec3d(o3.x, o3.y, o3.z), openvdb::Vec3d(d3.x, d3.y, d3.z));
        return w.worldToIndex(grid);  // index-ray time = world distance / voxel size
    };
    auto blocked = [&](ThreadState& st, const glm::vec3& origin, const glm::vec3& d, float tmax) {
        // Shadows: only opaque layers block light.
        const IndexRay r = toIndexRay(origin, d);
        double t = 0;
        const double end = std::isfinite(tmax) ? double(tmax) / voxel : std::numeric_limits<double>::max();
        for (int k = 0; k < 16; ++k) {
            const auto c = marcher.first(st, r, t, end);
            if (!c) return false;
            if (layers[static_cast<std::size_t>(c->layer)].material.color.a >= 1.f) return true;
            t = c->t + 0.3;
        }
        return false;
    };
    // Depth pre-pass for level sets seen from outside: the nearest view depth, per pixel, of the leaf
    // nodes whose values come within 1.5 voxels of an iso-value (where every crossing lies). A ray's
    // first crossing is inside one of the boxes its pixel is covered by, so marching may start at that
    // depth, and pixels no box covers see the background. Rays that find nothing near their start fall
    // back to the full traversal.
    const detail::RayGenerator gen(look.camera, o.width, o.height);
    std::vector<float> nearDepth;
    {
        const openvdb::Vec3d eyeIndex =
            xform.worldToIndex(openvdb::Vec3d(look.camera.eye.x, look.camera.eye.y, look.camera.eye.z));
        openvdb::CoordBBox grown = grid.evalActiveVoxelBoundingBox();
        grown.expand(2);
        const bool eyeOutside = !grown.isInside(openvdb::Coord::floor(eyeIndex));
        if (grid.getGridClass() == openvdb::GRID_LEVEL_SET && grid.tree().activeTileCount() == 0 && eyeOutside &&
            xform.isLinear()) {
            nearDepth.assign(static_cast<std::size_t>(o.width) * static_cast<std::size_t>(o.height),
                             std::numeric_limits<float>::infinity());
            const float reach = float(1.5 * voxel);
            bool ok = true;
            for (auto leaf = grid.tree().cbeginLeaf(); leaf && ok; ++leaf) {
                float lo = kInf, hi = -kInf;
                for (auto v = leaf->cbeginValueAll(); v; ++v) {
                    lo = std::min(lo, *v);
                    hi = std::max(hi, *v);
                }
                bool surface = false;
                for (const IsoLayer& l : layers) surface = surface || (lo - l.iso < reach && hi - l.iso > -reach);
                if (!surface) continue;
                const openvdb::Coord org = leaf->origin();
                float x0 = kInf, y0 = kInf, x1 = -kInf, y1 = -kInf, dmin = kInf;
                for (int c = 0; c < 8; ++c) {
                    const openvdb::Vec3d ic(org.x() + (c & 1 ? 9.0 : -1.0), org.y() + (c & 2 ? 9.0 : -1.0),
                                            org.z() + (c & 4 ? 9.0 : -1.0));
                    const openvdb::Vec3d w = xform.indexToWorld(ic);
                    float px, py, d;
                    if (!gen.project(glm::vec3(float(w.x()), float(w.y()), float(w.z())), px, py, d)) {
                        ok = false;
                        break;
                    }
                    x0 = std::min(x0, px);
                    x1 = std::max(x1, px);
                    y0 = std::min(y0, py);
                    y1 = std::max(y1, py);
                    dmin = std::min(dmin, d);
                }
                if (!ok) break;
                // One pixel of margin: samples are jittered inside their pixel.
                const int ix0 = std::max(0, int(std::floor(x0)) - 1), ix1 = std::min(o.width - 1, int(x1) + 1);
                const int iy0 = std::max(0, int(std::floor(y0)) - 1), iy1 = std::min(o.height - 1, int(y1) + 1);
                for (int y = iy0; y <= iy1; ++y)
                    for (int x = ix0; x <= ix1; ++x) {
                        float& z = nearDepth[static_cast<std::size_t>(y) * static_cast<std::size_t>(o.width) +
                                             static_cast<std::size_t>(x)];
                        z = std::min(z, dmin);
                    }
            }
            if (!ok) nearDepth.clear();
        }
    }
    auto trace = [&](const detail::Ray& ray, std::size_t pix, std::size_t s, float py) {
        ThreadState& st = states.local();
        detail::SampleResult out;
        glm::vec3 acc(0.f);
        float transmit = 1.f;
        const IndexRay iray = toIndexRay(ray.origin, ray.dir);
        double t = 0;
        std::optional<Crossing> early;
        if (!nearDepth.empty()) {
            const float d = nearDepth[pix];
            if (!std::isfinite(d)) {
                out.color = background.at(py, o.height);
                return out;
            }
            // Start at the box depth (a little before), look for a crossing within four leaves.
            t = std::max(0.0, double(d) / double(glm::dot(ray.dir, gen.forward())) / voxel - 1.0);
            bool startInside = false;
            early = marcher.near(st.acc, iray, t, t + 32.0, startInside);
            if (startInside) t = 0;
        }
        for (int layer = 0; layer < 16 && transmit > 0.004f; ++layer) {
            const auto c = layer == 0 && early ? early : marcher.first(st, iray, t, std::numeric_limits<double>::max());
            if (!c) break;
            const openvdb::Vec3d ip = iray(c->t);
            const openvdb::Vec3d wp = xform.indexToWorld(ip);
            const IsoLayer& L = layers[static_cast<std::size_t>(c->layer)];
            detail::Surface surf;
            surf.position = glm::vec3(wp.x(), wp.y(), wp.z());
            glm::vec3 n = marcher.normal(st.acc, ip);
            if (glm::dot(n, ray.dir) > 0) n = -n;
            surf.normal = n;
            surf.albedo = srgbToLinear(glm::vec3(L.material.color));
            surf.setMaterial(L.material);
            const glm::vec3 origin = surf.position + n * float(0.75 * voxel);
            const float tWorld = float(c->t * voxel);
            acc += transmit * surf.opacity *
                   detail::shadeHit(
                       surf, origin, ray.dir, look, lights, o, o.aoDistance > 0 ? o.aoDistance : float(20 * voxel),
                       static_cast<std::uint32_t>(pix * 64u + s * 16u + static_cast<std::size_t>(layer)),
                       [&](const glm::vec3& org, const glm::vec3& d, float tmax) { return blocked(st, org, d, tmax); });
            if (!out.hit) {
                out.hit = true;
                out.depth = tWorld;
                out.normal = n;
                out.id = float(c->layer + 1);
            }
            transmit *= 1.f - surf.opacity;
            t = c->t + 0.3;  // past this crossing
        }
        out.color = acc + transmit * background.at(py, o.height);
        return out;
    };
    Frame f = detail::renderTiles(look, o, trace, hitPixels);
    if (stats) {
        stats->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        stats->primaryRays = f.pixels() * static_cast<std::size_t>(std::max(o.spp, 1));
        stats->hitPixels = hitPixels;
        const openvdb::Vec3d e =
            xform.worldToIndex(openvdb::Vec3d(look.camera.eye.x, look.camera.eye.y, look.camera.eye.z));
        Accessor a(grid.tree());
        if (marcher.insideMask(openvdb::tools::BoxSampler::sample(a, e)) != 0)
            stats->warnings.push_back("the camera is inside a surface: the view shows it from inside");
    }
    return f;
}

}  // namespace isoforge::render
