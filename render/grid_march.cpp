#include "render/grid_march.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <unordered_map>

#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/RayIntersector.h>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "render/depth_prepass.h"
#include "render/shading.h"
#include "volume/marching_cubes.h"

namespace isoforge::render {

using detail::floorInt;

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
/// Crossed-cell boxes of at most 2^3 cells: the depth pre-pass then starts rays within a voxel or
/// two of the surface (4^3 and 8^3 boxes were slower on the benchmark: fewer boxes to rasterize, but
/// more samples per ray).
constexpr int kBrick = 2;
using Intersector = openvdb::tools::VolumeRayIntersector<openvdb::FloatGrid, 0>;  // spans of leaf nodes
using Accessor = openvdb::FloatGrid::ConstAccessor;
using IndexRay = openvdb::math::Ray<double>;

/// A ray in index space: time along it is world distance over the voxel size.
struct Line {
    openvdb::Vec3d o, d;  ///< d: unit length
    openvdb::Vec3d operator()(double t) const { return o + d * t; }
};

/// Every 8^3 region of the grid's bounding box (and one region of margin each side) in a flat
/// array of pointers to 512 values: a leaf's buffer, or a block holding the constant value of the
/// tile or background there (one shared block per distinct value). A corner fetch then costs an
/// index computation and loads instead of a tree descent; positions outside the array go through
/// the accessor. Not built when the array would pass kMaxRegions (a grid spread far and thin) or the
/// tiles hold more than kMaxConstants distinct values: then every fetch does.
class LeafTable {
public:
    static constexpr std::size_t kMaxRegions = std::size_t{1} << 22;  // 32 MiB of pointers
    static constexpr std::size_t kMaxConstants = 4096;                // 8 MiB of constant blocks

    explicit LeafTable(const openvdb::FloatGrid& grid) {
        const openvdb::FloatTree& tree = grid.tree();
        openvdb::CoordBBox box;  // tiles outside the leaves' box are read through the accessor
        if (!tree.evalLeafBoundingBox(box) || box.empty()) return;
        for (int k = 0; k < 3; ++k) {
            const std::int64_t lo = (std::int64_t(box.min()[k]) & ~std::int64_t{7}) - 8;
            const std::int64_t n = ((std::int64_t(box.max()[k]) & ~std::int64_t{7}) + 16 - lo) / 8;
            if (n > (std::int64_t{1} << 20) || lo < std::numeric_limits<int>::min() / 2) return;
            base_[k] = static_cast<int>(lo);
            dims_[k] = static_cast<int>(n);
        }
        const std::size_t count = std::size_t(dims_[0]) * std::size_t(dims_[1]) * std::size_t(dims_[2]);
        if (count > kMaxRegions) return;
        // First the constant value of every region (tiles level by level: a tile's regions are
        // disjoint from every node below it), then the leaves' buffers, then constants to blocks.
        std::vector<float> value(count, tree.background());
        regions_.assign(count, nullptr);
        using L2 = openvdb::FloatTree::RootNodeType::ChildNodeType;
        using L1 = L2::ChildNodeType;
        for (auto it = tree.root().cbeginValueAll(); it; ++it) fill(value, it.getCoord(), L2::DIM, *it);
        std::vector<const L2*> upper;
        tree.getNodes(upper);
        for (const L2* node : upper)
            for (auto it = node->cbeginValueAll(); it; ++it) fill(value, it.getCoord(), L1::DIM, *it);
        std::vector<const L1*> lower;
        tree.getNodes(lower);
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, lower.size(), 4), [&](const auto& r) {
            for (std::size_t i = r.begin(); i != r.end(); ++i)
                for (auto it = lower[i]->cbeginValueAll(); it; ++it)
                    if (const std::size_t k = indexOf(it.getCoord()); k != kNone) value[k] = *it;
        });
        std::vector<const openvdb::FloatTree::LeafNodeType*> leaves;
        tree.getNodes(leaves);
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, leaves.size(), 1024), [&](const auto& r) {
            for (std::size_t i = r.begin(); i != r.end(); ++i)
                if (const std::size_t k = indexOf(leaves[i]->origin()); k != kNone)
                    regions_[k] = leaves[i]->buffer().data();
        });
        // Constant regions: one block per distinct value (runs of equal values need no lookup).
        std::unordered_map<std::uint32_t, const float*> blocks;
        std::uint32_t lastBits = 0;
        const float* last = nullptr;
        for (std::size_t k = 0; k < count; ++k) {
            if (regions_[k]) continue;
            std::uint32_t bits;
            std::memcpy(&bits, &value[k], sizeof bits);
            if (!last || bits != lastBits) {
                auto [it, fresh] = blocks.emplace(bits, nullptr);
                if (fresh) {
                    if (constants_.size() == kMaxConstants) {
                        regions_.clear();
                        return;
                    }
                    constants_.emplace_back(new float[512]);
                    std::fill_n(constants_.back().get(), 512, value[k]);
                    it->second = constants_.back().get();
                }
                last = it->second;
                lastBits = bits;
            }
            regions_[k] = last;
        }
        for (int k = 0; k < 3; ++k) extent_[k] = 8.0 * dims_[k];
        ok_ = true;
    }
    bool ok() const { return ok_; }
    /// The 512 values of the region holding voxel c (x-major: offset (x & 7) * 64 + (y & 7) * 8 +
    /// (z & 7)), as a pointer into the table, or null outside the array.
    const float* const* at(int cx, int cy, int cz) const {
        // Below the base, the unsigned difference wraps to a huge value and fails the bound too.
        const unsigned x = (unsigned(cx) - unsigned(base_[0])) >> 3, y = (unsigned(cy) - unsigned(base_[1])) >> 3,
                       z = (unsigned(cz) - unsigned(base_[2])) >> 3;
        if (x >= unsigned(dims_[0]) || y >= unsigned(dims_[1]) || z >= unsigned(dims_[2])) return nullptr;
        return &regions_[(std::size_t(x) * std::size_t(dims_[1]) + y) * std::size_t(dims_[2]) + z];
    }
    /// at() for an index position: the region holding it, or null when the table is not built or
    /// the position is outside it (or not a number); with the cell (ix, iy, iz) and the fractions.
    /// Relative to the table's corner positions are not negative, so truncation is floor.
    const float* const* locate(double x, double y, double z, int& ix, int& iy, int& iz, float& fx, float& fy,
                               float& fz) const {
        const double u = x - double(base_[0]), v = y - double(base_[1]), w = z - double(base_[2]);
        if (!(u >= 0.0 && u < extent_[0] && v >= 0.0 && v < extent_[1] && w >= 0.0 && w < extent_[2])) return nullptr;
        const int iu = static_cast<int>(u), iv = static_cast<int>(v), iw = static_cast<int>(w);
        fx = float(u - iu), fy = float(v - iv), fz = float(w - iw);
        ix = iu + base_[0], iy = iv + base_[1], iz = iw + base_[2];
        return &regions_[(std::size_t(iu >> 3) * std::size_t(dims_[1]) + std::size_t(iv >> 3)) * std::size_t(dims_[2]) +
                         std::size_t(iw >> 3)];
    }
    /// True when the regions after the one holding voxel c along x, y and z are in the array too.
    bool hasUpperNeighbours(int cx, int cy, int cz) const {
        return ((cx - base_[0]) >> 3) + 1 < dims_[0] && ((cy - base_[1]) >> 3) + 1 < dims_[1] &&
               ((cz - base_[2]) >> 3) + 1 < dims_[2];
    }
    /// Index offsets between neighbouring regions along x and y (z: 1).
    std::size_t strideX() const { return std::size_t(dims_[1]) * std::size_t(dims_[2]); }
    std::size_t strideY() const { return std::size_t(dims_[2]); }

private:
    static constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();
    /// The array index of the region holding voxel c, or kNone outside.
    std::size_t indexOf(const openvdb::Coord& c) const {
        const float* const* r = at(c.x(), c.y(), c.z());
        return r ? static_cast<std::size_t>(r - regions_.data()) : kNone;
    }
    /// Sets the value of the regions of a cubic tile (origin, edge `dim` voxels) inside the array.
    void fill(std::vector<float>& value, const openvdb::Coord& origin, int dim, float v) const {
        int lo[3], hi[3];
        for (int k = 0; k < 3; ++k) {
            lo[k] = std::max(origin[k], base_[k]);
            hi[k] = static_cast<int>(
                std::min<std::int64_t>(std::int64_t(origin[k]) + (dim - 1), std::int64_t(base_[k]) + dims_[k] * 8 - 1));
            if (lo[k] > hi[k]) return;
        }
        for (int x = lo[0]; x <= hi[0]; x += 8)
            for (int y = lo[1]; y <= hi[1]; y += 8)
                for (int z = lo[2]; z <= hi[2]; z += 8) value[indexOf(openvdb::Coord(x, y, z))] = v;
    }

    int base_[3] = {0, 0, 0};
    int dims_[3] = {0, 0, 0};
    double extent_[3] = {0, 0, 0};  ///< voxels covered along each axis (0 when not built: every locate fails)
    std::vector<const float*> regions_;
    std::vector<std::unique_ptr<float[]>> constants_;
    bool ok_ = false;
};

/// OpenVDB's span intersector, built on first use: its constructor copies the tree's topology,
/// which rays started by the depth pre-pass never need.
class SharedIntersector {
public:
    explicit SharedIntersector(const openvdb::FloatGrid& g) : g_(g) {}
    const Intersector& get() const {
        std::call_once(once_, [&] { master_ = std::make_unique<Intersector>(g_); });
        return *master_;
    }

private:
    const openvdb::FloatGrid& g_;
    mutable std::once_flag once_;
    mutable std::unique_ptr<Intersector> master_;
};

struct ThreadState {
    ThreadState(const SharedIntersector& s, const openvdb::FloatGrid& g, const LeafTable& t)
        : shared(&s), acc(g.tree()), table(&t) {}
    const SharedIntersector* shared;
    std::unique_ptr<Intersector> inter;
    Accessor acc;
    const LeafTable* table;

    Intersector& intersector() {
        if (!inter) inter = std::make_unique<Intersector>(shared->get());
        return *inter;
    }
};

struct Crossing {
    Crossing(double time, int l, bool in) : t(time), layer(l), inward(in) {}
    double t;     ///< index-ray time of the last sample on the near side
    int layer;    ///< which iso-surface
    bool inward;  ///< entering the inside of that layer
    bool hasGradient = false;
    openvdb::Vec3d gradient;  ///< index-space gradient at t, when hasGradient
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
                for (int c = 0; c < 3; ++c) invf_[r][c] = float(inv(r, c));
        }
    }

    /// Trilinear value at index position p.
    static float sample(ThreadState& st, const openvdb::Vec3d& p) {
        float c[8];
        const openvdb::Vec3d f = corners(st, p, c);
        return trilinear(c, f);
    }
    static float trilinear(const float* c, float fx, float fy, float fz) {
        const float x00 = c[0] + (c[4] - c[0]) * fx, x01 = c[1] + (c[5] - c[1]) * fx;
        const float x10 = c[2] + (c[6] - c[2]) * fx, x11 = c[3] + (c[7] - c[3]) * fx;
        const float y0 = x00 + (x10 - x00) * fy, y1 = x01 + (x11 - x01) * fy;
        return y0 + (y1 - y0) * fz;
    }
    /// Index-space gradient of the trilinear interpolant of a cell at fractions (fx, fy, fz).
    static void gradient(const float* c, float fx, float fy, float fz, float& gx, float& gy, float& gz) {
        auto lerp = [](float a, float b, float t) { return a + (b - a) * t; };
        // d/dx: difference of the x = 1 and x = 0 faces, bilinear in (y, z); likewise for y and z.
        gx = lerp(lerp(c[4] - c[0], c[6] - c[2], fy), lerp(c[5] - c[1], c[7] - c[3], fy), fz);
        gy = lerp(lerp(c[2] - c[0], c[6] - c[4], fx), lerp(c[3] - c[1], c[7] - c[5], fx), fz);
        gz = lerp(lerp(c[1] - c[0], c[5] - c[4], fx), lerp(c[3] - c[2], c[7] - c[6], fx), fy);
    }
    static float trilinear(const float* c, const openvdb::Vec3d& f) {
        const float fx = float(f.x()), fy = float(f.y()), fz = float(f.z());
        const float x00 = c[0] + (c[4] - c[0]) * fx, x01 = c[1] + (c[5] - c[1]) * fx;
        const float x10 = c[2] + (c[6] - c[2]) * fx, x11 = c[3] + (c[7] - c[3]) * fx;
        const float y0 = x00 + (x10 - x00) * fy, y1 = x01 + (x11 - x01) * fy;
        return y0 + (y1 - y0) * fz;
    }
    /// The eight corner values (index i = dx * 4 + dy * 2 + dz) of the cell holding index position
    /// (x, y, z), and the position's fractions in it: from one region's values when the cell lies
    /// inside it (7 cells in 8 per axis), else from the neighbouring regions it reaches into.
    static inline __attribute__((always_inline)) void fetch(ThreadState& st, double x, double y, double z, float* c,
                                                            float& fx, float& fy, float& fz) {
        const LeafTable& table = *st.table;
        int ix, iy, iz;
        if (const float* const* r = table.locate(x, y, z, ix, iy, iz, fx, fy, fz)) {
            const int lx = ix & 7, ly = iy & 7, lz = iz & 7;
            if (lx < 7 && ly < 7 && lz < 7) {
                const float* d = *r + ((lx << 6) | (ly << 3) | lz);
                c[0] = d[0], c[1] = d[1], c[2] = d[8], c[3] = d[9];
                c[4] = d[64], c[5] = d[65], c[6] = d[72], c[7] = d[73];
                return;
            }
            if (table.hasUpperNeighbours(ix, iy, iz)) {
                // Per axis: the step to the next region when the cell reaches into it, and the
                // offsets of the lower and upper corner in their regions.
                const std::size_t sx = lx == 7 ? table.strideX() : 0, sy = ly == 7 ? table.strideY() : 0,
                                  sz = lz == 7 ? 1 : 0;
                const int x0 = lx << 6, x1 = ((lx + 1) & 7) << 6, y0 = ly << 3, y1 = ((ly + 1) & 7) << 3, z0 = lz,
                          z1 = (lz + 1) & 7;
                c[0] = r[0][x0 | y0 | z0];
                c[1] = r[sz][x0 | y0 | z1];
                c[2] = r[sy][x0 | y1 | z0];
                c[3] = r[sy + sz][x0 | y1 | z1];
                c[4] = r[sx][x1 | y0 | z0];
                c[5] = r[sx + sz][x1 | y0 | z1];
                c[6] = r[sx + sy][x1 | y1 | z0];
                c[7] = r[sx + sy + sz][x1 | y1 | z1];
                return;
            }
        }
        ix = floorInt(x), iy = floorInt(y), iz = floorInt(z);
        fx = float(x - ix), fy = float(y - iy), fz = float(z - iz);
        const openvdb::Coord ijk(ix, iy, iz);
        for (int i = 0; i < 8; ++i) c[i] = st.acc.getValue(ijk.offsetBy(i >> 2, (i >> 1) & 1, i & 1));
    }
    /// Asks for the cache lines of the cell holding index position p (no effect outside the table).
    static void prefetch(ThreadState& st, const openvdb::Vec3d& p) {
        int ix, iy, iz;
        float fx, fy, fz;
        if (const float* const* r = st.table->locate(p.x(), p.y(), p.z(), ix, iy, iz, fx, fy, fz)) {
            const float* d = *r + (((ix & 7) << 6) | ((iy & 7) << 3) | (iz & 7));
            __builtin_prefetch(d);
            __builtin_prefetch(d + 64);
        }
    }
    /// fetch() for a position as a vector; the fractions as a vector.
    static openvdb::Vec3d corners(ThreadState& st, const openvdb::Vec3d& p, float* c) {
        float fx, fy, fz;
        fetch(st, p.x(), p.y(), p.z(), c, fx, fy, fz);
        return {fx, fy, fz};
    }
    unsigned insideMask(float v) const {
        unsigned m = 0;
        for (std::size_t i = 0; i < layers_.size(); ++i)
            if (below_ ? v < layers_[i].iso : v > layers_[i].iso) m |= 1u << i;
        return m;
    }

    /// The first crossing of any layer along the index ray, after time tStart.
    std::optional<Crossing> first(ThreadState& st, const Line& ray, double tStart, double tEnd) const {
        Intersector& inter = st.intersector();
        if (!inter.setIndexRay(IndexRay(ray.o, ray.d))) return std::nullopt;
        double t0 = 0, t1 = 0, prevT = -1;
        unsigned prevMask = 0;
        bool havePrev = false;
        while (inter.march(t0, t1)) {
            if (t1 < tStart) continue;
            if (t0 > tEnd) break;
            // Across a gap between spans (inactive values), the samples either side still bracket a crossing.
            double t = std::max(t0, tStart);
            const double end = std::min(t1, tEnd);
            for (;;) {
                const float v = sample(st, ray(t));
                const unsigned mask = insideMask(v);
                if (havePrev && mask != prevMask) return refine(st, ray, prevT, t, prevMask, mask);
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

    /// The first crossing in [ta, tb] by plain stepping (no tree traversal): for rays that the depth
    /// pre-pass has confined to the span where their crossings lie. With `fromOutside`, ta must be
    /// outside every layer (else startInside is set and nothing returned); without, the first change
    /// of side from ta's is the answer (the layers behind a translucent one).
    std::optional<Crossing> near(ThreadState& st, const Line& ray, double ta, double tb, bool& startInside,
                                 bool fromOutside = true) const {
        if (fromOutside && levelSet_ && layers_.size() == 1) return nearLevelSet(st, ray, ta, tb, startInside);
        startInside = false;
        double t = ta, prevT = ta;
        unsigned prevMask = 0;
        bool havePrev = false;
        for (;;) {
            const float v = sample(st, ray(t));
            const unsigned mask = insideMask(v);
            if (fromOutside && !havePrev && mask != 0) {  // not outside here: the full path decides, from the eye
                startInside = true;
                return std::nullopt;
            }
            if (havePrev && mask != prevMask) return refine(st, ray, prevT, t, prevMask, mask);
            havePrev = true;
            prevT = t;
            prevMask = mask;
            double step = 0.5;
            if (levelSet_) {
                // A step of the distance to the nearest iso-value, and a quarter voxel more: the sign
                // change after the surface brackets it.
                float near = kInf;
                for (const IsoLayer& l : layers_) near = std::min(near, std::abs(v - l.iso));
                step = std::max(double(near) / voxel_ + 0.25, 0.5);
            }
            if (t >= tb) return std::nullopt;
            t = std::min(t + step, tb);  // the last sample at tb exactly
        }
    }

    /// near() for one level-set layer: Newton steps along the ray. The values are distances, so the
    /// trilinear gradient at a sample gives the rate at which the ray approaches the surface, and
    /// one step usually lands just past it (a tenth of a voxel is added so that it does); a
    /// last Newton step from that first inside sample, with the gradient of the same cell, is the
    /// crossing. Steps never exceed twice the distance plus a quarter voxel (the sphere-tracing bound
    /// for rays up to 60 degrees off the normal), so thin parts are not stepped over more than by
    /// sphere tracing; where the ray runs along the surface, plain distance steps are taken.
    std::optional<Crossing> nearLevelSet(ThreadState& st, const Line& ray, double ta, double tb,
                                         bool& startInside) const {
        // Positions in double (index coordinates may be large), everything within a cell in float.
        startInside = false;
        const float iso = layers_[0].iso;
        const float side = below_ ? 1.f : -1.f;  // side * (v - iso) > 0 outside
        const float dx = float(ray.d.x()), dy = float(ray.d.y()), dz = float(ray.d.z());
        const float voxel = float(voxel_), perVoxel = float(1.0 / voxel_);
        double t = ta, prevT = ta;
        float prevDist = 0.f;
        bool havePrev = false;
        for (;;) {
            float c[8], fx, fy, fz;
            fetch(st, ray.o.x() + ray.d.x() * t, ray.o.y() + ray.d.y() * t, ray.o.z() + ray.d.z() * t, c, fx, fy, fz);
            const float v = trilinear(c, fx, fy, fz);
            const float dist = side * (v - iso);  // > 0 outside (in value units)
            float gx, gy, gz;
            gradient(c, fx, fy, fz, gx, gy, gz);
            const float rate = side * (gx * dx + gy * dy + gz * dz);  // change of dist per unit of ray time
            if (below_ ? v < iso : v > iso) {
                if (!havePrev) {  // not outside here: let the full path decide, from the eye
                    startInside = true;
                    return std::nullopt;
                }
                // Bracketed in [prevT, t]: Newton back from the inside sample, else interpolation.
                double x = rate < 0.f ? t + double(dist / rate) : prevT;  // dist <= 0 here
                if (!(x > prevT && x < t))
                    x = prevT + (t - prevT) * double(std::clamp(prevDist / (prevDist - dist), 0.f, 1.f));
                Crossing cr{std::max(prevT, x - 1e-3), 0, true};
                cr.hasGradient = true;
                cr.gradient = openvdb::Vec3d(gx, gy, gz);
                return cr;
            }
            havePrev = true;
            prevT = t;
            prevDist = dist;
            if (t >= tb) return std::nullopt;
            const float voxels = dist * perVoxel;
            float step = voxels + 0.25f;  // sphere tracing, for rays running along the surface
            if (rate < -1e-3f * voxel) step = std::max(step, std::min(dist / -rate + 0.1f, 2.f * voxels + 0.25f));
            t = std::min(t + double(std::max(step, 0.1f)), tb);  // the last sample at tb exactly
        }
    }

    /// Bisection on the first layer whose side changes between ta (mask ma) and tb (mask mb).
    Crossing refine(ThreadState& st, const Line& ray, double ta, double tb, unsigned ma, unsigned mb) const {
        if (tb - ta > 1.0) {
            // A long bracket (samples either side of a gap between spans, where active tiles may lie):
            // the first change is found in half-voxel steps before bisecting.
            double prev = ta;
            for (double t = ta + 0.5;; t = std::min(t + 0.5, tb)) {
                const unsigned m = insideMask(sample(st, ray(t)));
                if (m != ma) {
                    ta = prev;
                    tb = t;
                    mb = m;
                    break;
                }
                prev = t;
            }
        }
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
                if ((insideMask(sample(st, ray(m))) & bit) == (ma & bit))
                    a = m;
                else
                    b = m;
            }
            const double fa = sample(st, ray(a)) - iso, fb = sample(st, ray(b)) - iso;
            if (fa != fb) {
                const double x = a + (b - a) * std::clamp(fa / (fa - fb), 0.0, 1.0);
                // Keep the answer on the near side: step back a hair if the interpolation crossed.
                a = (insideMask(sample(st, ray(x))) & bit) == (ma & bit) ? x : a + 0.999 * (x - a);
            }
            if (a < best.t || best.t == tb) best = {a, static_cast<int>(i), (mb & bit) != 0};
        }
        return best;
    }

    /// Outward normal (world) at index position p: the gradient of the trilinear interpolant of the
    /// cell holding p (one fetch of its eight corners), mapped to world space.
    glm::vec3 normal(ThreadState& st, const openvdb::Vec3d& p) const {
        float c[8];
        const openvdb::Vec3d f = corners(st, p, c);
        return worldNormal(gradient(c, f), p);
    }
    /// Index-space gradient of the trilinear interpolant of a cell at fractional position f.
    static openvdb::Vec3d gradient(const float* c, const openvdb::Vec3d& f) {
        const double fx = f.x(), fy = f.y(), fz = f.z();
        auto lerp = [](double a, double b, double t) { return a + (b - a) * t; };
        // d/dx: difference of the x = 1 and x = 0 faces, bilinear in (y, z); likewise for y and z.
        const double gx = lerp(lerp(c[4] - c[0], c[6] - c[2], fy), lerp(c[5] - c[1], c[7] - c[3], fy), fz);
        const double gy = lerp(lerp(c[2] - c[0], c[6] - c[4], fx), lerp(c[3] - c[1], c[7] - c[5], fx), fz);
        const double gz = lerp(lerp(c[1] - c[0], c[5] - c[4], fx), lerp(c[3] - c[2], c[7] - c[6], fx), fy);
        return {gx, gy, gz};
    }
    /// Outward unit normal (world) from an index-space gradient at index position p.
    /// (In float for affine maps: a direction needs no more.)
    glm::vec3 worldNormal(const openvdb::Vec3d& g, const openvdb::Vec3d& p) const {
        glm::vec3 w;
        if (affine_) {
            const glm::vec3 gf(float(g.x()), float(g.y()), float(g.z()));
            w = glm::vec3(glm::dot(invf_[0], gf), glm::dot(invf_[1], gf), glm::dot(invf_[2], gf));
        } else {
            const openvdb::Vec3d wd = g_.transform().baseMap()->applyIJT(g, p);
            w = glm::vec3(float(wd.x()), float(wd.y()), float(wd.z()));
        }
        const float len2 = glm::dot(w, w);
        if (!(len2 > 0.f)) return glm::vec3(0, 0, 1);
        return w * ((below_ ? 1.f : -1.f) / std::sqrt(len2));
    }

private:
    const openvdb::FloatGrid& g_;
    const std::vector<IsoLayer>& layers_;
    bool below_, levelSet_, affine_ = false;
    double voxel_;
    glm::vec3 invf_[3] = {};  ///< rows of the inverse of the index-to-world matrix
};

}  // namespace

struct PreparedGrid::Impl {
    Impl(const openvdb::FloatGrid& g, std::vector<IsoLayer> l, bool below)
        : grid(g), layers(std::move(l)), insideBelow(below), table(g) {}
    const openvdb::FloatGrid& grid;
    const std::vector<IsoLayer> layers;
    const bool insideBelow;
    const LeafTable table;
    std::vector<openvdb::CoordBBox> boxes;  ///< crossed cells of every layer; empty for non-affine transforms
    bool empty = false;                     ///< no active values
    bool prepass = true;                    ///< use the depth pre-pass where it applies
    double setupSeconds = 0;
};

PreparedGrid::PreparedGrid(const openvdb::FloatGrid& grid, std::vector<IsoLayer> layers, bool insideBelow,
                           bool depthPrepass) {
    const auto start = std::chrono::steady_clock::now();
    if (layers.empty() || layers.size() > 16) throw std::invalid_argument("give 1 to 16 iso-surfaces");
    if (!grid.hasUniformVoxels())
        throw std::invalid_argument("the grid's voxels are not cubes: render it with --method mesh");
    impl_ = std::make_unique<Impl>(grid, std::move(layers), insideBelow);
    impl_->empty = !grid.tree().cbeginValueOn();
    impl_->prepass = depthPrepass && grid.transform().isLinear();
    if (!impl_->empty && impl_->prepass)
        for (const IsoLayer& l : impl_->layers) {
            auto b = volume::crossedCellBoxes(
                grid, l.iso, insideBelow ? volume::InsideSide::Below : volume::InsideSide::Above, kBrick);
            impl_->boxes.insert(impl_->boxes.end(), b.begin(), b.end());
        }
    impl_->setupSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

PreparedGrid::~PreparedGrid() = default;

double PreparedGrid::setupSeconds() const {
    return impl_->setupSeconds;
}

Frame PreparedGrid::render(const Look& look, const RenderOptions& o, RenderStats* stats) const {
    const auto start = std::chrono::steady_clock::now();
    if (o.width <= 0 || o.height <= 0) throw std::invalid_argument("image size must be positive");
    const openvdb::FloatGrid& grid = impl_->grid;
    const std::vector<IsoLayer>& layers = impl_->layers;
    const bool insideBelow = impl_->insideBelow;
    const detail::LightSet lights(look);
    const detail::Background background(look);
    std::uint64_t hitPixels = 0;
    if (impl_->empty) {
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
    const SharedIntersector master(grid);
    tbb::enumerable_thread_specific<ThreadState> states([&] { return ThreadState(master, grid, impl_->table); });
    const GridMarcher marcher(grid, layers, insideBelow);
    const auto& xform = grid.transform();
    const double voxel = grid.voxelSize()[0];

    // World to index: an affine map computed once (OpenVDB's maps are virtual calls per point).
    const bool affine = xform.isLinear();
    openvdb::Mat4d toIndex = openvdb::Mat4d::identity();
    if (affine) toIndex = xform.baseMap()->getAffineMap()->getMat4().inverse();  // row vectors: index = world * M
    auto toIndexRay = [&](const glm::vec3& o3, const glm::vec3& d3) {
        const openvdb::Vec3d wo(o3.x, o3.y, o3.z), wd(d3.x, d3.y, d3.z);
        if (!affine) {
            const IndexRay r = IndexRay(wo, wd).worldToIndex(grid);  // time = world distance / voxel size
            return Line{r.eye(), r.dir()};
        }
        openvdb::Vec3d d = toIndex.transform3x3(wd);
        d.normalize();
        return Line{toIndex.transform(wo), d};
    };
    // Directional lights seen from the light (detail::LightView): a shadow ray towards one steps only the
    // stretch between its start and the nearest crossed-cell box along its light pixel.
    std::vector<std::optional<detail::LightView>> lightViews(lights.size());
    if (o.shadows && impl_->prepass)
        for (std::size_t li = 0; li < lights.size(); ++li)
            if (!lights[li].point) lightViews[li] = detail::LightView::make(grid, impl_->boxes, lights[li].vector);
    // Shadows (light `li`; none: AO and translucent layers' rays): only opaque layers block light.
    auto blocked = [&](ThreadState& st, const glm::vec3& origin, const glm::vec3& d, float tmax,
                       std::optional<std::size_t> li = std::nullopt) {
        const Line r = toIndexRay(origin, d);
        double t = 0;
        double end = std::isfinite(tmax) ? double(tmax) / voxel : std::numeric_limits<double>::max();
        bool confined = false;
        if (li && lightViews[*li]) {
            if (const std::optional<float> reach = lightViews[*li]->reach(origin)) {
                if (*reach <= 0.f) return false;  // no box between here and the light
                end = std::min(end, double(*reach) / voxel + 1.0);
                confined = true;
            }
        }
        for (int k = 0; k < 16; ++k) {
            bool unused = false;
            const auto c = confined ? marcher.near(st, r, t, end, unused, false) : marcher.first(st, r, t, end);
            if (!c) return false;
            if (layers[static_cast<std::size_t>(c->layer)].material.color.a >= 1.f) return true;
            t = c->t + 0.3;
        }
        return false;
    };
    std::vector<glm::vec3> albedo;
    for (const IsoLayer& l : layers) albedo.push_back(srgbToLinear(glm::vec3(l.material.color)));
    const detail::RayGenerator gen(look.camera, o.width, o.height);
    // The depth pre-pass applies when the eye is outside every layer (nothing is crossed before the
    // first box along any ray).
    detail::DepthSpans span;
    {
        ThreadState probe(master, grid, impl_->table);
        const openvdb::Vec3d e =
            xform.worldToIndex(openvdb::Vec3d(look.camera.eye.x, look.camera.eye.y, look.camera.eye.z));
        if (impl_->prepass && marcher.insideMask(GridMarcher::sample(probe, e)) == 0)
            span = detail::depthPrepass(grid, impl_->boxes, gen, o);
    }
    const float aoReach = o.aoDistance > 0 ? o.aoDistance : float(20 * voxel);
    // Where a covered pixel's march starts (index-ray time), from its span and the ray's index time
    // per unit of view depth.
    auto spanStart = [](const detail::DepthSpan& d, double perDepth) {
        return std::max(0.0, double(d.near) * perDepth - 0.01);
    };
    // One camera sample. When `lanes` is given and the pre-pass span finds the first crossing on an
    // opaque layer (nothing behind it shows), that hit goes to lane k of `lanes`, to be shaded with
    // the block's other lanes, and trace returns true; otherwise it fills `out` (reset by the
    // caller) and returns false.
    auto trace = [&](ThreadState& st, const detail::Ray& ray, const Line& iray, std::size_t pix, std::size_t s,
                     float py, detail::SampleResult& out, detail::HitLanes* lanes, int k) {
        if (!span.empty() && !(span[pix].near <= span[pix].far)) {  // no box covers this pixel
            out.color = background.at(py, o.height);
            return false;
        }
        glm::vec3 acc(0.f);
        float transmit = 1.f;
        double t = 0;
        double tEnd = std::numeric_limits<double>::max();
        std::optional<Crossing> early;
        bool confined = false;  // every crossing lies in [t, tEnd]
        if (!span.empty()) {
            // Every crossing along this ray lies between the pixel's span depths: march that stretch
            // alone, from outside (the eye is outside every layer, and nothing is crossed before).
            const detail::DepthSpan& d = span[pix];  // covered: checked above
            const double perDepth = 1.0 / double(glm::dot(ray.dir, gen.forward())) / voxel;
            t = spanStart(d, perDepth);
            tEnd = double(d.far) * perDepth + 0.01;
            bool startInside = false;
            early = marcher.near(st, iray, t, tEnd, startInside);
            if (startInside) {  // a rounding surprise: march the whole ray instead
                t = 0;
                tEnd = std::numeric_limits<double>::max();
            } else if (early) {
                confined = true;
                const IsoLayer& L = layers[static_cast<std::size_t>(early->layer)];
                if (lanes && L.material.color.a >= 1.f) {
                    const openvdb::Vec3d ip = iray(early->t);
                    const float tWorld = float(early->t * voxel);
                    const glm::vec3 p = ray.origin + ray.dir * tWorld;  // affine: the pre-pass applies
                    glm::vec3 n =
                        early->hasGradient ? marcher.worldNormal(early->gradient, ip) : marcher.normal(st, ip);
                    if (glm::dot(n, ray.dir) > 0) n = -n;
                    const glm::vec3 q = p + n * float(0.75 * voxel);
                    lanes->on[k] = -1;
                    lanes->px[k] = p.x, lanes->py[k] = p.y, lanes->pz[k] = p.z;
                    lanes->nx[k] = n.x, lanes->ny[k] = n.y, lanes->nz[k] = n.z;
                    lanes->qx[k] = q.x, lanes->qy[k] = q.y, lanes->qz[k] = q.z;
                    lanes->setMaterial(k, albedo[static_cast<std::size_t>(early->layer)], L.material);
                    if (o.aoSamples > 0)
                        lanes->ao[k] = detail::ambientOcclusion(
                            n, o.aoSamples, static_cast<std::uint32_t>(pix * 64u + s * 16u),
                            [&](const glm::vec3& dir) { return !blocked(st, q, dir, aoReach); });
                    out.hit = true;
                    out.depth = tWorld;
                    out.normal = n;
                    out.id = float(early->layer + 1);
                    return true;
                }
            } else {
                out.color = background.at(py, o.height);
                return false;
            }
        }
        for (int layer = 0; layer < 16 && transmit > 0.004f; ++layer) {
            // Behind the first layer: within the pre-pass span, stepping it; else the tree traversal.
            bool unused = false;
            const auto c = layer == 0 && early ? early
                           : confined          ? marcher.near(st, iray, t, tEnd, unused, false)
                                               : marcher.first(st, iray, t, tEnd);
            if (!c) break;
            const openvdb::Vec3d ip = iray(c->t);
            const IsoLayer& L = layers[static_cast<std::size_t>(c->layer)];
            detail::Surface surf;
            if (affine) {
                surf.position = ray.origin + ray.dir * float(c->t * voxel);
            } else {
                const openvdb::Vec3d wp = xform.indexToWorld(ip);
                surf.position = glm::vec3(wp.x(), wp.y(), wp.z());
            }
            glm::vec3 n = c->hasGradient ? marcher.worldNormal(c->gradient, ip) : marcher.normal(st, ip);
            if (glm::dot(n, ray.dir) > 0) n = -n;
            surf.normal = n;
            surf.albedo = albedo[static_cast<std::size_t>(c->layer)];
            surf.setMaterial(L.material);
            const glm::vec3 origin = surf.position + n * float(0.75 * voxel);
            const float tWorld = float(c->t * voxel);
            acc += transmit * surf.opacity *
                   detail::shadeHit(
                       surf, origin, ray.dir, look, lights, o, aoReach,
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
        return false;
    };
    Frame f = detail::renderBlocks(
        look, o,
        [&](const detail::RayBlock& rays, int n, const std::size_t* pix, std::size_t s, const float* py,
            detail::SampleResult* out) {
            ThreadState& st = states.local();
            // Index rays first, with a prefetch of the cell where each covered pixel's march starts:
            // the block's cache misses then overlap instead of each ray waiting for its own.
            Line irays[16];
            for (int k = 0; k < n; ++k) {
                const bool covered = !span.empty() && span[pix[k]].near <= span[pix[k]].far;
                if (!covered && !span.empty()) continue;  // background: trace() needs no index ray
                irays[k] = toIndexRay(glm::vec3(rays.ox[k], rays.oy[k], rays.oz[k]),
                                      glm::vec3(rays.dx[k], rays.dy[k], rays.dz[k]));
                if (!covered) continue;
                const double perDepth =
                    1.0 /
                    double(rays.dx[k] * gen.forward().x + rays.dy[k] * gen.forward().y + rays.dz[k] * gen.forward().z) /
                    voxel;
                marcher.prefetch(st, irays[k](spanStart(span[pix[k]], perDepth)));
            }
            detail::HitLanes h;
            h.clear();
            bool any = false;
            for (int k = 0; k < n; ++k) any |= trace(st, rays[k], irays[k], pix[k], s, py[k], out[k], &h, k);
            if (!any) return;
            // The opaque first hits shaded together (shadows: a march towards each light per lane).
            auto shadow = [&](std::size_t li, const float* lx, const float* ly, const float* lz, const float* reach,
                              int* lit) {
                if (!o.shadows) return;
                for (int k = 0; k < 16; ++k)
                    if (lit[k] &&
                        blocked(st, glm::vec3(h.qx[k], h.qy[k], h.qz[k]), glm::vec3(lx[k], ly[k], lz[k]), reach[k], li))
                        lit[k] = 0;
            };
            alignas(64) float cr[16], cg[16], cb[16];
            detail::shadeLanes(h, rays, lights, look.ambient, shadow, cr, cg, cb);
            for (int k = 0; k < n; ++k)
                if (h.on[k]) out[k].color = glm::vec3(cr[k], cg[k], cb[k]);
        },
        hitPixels);
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

Frame marchGrid(const openvdb::FloatGrid& grid, const std::vector<IsoLayer>& layers, bool insideBelow, const Look& look,
                const RenderOptions& options, RenderStats* stats) {
    const PreparedGrid prepared(grid, layers, insideBelow);
    Frame f = prepared.render(look, options, stats);
    if (stats) {
        stats->setupSeconds = prepared.setupSeconds();
        stats->seconds += prepared.setupSeconds();
    }
    return f;
}

}  // namespace isoforge::render
