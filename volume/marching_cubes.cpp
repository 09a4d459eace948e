#include "volume/marching_cubes.h"

#include <algorithm>
#include <atomic>
#include <bit>
#include <chrono>
#include <cstdint>
#include <memory>
#include <numeric>
#include <string>
#include <vector>

#include <glm/geometric.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include "core/error.h"
#include "volume/mc_table.h"

namespace isoforge::volume {

namespace {

using Tree = openvdb::FloatTree;
using Leaf = Tree::LeafNodeType;
using Accessor = openvdb::tree::ValueAccessor<const Tree>;
using openvdb::Coord;
using Clock = std::chrono::steady_clock;

constexpr float kEdgeMargin = 1e-3f;  // vertices stay this far (in voxels) from grid corners
constexpr int kKeyBits = 21;
constexpr std::uint64_t kKeyMask = (std::uint64_t{1} << kKeyBits) - 1;

double secondsSince(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

/// Block origins packed into 64-bit keys (21 bits per axis, in units of 8 voxels, relative to a
/// base), so that sorting keys sorts blocks lexicographically by (x, y, z).
struct KeyPacker {
    Coord base;
    std::uint64_t pack(const Coord& origin) const {
        auto u = [&](int k) { return static_cast<std::uint64_t>((origin[k] - base[k]) >> 3); };
        return (u(0) << (2 * kKeyBits)) | (u(1) << kKeyBits) | u(2);
    }
    Coord unpack(std::uint64_t key) const {
        return Coord(base[0] + static_cast<int>((key >> (2 * kKeyBits)) & kKeyMask) * 8,
                     base[1] + static_cast<int>((key >> kKeyBits) & kKeyMask) * 8,
                     base[2] + static_cast<int>(key & kKeyMask) * 8);
    }
};

/// Open-addressing map from block key to block index.
class BlockIndex {
public:
    explicit BlockIndex(const std::vector<std::uint64_t>& keys) {
        std::size_t cap = 16;
        while (cap < 2 * keys.size()) cap <<= 1;
        shift_ = 64 - std::countr_zero(cap);
        slots_.assign(cap, Slot{kEmpty, 0});
        for (std::size_t i = 0; i < keys.size(); ++i) {
            std::size_t h = hash(keys[i]);
            while (slots_[h].key != kEmpty) h = (h + 1) & (cap - 1);
            slots_[h] = {keys[i], static_cast<std::uint32_t>(i)};
        }
    }
    std::int64_t find(std::uint64_t key) const {
        std::size_t h = hash(key);
        while (slots_[h].key != kEmpty) {
            if (slots_[h].key == key) return slots_[h].index;
            h = (h + 1) & (slots_.size() - 1);
        }
        return -1;
    }

private:
    static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};
    struct Slot {
        std::uint64_t key;
        std::uint32_t index;
    };
    std::size_t hash(std::uint64_t k) const { return static_cast<std::size_t>((k * 0x9E3779B97F4A7C15ull) >> shift_); }
    int shift_ = 60;
    std::vector<Slot> slots_;
};

/// The eight 8^3 regions a block of cells reads: itself and its +x, +y, +z neighbours (bit i of the
/// index: x, y, z). Each is a leaf buffer or a constant (tile or background).
struct Sources {
    const float* data[8];
    float constant[8];

    void load(const Accessor& acc, const Coord& origin) {
        for (int i = 0; i < 8; ++i) {
            const Coord p = origin.offsetBy((i & 1) * 8, ((i >> 1) & 1) * 8, ((i >> 2) & 1) * 8);
            if (const Leaf* leaf = acc.probeConstLeaf(p)) {
                data[i] = leaf->buffer().data();
            } else {
                data[i] = nullptr;
                constant[i] = acc.getValue(p);
            }
        }
    }
    /// Value at block-local (x, y, z), each in [0, 8].
    float value(int x, int y, int z) const {
        const int i = (x >> 3) | ((y >> 3) << 1) | ((z >> 3) << 2);
        return data[i] ? data[i][((x & 7) << 6) | ((y & 7) << 3) | (z & 7)] : constant[i];
    }
};

/// Per-block state kept between the passes.
struct BlockData {
    std::uint16_t mask[9][9];      ///< bit z set: (x, y, z) inside; x, y, z in [0, 8]
    std::uint16_t prefix[3][64];   ///< owned vertices before (axis, row x * 8 + y)
};

inline std::uint32_t edgeRow(const BlockData& b, int axis, int x, int y) {
    switch (axis) {
        case 0: return static_cast<std::uint32_t>(b.mask[x][y] ^ b.mask[x + 1][y]) & 0xFFu;
        case 1: return static_cast<std::uint32_t>(b.mask[x][y] ^ b.mask[x][y + 1]) & 0xFFu;
        default: return static_cast<std::uint32_t>(b.mask[x][y] ^ (b.mask[x][y] >> 1)) & 0xFFu;
    }
}

inline bool rowIsUniform(const BlockData& b, int x, int y) {
    const std::uint32_t c0 = b.mask[x][y], c1 = b.mask[x + 1][y], c2 = b.mask[x][y + 1], c3 = b.mask[x + 1][y + 1];
    return (c0 | c1 | c2 | c3) == 0 || (c0 & c1 & c2 & c3) == 0x1FF;
}

inline int cellCode(const BlockData& b, int x, int y, int z) {
    const std::uint32_t c0 = b.mask[x][y] >> z, c1 = b.mask[x + 1][y] >> z, c2 = b.mask[x][y + 1] >> z,
                        c3 = b.mask[x + 1][y + 1] >> z;
    return static_cast<int>((c0 & 1) | ((c1 & 1) << 1) | ((c2 & 1) << 2) | ((c3 & 1) << 3) | ((c0 & 2) << 3) |
                            ((c1 & 2) << 4) | ((c2 & 2) << 5) | ((c3 & 2) << 6));
}

template <bool Below>
inline bool isInside(float v, float iso) {
    if constexpr (Below) return v < iso;
    else return v > iso;
}

template <bool Below>
void computeMasks(const Sources& s, float iso, BlockData& b) {
    for (int x = 0; x <= 8; ++x)
        for (int y = 0; y <= 8; ++y) {
            const int i = (x >> 3) | ((y >> 3) << 1);
            std::uint32_t bits;
            if (const float* p = s.data[i]) {
                p += ((x & 7) << 6) | ((y & 7) << 3);
                bits = 0;
                for (int z = 0; z < 8; ++z) bits |= static_cast<std::uint32_t>(isInside<Below>(p[z], iso)) << z;
            } else {
                bits = isInside<Below>(s.constant[i], iso) ? 0xFFu : 0u;
            }
            const float top = s.data[i | 4] ? s.data[i | 4][((x & 7) << 6) | ((y & 7) << 3)] : s.constant[i | 4];
            bits |= static_cast<std::uint32_t>(isInside<Below>(top, iso)) << 8;
            b.mask[x][y] = static_cast<std::uint16_t>(bits);
        }
}

/// Blocks of cells to visit: every leaf, its seven lower neighbours (cells whose lower corner lies
/// there reach into the leaf), and both sides of active-tile borders whose values straddle the iso.
template <bool Below>
std::vector<std::uint64_t> collectBlocks(const Tree& tree, float iso, KeyPacker& packer, std::size_t& leafCount) {
    std::vector<const Leaf*> leaves;
    tree.getNodes(leaves);
    leafCount = leaves.size();

    // Borders of active tiles (dense regions of fog volumes): where the region next to a tile lies
    // on the other side of the iso-value, the cells between them are visited.
    std::vector<Coord> extra;
    {
        Accessor acc(tree);
        Tree::ValueOnCIter it = tree.cbeginValueOn();
        it.setMaxDepth(Tree::ValueOnCIter::LEAF_DEPTH - 1);
        for (; it; ++it) {
            openvdb::CoordBBox box;
            it.getBoundingBox(box);
            const int depth = it.getDepth();
            const bool in = isInside<Below>(*it, iso);
            const int dim = box.dim().x();
            for (int dz = -1; dz <= 1; ++dz)
                for (int dy = -1; dy <= 1; ++dy)
                    for (int dx = -1; dx <= 1; ++dx) {
                        if (!dx && !dy && !dz) continue;
                        const Coord dir(dx, dy, dz);
                        const Coord region = box.min() + Coord(dx * dim, dy * dim, dz * dim);
                        const int regionDepth = acc.getValueDepth(region);
                        const bool uniform = regionDepth >= 0 && regionDepth <= depth;
                        if (uniform || regionDepth < 0) {
                            if (isInside<Below>(acc.getValue(region), iso) == in) continue;
                        }
                        // Blocks of the tile facing `dir`, and their neighbours across the border.
                        Coord lo, hi;
                        for (int k = 0; k < 3; ++k) {
                            lo[k] = dir[k] > 0 ? box.max()[k] - 7 : box.min()[k];
                            hi[k] = dir[k] < 0 ? box.min()[k] : box.max()[k] - 7;
                        }
                        for (int x = lo[0]; x <= hi[0]; x += 8)
                            for (int y = lo[1]; y <= hi[1]; y += 8)
                                for (int z = lo[2]; z <= hi[2]; z += 8) {
                                    const Coord b(x, y, z), nb = b + Coord(8 * dx, 8 * dy, 8 * dz);
                                    if (!(uniform || regionDepth < 0)) {
                                        if (acc.probeConstLeaf(nb)) continue;  // the leaf rule covers it
                                        if (isInside<Below>(acc.getValue(nb), iso) == in) continue;
                                    }
                                    extra.push_back(b);
                                    extra.push_back(nb);
                                }
                    }
        }
    }
    if (leaves.empty() && extra.empty()) return {};

    // Base and extent of the keys.
    Coord lo(std::numeric_limits<int>::max()), hi(std::numeric_limits<int>::min());
    for (const Leaf* leaf : leaves) {
        lo.minComponent(leaf->origin());
        hi.maxComponent(leaf->origin());
    }
    for (const Coord& c : extra) {
        lo.minComponent(c);
        hi.maxComponent(c);
    }
    packer.base = lo - Coord(8);
    for (int k = 0; k < 3; ++k) {
        const std::int64_t extent = (static_cast<std::int64_t>(hi[k]) - packer.base[k]) / 8 + 1;
        if (extent >= (std::int64_t{1} << kKeyBits))
            throw ResourceError("grid spans " + std::to_string(extent * 8) +
                                " voxels along one axis; the mesher addresses at most 16.7 million");
    }

    std::vector<std::uint64_t> keys(8 * leaves.size() + extra.size());
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, leaves.size(), 1024), [&](const auto& r) {
        for (std::size_t i = r.begin(); i != r.end(); ++i)
            for (int n = 0; n < 8; ++n)
                keys[8 * i + n] = packer.pack(leaves[i]->origin().offsetBy(-8 * (n & 1), -8 * ((n >> 1) & 1),
                                                                           -8 * ((n >> 2) & 1)));
    });
    for (std::size_t i = 0; i < extra.size(); ++i) keys[8 * leaves.size() + i] = packer.pack(extra[i]);
    tbb::parallel_sort(keys.begin(), keys.end());
    keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
    return keys;
}

class ProgressTicker {
public:
    ProgressTicker(Progress* p, const char* stage, std::size_t total) : p_(p), total_(total) {
        if (p_) p_->begin(stage);
    }
    ~ProgressTicker() {
        if (p_) p_->end();
    }
    void add(std::size_t n) {
        if (p_) p_->update(done_.fetch_add(n) + n, total_);
    }

private:
    Progress* p_;
    std::size_t total_;
    std::atomic<std::size_t> done_{0};
};

template <bool Below>
void extract(const openvdb::FloatGrid& grid, const MeshingOptions& options, mesh::TriMesh& out,
             MeshingStats& stats) {
    const Tree& tree = grid.tree();
    const float iso = options.isovalue;
    const mc::CaseTable& table = mc::caseTable();
    auto t0 = Clock::now();

    KeyPacker packer;
    const std::vector<std::uint64_t> keys = collectBlocks<Below>(tree, iso, packer, stats.leaves);
    const std::size_t n = keys.size();
    stats.blocks = n;
    const BlockIndex index(keys);
    stats.secondsSetup = secondsSince(t0);

    // Pass 1: inside masks, owned-vertex prefixes and triangle counts per block.
    t0 = Clock::now();
    std::unique_ptr<BlockData[]> blocks(new BlockData[n]);
    std::vector<std::uint64_t> vertexOffset(n + 1, 0), triangleOffset(n + 1, 0);
    {
        ProgressTicker ticker(options.progress, "meshing", 2 * n);
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 64), [&](const tbb::blocked_range<std::size_t>& r) {
            Accessor acc(tree);
            Sources src;
            for (std::size_t bi = r.begin(); bi != r.end(); ++bi) {
                BlockData& b = blocks[bi];
                src.load(acc, packer.unpack(keys[bi]));
                computeMasks<Below>(src, iso, b);
                std::uint32_t vertices = 0;
                for (int a = 0; a < 3; ++a)
                    for (int row = 0; row < 64; ++row) {
                        b.prefix[a][row] = static_cast<std::uint16_t>(vertices);
                        vertices += static_cast<std::uint32_t>(std::popcount(edgeRow(b, a, row >> 3, row & 7)));
                    }
                std::uint32_t triangles = 0;
                for (int x = 0; x < 8; ++x)
                    for (int y = 0; y < 8; ++y) {
                        if (rowIsUniform(b, x, y)) continue;
                        for (int z = 0; z < 8; ++z) triangles += table.triangleCount[cellCode(b, x, y, z)];
                    }
                vertexOffset[bi + 1] = vertices;
                triangleOffset[bi + 1] = triangles;
            }
            ticker.add(r.size());
        });
        std::partial_sum(vertexOffset.begin(), vertexOffset.end(), vertexOffset.begin());
        std::partial_sum(triangleOffset.begin(), triangleOffset.end(), triangleOffset.begin());
        stats.secondsCount = secondsSince(t0);

        if (vertexOffset[n] > std::numeric_limits<std::uint32_t>::max())
            throw ResourceError("the surface has " + std::to_string(vertexOffset[n]) +
                                " vertices, more than 32-bit indices can address");

        // Pass 2: vertices and triangles, each block at its own offsets.
        t0 = Clock::now();
        out.positions.resize(vertexOffset[n]);
        out.triangles.resize(triangleOffset[n]);
        if (options.normals) out.normals.resize(vertexOffset[n]);
        else out.normals.clear();

        const openvdb::math::Transform& xform = grid.transform();
        const bool affine = xform.isLinear();
        const openvdb::Mat4d m = affine ? xform.baseMap()->getAffineMap()->getMat4() : openvdb::Mat4d::identity();
        std::atomic<std::size_t> surfaceBlocks{0};

        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 64), [&](const tbb::blocked_range<std::size_t>& r) {
            Accessor acc(tree);
            Sources src;
            std::size_t localSurface = 0;
            for (std::size_t bi = r.begin(); bi != r.end(); ++bi) {
                const std::uint64_t vbase = vertexOffset[bi];
                if (vertexOffset[bi + 1] == vbase && triangleOffset[bi + 1] == triangleOffset[bi]) continue;
                ++localSurface;
                const BlockData& b = blocks[bi];
                const Coord origin = packer.unpack(keys[bi]);
                src.load(acc, origin);

                // Vertices owned by this block, in rank order.
                std::uint64_t vi = vbase;
                for (int a = 0; a < 3; ++a)
                    for (int row = 0; row < 64; ++row) {
                        const int x = row >> 3, y = row & 7;
                        for (std::uint32_t bits = edgeRow(b, a, x, y); bits; bits &= bits - 1) {
                            const int z = std::countr_zero(bits);
                            const float v0 = src.value(x, y, z);
                            const float v1 = src.value(x + (a == 0), y + (a == 1), z + (a == 2));
                            float t = (iso - v0) / (v1 - v0);
                            t = t > kEdgeMargin ? (t < 1.f - kEdgeMargin ? t : 1.f - kEdgeMargin) : kEdgeMargin;
                            openvdb::Vec3d p(origin.x() + x, origin.y() + y, origin.z() + z);
                            p[a] += t;
                            if (options.normals) {
                                auto gradient = [&](const Coord& c) {
                                    return openvdb::Vec3d(acc.getValue(c.offsetBy(1, 0, 0)) - acc.getValue(c.offsetBy(-1, 0, 0)),
                                                          acc.getValue(c.offsetBy(0, 1, 0)) - acc.getValue(c.offsetBy(0, -1, 0)),
                                                          acc.getValue(c.offsetBy(0, 0, 1)) - acc.getValue(c.offsetBy(0, 0, -1)));
                                };
                                const Coord c0 = origin.offsetBy(x, y, z);
                                Coord c1 = c0;
                                c1[a] += 1;
                                openvdb::Vec3d g = gradient(c0) * (1.0 - t) + gradient(c1) * t;
                                if (options.worldSpace) g = xform.baseMap()->applyIJT(g, p);
                                if (!Below) g = -g;
                                const double len = g.length();
                                out.normals[vi] = len > 0 ? glm::vec3(g.x() / len, g.y() / len, g.z() / len) : glm::vec3(0.f);
                            }
                            if (options.worldSpace) p = affine ? m.transformH(p) : xform.indexToWorld(p);
                            out.positions[vi++] = glm::vec3(p.x(), p.y(), p.z());
                        }
                    }

                // Neighbour blocks that own vertices on our upper faces.
                std::int64_t owner[7];
                owner[0] = static_cast<std::int64_t>(bi);
                for (int o = 1; o < 7; ++o)
                    owner[o] = index.find(packer.pack(origin.offsetBy(8 * (o & 1), 8 * ((o >> 1) & 1), 8 * ((o >> 2) & 1))));

                std::uint64_t ti = triangleOffset[bi];
                for (int x = 0; x < 8; ++x)
                    for (int y = 0; y < 8; ++y) {
                        if (rowIsUniform(b, x, y)) continue;
                        for (int z = 0; z < 8; ++z) {
                            const int code = cellCode(b, x, y, z);
                            const int count = table.triangleCount[code];
                            for (int k = 0; k < 3 * count; ++k) {
                                const mc::EdgeInfo e = mc::edgeInfo(table.edges[code][k]);
                                const int cx = x + e.dx, cy = y + e.dy, cz = z + e.dz;
                                const int o = (cx >> 3) | ((cy >> 3) << 1) | ((cz >> 3) << 2);
                                const std::int64_t ob = owner[o];
                                if (ob < 0) throw std::logic_error("marching cubes: vertex owner block missing");
                                const BlockData& B = blocks[static_cast<std::size_t>(ob)];
                                const int lx = cx & 7, ly = cy & 7, lz = cz & 7;
                                const std::uint32_t rank =
                                    B.prefix[e.axis][lx * 8 + ly] +
                                    static_cast<std::uint32_t>(std::popcount(edgeRow(B, e.axis, lx, ly) & ((1u << lz) - 1u)));
                                out.triangles[ti + static_cast<std::uint64_t>(k / 3)][k % 3] =
                                    static_cast<std::uint32_t>(vertexOffset[static_cast<std::size_t>(ob)] + rank);
                            }
                            ti += static_cast<std::uint64_t>(count);
                        }
                    }
            }
            surfaceBlocks += localSurface;
            ticker.add(r.size());
        });
        stats.surfaceBlocks = surfaceBlocks;
        stats.secondsWrite = secondsSince(t0);
    }
}

}  // namespace

bool insideIsBelow(const openvdb::FloatGrid& grid, InsideSide side) {
    if (side == InsideSide::Below) return true;
    if (side == InsideSide::Above) return false;
    return grid.getGridClass() == openvdb::GRID_LEVEL_SET;
}

void extractIsosurface(const openvdb::FloatGrid& grid, const MeshingOptions& options, mesh::TriMesh& out,
                       MeshingStats* stats) {
    MeshingStats local;
    if (insideIsBelow(grid, options.inside)) extract<true>(grid, options, out, local);
    else extract<false>(grid, options, out, local);
    if (stats) *stats = local;
}

mesh::TriMesh extractIsosurface(const openvdb::FloatGrid& grid, const MeshingOptions& options, MeshingStats* stats) {
    mesh::TriMesh mesh;
    extractIsosurface(grid, options, mesh, stats);
    return mesh;
}

}  // namespace isoforge::volume
