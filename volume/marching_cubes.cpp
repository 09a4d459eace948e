#include "volume/marching_cubes.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <numeric>
#include <stdexcept>
#include <string>
#include <vector>

#include <sys/mman.h>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>
#include <glm/geometric.hpp>

#include "core/big_buffer.h"
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

double secondsSince(Clock::time_point t) {
    return std::chrono::duration<double>(Clock::now() - t).count();
}

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
    /// Built in parallel: keys are unique, so a compare-and-swap per key is all it takes; where a key
    /// lands may vary with scheduling, what find() answers does not.
    explicit BlockIndex(const std::vector<std::uint64_t>& keys) {
        std::size_t cap = 16;
        while (cap < 2 * keys.size()) cap <<= 1;
        shift_ = 64 - std::countr_zero(cap);
        mask_ = cap - 1;
        keys_.reset(new std::atomic<std::uint64_t>[cap]);
        index_.reset(new std::uint32_t[cap]);
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cap, 1 << 14), [&](const auto& r) {
            for (std::size_t i = r.begin(); i != r.end(); ++i) keys_[i].store(kEmpty, std::memory_order_relaxed);
        });
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, keys.size(), 1 << 12), [&](const auto& r) {
            for (std::size_t i = r.begin(); i != r.end(); ++i) {
                for (std::size_t h = hash(keys[i]);; h = (h + 1) & mask_) {
                    std::uint64_t expected = kEmpty;
                    if (keys_[h].compare_exchange_strong(expected, keys[i], std::memory_order_relaxed)) {
                        index_[h] = static_cast<std::uint32_t>(i);
                        break;
                    }
                }
            }
        });  // parallel_for's end synchronizes: find() sees every key and index
    }
    std::int64_t find(std::uint64_t key) const {
        for (std::size_t h = hash(key);; h = (h + 1) & mask_) {
            const std::uint64_t k = keys_[h].load(std::memory_order_relaxed);
            if (k == key) return index_[h];
            if (k == kEmpty) return -1;
        }
    }

private:
    static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};
    std::size_t hash(std::uint64_t k) const { return static_cast<std::size_t>((k * 0x9E3779B97F4A7C15ull) >> shift_); }
    int shift_ = 60;
    std::size_t mask_ = 0;
    std::unique_ptr<std::atomic<std::uint64_t>[]> keys_;
    std::unique_ptr<std::uint32_t[]> index_;
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
    /// True if all eight regions are constants on the same side of the iso-value.
    template <bool Below>
    bool isUniform(float iso) const;
    /// Value at block-local (x, y, z), each in [0, 8].
    float value(int x, int y, int z) const {
        const int i = (x >> 3) | ((y >> 3) << 1) | ((z >> 3) << 2);
        return data[i] ? data[i][((x & 7) << 6) | ((y & 7) << 3) | (z & 7)] : constant[i];
    }
};

/// Bit counts of bytes (x86-64's baseline has no popcnt instruction; a table beats libgcc's call).
constexpr std::array<std::uint8_t, 256> kPopcount8 = [] {
    std::array<std::uint8_t, 256> t{};
    for (int i = 0; i < 256; ++i)
        t[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(std::popcount(static_cast<unsigned>(i)));
    return t;
}();
inline std::uint32_t popcount8(std::uint32_t byte) {
    return kPopcount8[byte & 0xFFu];
}

/// Bit z of a 9-bit column moved to bit 4z: four spread columns, shifted by 0..3 and or-ed, give a
/// word whose byte at bit 4z is the case code of the cell at z.
constexpr std::array<std::uint64_t, 512> kSpread9 = [] {
    std::array<std::uint64_t, 512> t{};
    for (int m = 0; m < 512; ++m)
        for (int z = 0; z < 9; ++z)
            if ((m >> z) & 1) t[static_cast<std::size_t>(m)] |= std::uint64_t{1} << (4 * z);
    return t;
}();
constexpr std::uint64_t kAllCorners = 0xFFFFFFFFFull;  // 36 bits

/// Vertex indices of a block's edges, by slot axis * 729 + x * 81 + y * 9 + z (x, y, z in [0, 8]).
constexpr int kSlots = 3 * 729;
constexpr std::array<int, 12> kEdgeSlot = [] {
    std::array<int, 12> t{};
    for (int e = 0; e < 12; ++e) {
        const mc::EdgeInfo i = mc::edgeInfo(e);
        t[static_cast<std::size_t>(e)] = i.axis * 729 + i.dx * 81 + i.dy * 9 + i.dz;
    }
    return t;
}();

/// An uninitialized array for per-call scratch, on transparent huge pages where it is large:
/// fresh 4 KiB pages cost a fault each, and faults serialize threads.
template <class T>
class ScratchArray {
public:
    explicit ScratchArray(std::size_t n) {
        constexpr std::size_t kHuge = std::size_t{2} << 20;
        bytes_ = std::max<std::size_t>(n * sizeof(T), 1);
        if (bytes_ >= kHuge) {
            bytes_ = (bytes_ + kHuge - 1) / kHuge * kHuge;
            data_ = static_cast<T*>(std::aligned_alloc(kHuge, bytes_));
            if (data_) ::madvise(data_, bytes_, MADV_HUGEPAGE);
        } else {
            data_ = static_cast<T*>(std::malloc(bytes_));
        }
        if (!data_) throw std::bad_alloc();
    }
    ~ScratchArray() { std::free(data_); }
    ScratchArray(const ScratchArray&) = delete;
    ScratchArray& operator=(const ScratchArray&) = delete;
    T& operator[](std::size_t i) { return data_[i]; }
    const T& operator[](std::size_t i) const { return data_[i]; }

private:
    T* data_ = nullptr;
    std::size_t bytes_ = 0;
};

/// Inside bits of a block's 9^3 corners: bit z of mask[x][y] is set when (x, y, z) is inside.
/// Recomputed from the grid in each pass (cheap), so that it needs no storage between them.
struct Masks {
    std::uint16_t mask[9][9];
};

/// Per-block state kept between the passes: 240 bytes.
struct BlockData {
    std::uint8_t cut[3][64];     ///< bit z set: owned edge (axis, x, y, z) is intersected; row x * 8 + y
    std::uint16_t prefix[3][8];  ///< owned vertices before the rows of (axis, x)

    /// Fills cut and prefix from the masks; returns the number of owned vertices.
    std::uint32_t build(const Masks& m) {
        std::uint32_t vertices = 0;
        for (int a = 0; a < 3; ++a)
            for (int x = 0; x < 8; ++x) {
                prefix[a][x] = static_cast<std::uint16_t>(vertices);
                for (int y = 0; y < 8; ++y) {
                    const std::uint32_t c = m.mask[x][y];
                    const std::uint32_t bits =
                        a == 0 ? c ^ m.mask[x + 1][y] : (a == 1 ? c ^ m.mask[x][y + 1] : c ^ (c >> 1));
                    cut[a][x * 8 + y] = static_cast<std::uint8_t>(bits);
                    vertices += popcount8(bits);
                }
            }
        return vertices;
    }
};

inline std::uint32_t edgeRow(const BlockData& b, int axis, int x, int y) {
    return b.cut[axis][x * 8 + y];
}

/// The case codes of the eight cells of row (x, y): byte at bit 4z is the code of cell z.
inline std::uint64_t rowCodes(const Masks& b, int x, int y) {
    return kSpread9[b.mask[x][y]] | (kSpread9[b.mask[x + 1][y]] << 1) | (kSpread9[b.mask[x][y + 1]] << 2) |
           (kSpread9[b.mask[x + 1][y + 1]] << 3);
}
inline bool isUniform(std::uint64_t codes) {
    return codes == 0 || codes == kAllCorners;
}

template <bool Below>
inline bool isInside(float v, float iso) {
    if constexpr (Below)
        return v < iso;
    else
        return v > iso;
}

template <bool Below>
bool Sources::isUniform(float iso) const {
    for (int i = 0; i < 8; ++i)
        if (data[i] || isInside<Below>(constant[i], iso) != isInside<Below>(constant[0], iso)) return false;
    return true;
}

/// True when some edge that the upper neighbour `o` (bit 0: +x, 1: +y, 2: +z) owns, within this
/// block's 9^3 corners, is cut: the cells of this block then use a vertex that block makes.
inline bool ownsCutEdges(const Masks& m, int o) {
    const bool ox = o & 1, oy = o & 2, oz = o & 4;
    const std::uint32_t zmask = oz ? 0x100u : 0xFFu;
    for (int x = ox ? 8 : 0; x <= (ox ? 8 : 7); ++x)
        for (int y = oy ? 8 : 0; y <= (oy ? 8 : 7); ++y) {
            const std::uint32_t c = m.mask[x][y];
            if (!ox && ((c ^ m.mask[x + 1][y]) & zmask)) return true;
            if (!oy && ((c ^ m.mask[x][y + 1]) & zmask)) return true;
            if (!oz && ((c ^ (c >> 1)) & 0xFFu)) return true;
        }
    return false;
}

/// Index to world for affine transforms: a 3x3 matrix and a translation, in double precision.
struct AffineToWorld {
    double m[3][3], t[3];
    explicit AffineToWorld(const openvdb::Mat4d& a) {
        // OpenVDB's Mat4 acts on row vectors: world = index * M.
        for (int r = 0; r < 3; ++r) {
            for (int c = 0; c < 3; ++c) m[r][c] = a(c, r);
            t[r] = a(3, r);
        }
    }
    openvdb::Vec3d apply(const openvdb::Vec3d& p) const {
        return {m[0][0] * p[0] + m[0][1] * p[1] + m[0][2] * p[2] + t[0],
                m[1][0] * p[0] + m[1][1] * p[1] + m[1][2] * p[2] + t[1],
                m[2][0] * p[0] + m[2][1] * p[1] + m[2][2] * p[2] + t[2]};
    }
};

/// The values around a block, for gradients: the 27 regions of 8^3 at offsets -8, 0 and 8 along each axis
/// (a leaf's buffer, or the constant of a tile or the background), so that the twelve values of a
/// vertex's two central differences are array loads, not twelve walks down the tree. The same values as
/// the accessor's: a region that is not a leaf is one value.
struct Around {
    const float* data[27];
    float constant[27];

    void load(const Accessor& acc, const Coord& origin) {
        for (int i = 0; i < 27; ++i) {
            const Coord p = origin.offsetBy(8 * (i % 3 - 1), 8 * (i / 3 % 3 - 1), 8 * (i / 9 - 1));
            if (const Leaf* leaf = acc.probeConstLeaf(p)) {
                data[i] = leaf->buffer().data();
            } else {
                data[i] = nullptr;
                constant[i] = acc.getValue(p);
            }
        }
    }
    /// Value at block-local (x, y, z), each in [-8, 16).
    float value(int x, int y, int z) const {
        const int i = ((x + 8) >> 3) + 3 * ((y + 8) >> 3) + 9 * ((z + 8) >> 3);
        return data[i] ? data[i][((x & 7) << 6) | ((y & 7) << 3) | (z & 7)] : constant[i];
    }
};

/// Sources as `around` has them (its regions at offsets 0 and +8): no second walk of the tree.
Sources sourcesOf(const Around& around) {
    Sources src;
    for (int i = 0; i < 8; ++i) {
        const int j = ((i & 1) + 1) + 3 * (((i >> 1) & 1) + 1) + 9 * (((i >> 2) & 1) + 1);
        src.data[i] = around.data[j];
        src.constant[i] = around.constant[j];
    }
    return src;
}

/// Unit normal at index-space point p on the edge from block-local corner c0 along `axis`, at parameter
/// t: the grid gradient by central differences at both ends, interpolated, mapped to world space,
/// pointing out of the solid.
template <bool Below>
glm::vec3 normalAt(const Around& around, const openvdb::math::MapBase& map, bool world, const Coord& c0, int axis,
                   float t, const openvdb::Vec3d& p) {
    auto gradient = [&](const Coord& c) {
        const int x = c.x(), y = c.y(), z = c.z();
        return openvdb::Vec3d(around.value(x + 1, y, z) - around.value(x - 1, y, z),
                              around.value(x, y + 1, z) - around.value(x, y - 1, z),
                              around.value(x, y, z + 1) - around.value(x, y, z - 1));
    };
    Coord c1 = c0;
    c1[axis] += 1;
    openvdb::Vec3d g = gradient(c0) * (1.0 - t) + gradient(c1) * t;
    if (world) g = map.applyIJT(g, p);
    if (!Below) g = -g;
    const double len = g.length();
    return len > 0 ? glm::vec3(g.x() / len, g.y() / len, g.z() / len) : glm::vec3(0.f);
}

/// Inside bits of eight consecutive values.
template <bool Below>
inline std::uint32_t insideBits8(const float* p, float iso) {
#if defined(__SSE2__)
    const __m128 v = _mm_set1_ps(iso);
    const __m128 lo = _mm_loadu_ps(p), hi = _mm_loadu_ps(p + 4);
    if constexpr (Below)
        return static_cast<std::uint32_t>(_mm_movemask_ps(_mm_cmplt_ps(lo, v)) |
                                          (_mm_movemask_ps(_mm_cmplt_ps(hi, v)) << 4));
    else
        return static_cast<std::uint32_t>(_mm_movemask_ps(_mm_cmpgt_ps(lo, v)) |
                                          (_mm_movemask_ps(_mm_cmpgt_ps(hi, v)) << 4));
#else
    std::uint32_t bits = 0;
    for (int z = 0; z < 8; ++z) bits |= static_cast<std::uint32_t>(isInside<Below>(p[z], iso)) << z;
    return bits;
#endif
}

template <bool Below>
void computeMasks(const Sources& s, float iso, Masks& b) {
    for (int x = 0; x <= 8; ++x)
        for (int y = 0; y <= 8; ++y) {
            const int i = (x >> 3) | ((y >> 3) << 1);
            std::uint32_t bits;
            if (const float* p = s.data[i]) {
                p += ((x & 7) << 6) | ((y & 7) << 3);
                bits = insideBits8<Below>(p, iso);
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
    openvdb::CoordBBox leafBox;
    tree.evalLeafBoundingBox(leafBox);
    Coord lo = leafBox.min(), hi = leafBox.max();
    for (const Coord& c : extra) {
        lo.minComponent(c);
        hi.maxComponent(c);
    }
    packer.base = Coord(lo.x() & ~7, lo.y() & ~7, lo.z() & ~7) - Coord(8);
    for (int k = 0; k < 3; ++k) {
        const std::int64_t extent = (static_cast<std::int64_t>(hi[k]) - packer.base[k]) / 8 + 1;
        if (extent >= (std::int64_t{1} << kKeyBits))
            throw ResourceError("grid spans " + std::to_string(extent * 8) +
                                " voxels along one axis; the mesher addresses at most 16.7 million");
    }

    // Leaves, and those of their seven lower neighbours that are not leaves themselves (in a
    // narrow band most are), then the tile borders: sorted, unique.
    std::vector<std::uint64_t> keys(leaves.size());
    constexpr std::size_t kChunk = 1024;
    std::vector<std::vector<std::uint64_t>> lower((leaves.size() + kChunk - 1) / kChunk);
    tbb::parallel_for(std::size_t{0}, lower.size(), [&](std::size_t chunk) {
        Accessor acc(tree);
        std::vector<std::uint64_t>& mine = lower[chunk];
        for (std::size_t i = chunk * kChunk; i < std::min(leaves.size(), (chunk + 1) * kChunk); ++i) {
            const Coord o = leaves[i]->origin();
            keys[i] = packer.pack(o);
            for (int n = 1; n < 8; ++n) {
                const Coord c = o.offsetBy(-8 * (n & 1), -8 * ((n >> 1) & 1), -8 * ((n >> 2) & 1));
                if (!acc.probeConstLeaf(c)) mine.push_back(packer.pack(c));
            }
        }
    });
    std::size_t total = keys.size() + extra.size();
    for (const auto& l : lower) total += l.size();
    keys.reserve(total);
    for (const auto& l : lower) keys.insert(keys.end(), l.begin(), l.end());
    for (const Coord& c : extra) keys.push_back(packer.pack(c));
    tbb::parallel_sort(keys.begin(), keys.end());
    keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
    return keys;
}

class ProgressTicker {
public:
    ProgressTicker(Progress* p, const char* stage, std::size_t total) : p_(p), total_(total) {
        if (p_) p_->begin(stage);
    }
    // Runs while a cancellation unwinds too: end() must not throw (core/progress.h), and if one does
    // anyway the destructor swallows it rather than terminate the process.
    ~ProgressTicker() {
        if (!p_) return;
        try {
            p_->end();
        } catch (...) {
        }
    }
    void add(std::size_t n) {
        if (p_) p_->update(done_.fetch_add(n) + n, total_);
    }

private:
    Progress* p_;
    std::size_t total_;
    std::atomic<std::size_t> done_{0};
};

/// Index of the first key whose block origin has x >= `x` (keys sorted).
std::size_t firstWithX(const std::vector<std::uint64_t>& keys, const KeyPacker& packer, std::int64_t x) {
    return static_cast<std::size_t>(
        std::partition_point(keys.begin(), keys.end(),
                             [&](std::uint64_t k) { return std::int64_t{packer.unpack(k).x()} < x; }) -
        keys.begin());
}

/// Meshes the blocks with x origin in [slab.x0, slab.x1) (everything for the whole grid), numbering
/// vertices from slab.vertexBase; `out` also receives the vertices of the blocks at x1 (the ghosts the
/// slab's triangles use). Returns the number of vertices the slab owns.
template <bool Below>
std::size_t extract(const openvdb::FloatGrid& grid, const MeshingOptions& options, const SlabRange& slab,
                    mesh::TriMesh& out, MeshingStats& stats) {
    const Tree& tree = grid.tree();
    const float iso = options.isovalue;
    const mc::CaseTable& table = mc::caseTable();
    auto t0 = Clock::now();

    KeyPacker packer;
    std::vector<std::uint64_t> keys = collectBlocks<Below>(tree, iso, packer, stats.leaves);
    // A slab counts the blocks from x0 - 8 (whose missing neighbours the whole grid adds too: they may
    // own vertices of the slab) to x1 (the owners of its ghost vertices), and writes those in [x0, x1).
    if (!keys.empty())
        keys.erase(std::remove_if(keys.begin(), keys.end(),
                                  [&](std::uint64_t k) {
                                      const std::int64_t x = packer.unpack(k).x();
                                      return x < slab.x0 - 8 || x > slab.x1;
                                  }),
                   keys.end());
    std::size_t n = keys.size();
    auto index = std::make_unique<BlockIndex>(keys);
    stats.secondsSetup = secondsSince(t0);

    // Pass 1: inside masks, owned-vertex prefixes and triangle counts per block.
    t0 = Clock::now();
    auto blocks = std::make_unique<ScratchArray<BlockData>>(n);
    std::vector<std::uint64_t> vertexOffset(n + 1, 0), triangleOffset(n + 1, 0);
    {
        ProgressTicker ticker(options.progress, "meshing", 2 * n);
        // In a consistent grid every cut edge lies in a leaf's reach, so the blocks collected above
        // own all the vertices their cells use. A grid may still put two tiles of opposite sides
        // next to each other (a hand-made or inconsistently sampled grid): then a block's cells use
        // edges of a neighbour region that no block owns. Such neighbours are added and pass 1 is
        // run again, so that every grid gives a valid mesh (a rare second round, never a bad index).
        tbb::enumerable_thread_specific<std::vector<std::uint64_t>> missing;
        auto pass1 = [&](const tbb::blocked_range<std::size_t>& r) {
            Accessor acc(tree);
            Sources src;
            Masks masks;
            auto& mine = missing.local();
            for (std::size_t bi = r.begin(); bi != r.end(); ++bi) {
                src.load(acc, packer.unpack(keys[bi]));
                vertexOffset[bi + 1] = triangleOffset[bi + 1] = 0;
                if (src.isUniform<Below>(iso)) continue;  // eight constants on one side: no surface
                computeMasks<Below>(src, iso, masks);
                const std::uint32_t vertices = (*blocks)[bi].build(masks);
                std::uint32_t triangles = 0;
                for (int x = 0; x < 8; ++x)
                    for (int y = 0; y < 8; ++y) {
                        const std::uint64_t codes = rowCodes(masks, x, y);
                        if (isUniform(codes)) continue;
                        for (int z = 0; z < 8; ++z) triangles += table.triangleCount[(codes >> (4 * z)) & 0xFF];
                    }
                vertexOffset[bi + 1] = vertices;
                triangleOffset[bi + 1] = triangles;
                const Coord origin = packer.unpack(keys[bi]);
                // Only blocks that write triangles need their neighbours' vertices (a slab's ghost
                // owners at x1 do not: the next slab writes their triangles, and finds their neighbours).
                if (triangles == 0 || origin.x() >= slab.x1) continue;
                for (int o = 1; o < 8; ++o)
                    if (ownsCutEdges(masks, o)) {
                        const std::uint64_t key =
                            packer.pack(origin.offsetBy(8 * (o & 1), 8 * ((o >> 1) & 1), 8 * ((o >> 2) & 1)));
                        if (index->find(key) < 0) mine.push_back(key);
                    }
            }
            ticker.add(r.size());
        };
        for (;;) {
            tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 64), pass1);
            std::vector<std::uint64_t> add;
            for (auto& m : missing) {
                add.insert(add.end(), m.begin(), m.end());
                m.clear();
            }
            if (add.empty()) break;
            for (std::uint64_t key : add) {
                const Coord c = packer.unpack(key);
                for (int k = 0; k < 3; ++k)
                    if (((c[k] - packer.base[k]) >> 3) >= (1 << kKeyBits) - 1)
                        throw ResourceError("grid too large for the mesher's block addressing");
            }
            keys.insert(keys.end(), add.begin(), add.end());
            std::sort(keys.begin(), keys.end());
            keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
            n = keys.size();
            index = std::make_unique<BlockIndex>(keys);
            blocks = std::make_unique<ScratchArray<BlockData>>(n);
            vertexOffset.assign(n + 1, 0);
            triangleOffset.assign(n + 1, 0);
        }
        stats.blocks = n;
        std::partial_sum(vertexOffset.begin(), vertexOffset.end(), vertexOffset.begin());
        std::partial_sum(triangleOffset.begin(), triangleOffset.end(), triangleOffset.begin());
        stats.secondsCount = secondsSince(t0);

        // Blocks [first, last) are the slab's, [last, ghostEnd) own its ghost vertices.
        const std::size_t first = firstWithX(keys, packer, slab.x0), last = firstWithX(keys, packer, slab.x1),
                          ghostEnd = firstWithX(keys, packer, slab.x1 + 1);
        const std::uint64_t vfirst = vertexOffset[first];
        if (slab.vertexBase + vertexOffset[ghostEnd] - vfirst > std::numeric_limits<std::uint32_t>::max())
            throw ResourceError("the surface has more than " +
                                std::to_string(slab.vertexBase + vertexOffset[ghostEnd] - vfirst) +
                                " vertices, more than 32-bit indices can address");

        // Pass 2: vertices and triangles, each block at its own offsets.
        t0 = Clock::now();
        // On huge pages, faulted in by TBB's threads before the resizes zero them (core/big_buffer.h).
        // With 4 KB pages, their faults and zeroing were a fifth of the samples of a dense surface's
        // whole call (perf, a gyroid in 512^3 from Python: 280 MB of mesh).
        resizeLarge(out.positions, vertexOffset[ghostEnd] - vfirst);
        resizeLarge(out.triangles, triangleOffset[last] - triangleOffset[first]);
        if (options.normals)
            resizeLarge(out.normals, out.positions.size());
        else
            out.normals.clear();
        if (options.edgeValues) resizeLarge(*options.edgeValues, out.positions.size());

        const openvdb::math::Transform& xform = grid.transform();
        const bool affine = xform.isLinear();
        const AffineToWorld toWorld(affine ? xform.baseMap()->getAffineMap()->getMat4() : openvdb::Mat4d::identity());
        // Held once: Transform::baseMap() returns a shared pointer, whose count both threads would
        // otherwise bump for every vertex (a cache line bouncing between cores).
        const openvdb::math::MapBase::ConstPtr map = xform.baseMap();
        std::atomic<std::size_t> surfaceBlocks{0};

        tbb::parallel_for(
            tbb::blocked_range<std::size_t>(first, ghostEnd, 64), [&](const tbb::blocked_range<std::size_t>& r) {
                Accessor acc(tree);
                Sources src;
                Around around;
                std::uint32_t slots[kSlots];  // only entries of cut edges are written and read
                Masks masks;
                std::size_t localSurface = 0;
                for (std::size_t bi = r.begin(); bi != r.end(); ++bi) {
                    const std::uint64_t vbase = vertexOffset[bi];
                    if (vertexOffset[bi + 1] == vbase && triangleOffset[bi + 1] == triangleOffset[bi]) continue;
                    const bool ghost = bi >= last;
                    localSurface += !ghost;
                    const BlockData& b = (*blocks)[bi];
                    const Coord origin = packer.unpack(keys[bi]);
                    if (options.normals && vertexOffset[bi + 1] != vbase) {  // the 27 regions hold the 8
                        around.load(acc, origin);
                        src = sourcesOf(around);
                    } else {
                        src.load(acc, origin);
                    }
                    computeMasks<Below>(src, iso, masks);

                    // Vertices owned by this block, in rank order; their indices go to the slot table.
                    std::size_t vi = vbase - vfirst;
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
                                if (options.normals)
                                    out.normals[vi] =
                                        normalAt<Below>(around, *map, options.worldSpace, Coord(x, y, z), a, t, p);
                                if (options.edgeValues) (*options.edgeValues)[vi] = std::max(v0, v1);
                                if (options.worldSpace) p = affine ? toWorld.apply(p) : xform.indexToWorld(p);
                                out.positions[vi] = glm::vec3(p.x(), p.y(), p.z());
                                slots[a * 729 + x * 81 + y * 9 + z] =
                                    static_cast<std::uint32_t>(slab.vertexBase + vi++);
                            }
                        }
                    if (ghost) continue;  // the next slab writes its triangles

                    // Vertices on our upper faces that neighbour blocks own (their edges start at 8).
                    for (int o = 1; o < 7; ++o) {
                        const std::int64_t ob = index->find(
                            packer.pack(origin.offsetBy(8 * (o & 1), 8 * ((o >> 1) & 1), 8 * ((o >> 2) & 1))));
                        if (ob < 0) continue;
                        const BlockData& B = (*blocks)[static_cast<std::size_t>(ob)];
                        const std::uint64_t oOffset = vertexOffset[static_cast<std::size_t>(ob)];
                        if (vertexOffset[static_cast<std::size_t>(ob) + 1] == oOffset) continue;
                        const auto obase = static_cast<std::uint32_t>(slab.vertexBase + oOffset - vfirst);
                        const int ox = o & 1, oy = (o >> 1) & 1, oz = (o >> 2) & 1;
                        for (int a = 0; a < 3; ++a) {
                            if ((a == 0 && ox) || (a == 1 && oy) || (a == 2 && oz))
                                continue;  // edge would leave the block
                            for (int lx = 0; lx < (ox ? 1 : 8); ++lx) {
                                std::uint32_t rowStart = obase + B.prefix[a][lx];
                                for (int ly = 0; ly < (oy ? 1 : 8); ++ly) {
                                    const std::uint32_t row = edgeRow(B, a, lx, ly);
                                    std::uint32_t bits = row & (oz ? 1u : 0xFFu);
                                    const int sx = ox ? 8 : lx, sy = oy ? 8 : ly;
                                    for (; bits; bits &= bits - 1) {
                                        const int lz = std::countr_zero(bits);
                                        const std::uint32_t rank = popcount8(row & ((1u << lz) - 1u));
                                        slots[a * 729 + sx * 81 + sy * 9 + (oz ? 8 : lz)] = rowStart + rank;
                                    }
                                    rowStart += popcount8(row);
                                }
                            }
                        }
                    }

                    // Triangles: each corner is one slot-table load.
                    std::uint64_t ti = triangleOffset[bi] - triangleOffset[first];
                    for (int x = 0; x < 8; ++x)
                        for (int y = 0; y < 8; ++y) {
                            const std::uint64_t codes = rowCodes(masks, x, y);
                            if (isUniform(codes)) continue;
                            for (int z = 0; z < 8; ++z) {
                                const int code = static_cast<int>((codes >> (4 * z)) & 0xFF);
                                const int count = table.triangleCount[code];
                                const std::uint32_t* cell = slots + x * 81 + y * 9 + z;
                                const std::uint8_t* edges = table.edges[code].data();
                                for (int k = 0; k < count; ++k, edges += 3)
                                    out.triangles[ti++] =
                                        glm::uvec3(cell[kEdgeSlot[edges[0]]], cell[kEdgeSlot[edges[1]]],
                                                   cell[kEdgeSlot[edges[2]]]);
                            }
                        }
                }
                surfaceBlocks += localSurface;
                ticker.add(r.size());
            });
        stats.surfaceBlocks = surfaceBlocks;
        stats.secondsWrite = secondsSince(t0);
        return static_cast<std::size_t>(vertexOffset[last] - vfirst);
    }
}

/// Per 8^3 block, up to (8 / brick)^3 boxes (one per brick^3 sub-block) tight around its crossed cells.
template <bool Below>
std::vector<openvdb::CoordBBox> crossedBoxes(const openvdb::FloatGrid& grid, float iso, int brick) {
    const int shift = brick >= 8 ? 3 : (brick >= 4 ? 2 : 1), per = 8 >> shift, count = per * per * per;
    const Tree& tree = grid.tree();
    KeyPacker packer;
    std::size_t leafCount = 0;
    const std::vector<std::uint64_t> keys = collectBlocks<Below>(tree, iso, packer, leafCount);
    constexpr std::size_t kChunk = 256;
    std::vector<std::vector<openvdb::CoordBBox>> parts((keys.size() + kChunk - 1) / kChunk);
    tbb::parallel_for(std::size_t{0}, parts.size(), [&](std::size_t chunk) {
        Accessor acc(tree);
        Sources src;
        Masks masks;
        std::vector<openvdb::CoordBBox>& out = parts[chunk];
        for (std::size_t bi = chunk * kChunk; bi < std::min(keys.size(), (chunk + 1) * kChunk); ++bi) {
            const Coord origin = packer.unpack(keys[bi]);
            src.load(acc, origin);
            if (src.isUniform<Below>(iso)) continue;
            computeMasks<Below>(src, iso, masks);
            int lo[64][3], hi[64][3];
            for (int b = 0; b < count; ++b) {
                lo[b][0] = lo[b][1] = lo[b][2] = 8;
                hi[b][0] = hi[b][1] = hi[b][2] = -1;
            }
            const int b = 1 << shift;
            const std::uint32_t groupMask = (1u << b) - 1u;
            for (int x = 0; x < 8; ++x)
                for (int y = 0; y < 8; ++y) {
                    // Cell z is crossed unless its eight corners (bits z and z + 1 of four columns)
                    // are all inside or all outside.
                    const std::uint32_t c0 = masks.mask[x][y], c1 = masks.mask[x + 1][y], c2 = masks.mask[x][y + 1],
                                        c3 = masks.mask[x + 1][y + 1];
                    const std::uint32_t any = c0 | c1 | c2 | c3, all = c0 & c1 & c2 & c3;
                    const std::uint32_t crossed = ((any | (any >> 1)) & ~(all & (all >> 1))) & 0xFFu;
                    if (!crossed) continue;
                    for (int g = 0; g < per; ++g) {
                        const std::uint32_t bits = (crossed >> (g * b)) & groupMask;
                        if (!bits) continue;
                        const int sb = ((x >> shift) * per + (y >> shift)) * per + g;
                        const int zlo = g * b + std::countr_zero(bits), zhi = g * b + std::bit_width(bits);
                        lo[sb][0] = std::min(lo[sb][0], x);
                        hi[sb][0] = std::max(hi[sb][0], x + 1);
                        lo[sb][1] = std::min(lo[sb][1], y);
                        hi[sb][1] = std::max(hi[sb][1], y + 1);
                        lo[sb][2] = std::min(lo[sb][2], zlo);
                        hi[sb][2] = std::max(hi[sb][2], zhi);
                    }
                }
            for (int sb = 0; sb < count; ++sb)
                if (hi[sb][0] >= 0)
                    out.emplace_back(origin.offsetBy(lo[sb][0], lo[sb][1], lo[sb][2]),
                                     origin.offsetBy(hi[sb][0], hi[sb][1], hi[sb][2]));
        }
    });
    std::vector<openvdb::CoordBBox> boxes;
    std::size_t total = 0;
    for (const auto& p : parts) total += p.size();
    boxes.reserve(total);
    for (const auto& p : parts) boxes.insert(boxes.end(), p.begin(), p.end());
    return boxes;
}

}  // namespace

bool insideIsBelow(const openvdb::FloatGrid& grid, InsideSide side) {
    if (side == InsideSide::Below) return true;
    if (side == InsideSide::Above) return false;
    if (const auto meta = grid.getMetadata<openvdb::StringMetadata>("isoforge_inside")) return meta->value() == "below";
    return grid.getGridClass() == openvdb::GRID_LEVEL_SET;
}

namespace {

std::size_t extractRange(const openvdb::FloatGrid& grid, const MeshingOptions& options, const SlabRange& slab,
                         mesh::TriMesh& out, MeshingStats* stats) {
    MeshingStats local;
    const std::size_t owned = insideIsBelow(grid, options.inside) ? extract<true>(grid, options, slab, out, local)
                                                                  : extract<false>(grid, options, slab, out, local);
    // A transform that mirrors (negative determinant, as medical volumes with a flipped axis have) turns
    // counter-clockwise index-space triangles clockwise in world space: rewind them so normals stay outward.
    if (options.worldSpace && grid.transform().isLinear()) {
        const openvdb::Mat3d m = grid.transform().baseMap()->getAffineMap()->getMat4().getMat3();
        if (m.det() < 0)
            for (glm::uvec3& t : out.triangles) std::swap(t.y, t.z);
    }
    if (stats) *stats = local;
    return owned;
}

}  // namespace

void extractIsosurface(const openvdb::FloatGrid& grid, const MeshingOptions& options, mesh::TriMesh& out,
                       MeshingStats* stats) {
    extractRange(grid, options, SlabRange{}, out, stats);
}

std::size_t extractSlab(const openvdb::FloatGrid& grid, const MeshingOptions& options, const SlabRange& slab,
                        mesh::TriMesh& out, MeshingStats* stats) {
    if ((slab.x0 & 7) || (slab.x1 & 7) || slab.x1 <= slab.x0)
        throw std::invalid_argument("a slab is a non-empty range of 8-voxel block columns");
    return extractRange(grid, options, slab, out, stats);
}

std::vector<openvdb::CoordBBox> crossedCellBoxes(const openvdb::FloatGrid& grid, float iso, InsideSide side,
                                                 int brick) {
    if (brick != 2 && brick != 4 && brick != 8) throw std::invalid_argument("brick must be 2, 4 or 8 cells");
    return insideIsBelow(grid, side) ? crossedBoxes<true>(grid, iso, brick) : crossedBoxes<false>(grid, iso, brick);
}

mesh::TriMesh extractIsosurface(const openvdb::FloatGrid& grid, const MeshingOptions& options, MeshingStats* stats) {
    mesh::TriMesh mesh;
    extractIsosurface(grid, options, mesh, stats);
    return mesh;
}

}  // namespace isoforge::volume
