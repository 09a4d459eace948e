#include "volume/near_level.h"

#include <algorithm>
#include <chrono>
#include <future>
#include <limits>
#include <stdexcept>

#include <openvdb/tools/Prune.h>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include "core/big_buffer.h"
#include "core/error.h"
#include "volume/dense_grid.h"
#include "volume/readers.h"
#include "volume/vdb_io.h"

namespace isoforge::volume {

namespace {

using Tree = openvdb::FloatGrid::TreeType;
using Leaf = Tree::LeafNodeType;

/// The slices a streamed pass holds: the twelve that a layer of blocks needs, and the next one read meanwhile.
constexpr std::int64_t kRingSlices = 13;

/// A volume's voxels and its 8^3 blocks.
struct Shape {
    std::int64_t nx, ny, nz, bx, by, bz;
    explicit Shape(const std::array<std::int64_t, 3>& d)
        : nx(d[0]), ny(d[1]), nz(d[2]), bx((d[0] + 7) / 8), by((d[1] + 7) / 8), bz((d[2] + 7) / 8) {}
};

/// What a block is for the level: 0 outside, 1 inside, 2 both (a leaf). A block whose voxels, or those
/// within two voxels of them, lie on both sides of the level is a leaf; a block reaching past the array
/// sees outside there, or inside where `exteriorInside`.
enum : std::uint8_t { kOutside = 0, kInside = 1, kLeaf = 2 };

/// The ranges of one slice's rows [j0, j1) over each block column I in [I0, I1), widened by two voxels
/// each way, at rowLo[(j - j0) * stride + I - I0] (rowHi likewise); lo and hi take the values visited.
void rowRanges(const Shape& s, const float* values, std::int64_t j0, std::int64_t j1, std::int64_t I0, std::int64_t I1,
               std::int64_t stride, float* rowLo, float* rowHi, float& lo, float& hi) {
    const float inf = std::numeric_limits<float>::infinity();
    for (std::int64_t j = j0; j < j1; ++j) {
        const float* p = values + std::size_t(j * s.nx);
        float* l8 = rowLo + std::size_t((j - j0) * stride);
        float* h8 = rowHi + std::size_t((j - j0) * stride);
        for (std::int64_t I = I0; I < I1; ++I) {
            float l = inf, h = -inf;
            for (std::int64_t i = std::max<std::int64_t>(8 * I - 2, 0); i < std::min(8 * I + 10, s.nx); ++i) {
                l = std::min(l, p[i]);  // branch-free: vectorized
                h = std::max(h, p[i]);
            }
            l8[I - I0] = l;
            h8[I - I0] = h;
            lo = std::min(lo, l);
            hi = std::max(hi, h);
        }
    }
}

/// The kinds of layer K's blocks in rows [J0, J1) and columns [I0, I1) (kind[(J - J0) * (I1 - I0) + I - I0]),
/// from the row ranges of its slices and the two each side: rows(k, j) gives the lo and hi of slice k's
/// row j at column I0 (rowRanges').
template <class Rows>
void blockKinds(const Shape& s, std::int64_t K, std::int64_t J0, std::int64_t J1, std::int64_t I0, std::int64_t I1,
                const Rows& rows, float level, bool above, bool exteriorInside, std::uint8_t* kind) {
    const float inf = std::numeric_limits<float>::infinity();
    const std::int64_t k0 = std::max<std::int64_t>(8 * K - 2, 0), k1 = std::min(8 * K + 10, s.nz);
    const std::int64_t ni = I1 - I0;
    for (std::int64_t J = J0; J < J1; ++J)
        for (std::int64_t I = I0; I < I1; ++I) {
            float l = inf, h = -inf;
            for (std::int64_t k = k0; k < k1; ++k)
                for (std::int64_t j = std::max<std::int64_t>(8 * J - 2, 0); j < std::min(8 * J + 10, s.ny); ++j) {
                    const auto [rl, rh] = rows(k, j);
                    l = std::min(l, rl[I - I0]);
                    h = std::max(h, rh[I - I0]);
                }
            const bool past = 8 * I - 2 < 0 || 8 * J - 2 < 0 || 8 * K - 2 < 0 || 8 * I + 10 > s.nx ||
                              8 * J + 10 > s.ny || 8 * K + 10 > s.nz;
            const bool in = (past && exteriorInside) || (above ? h > level : l < level);
            const bool out = (past && !exteriorInside) || (above ? l <= level : h >= level);
            kind[std::size_t((J - J0) * ni + I - I0)] = in && out ? kLeaf : (in ? kInside : kOutside);
        }
}

/// blockKinds for a volume in memory: layer K's row ranges found first, in `buffer`. `slice(k)` gives
/// slice k, x fastest; lo and hi take the range of the rows visited.
template <class Slice>
void classifyBlocks(const Shape& s, std::int64_t K, std::int64_t J0, std::int64_t J1, std::int64_t I0, std::int64_t I1,
                    const Slice& slice, float level, bool above, bool exteriorInside, std::uint8_t* kind,
                    std::vector<float>& buffer, float& lo, float& hi) {
    const std::int64_t k0 = std::max<std::int64_t>(8 * K - 2, 0), k1 = std::min(8 * K + 10, s.nz);
    const std::int64_t j0 = std::max<std::int64_t>(8 * J0 - 2, 0), j1 = std::min(8 * J1 + 10, s.ny);
    const std::int64_t ni = I1 - I0, nj = j1 - j0;
    const std::size_t rows = std::size_t((k1 - k0) * nj * ni);
    buffer.resize(2 * rows);
    float *rowLo = buffer.data(), *rowHi = buffer.data() + rows;
    for (std::int64_t k = k0; k < k1; ++k) {
        const std::size_t at = std::size_t((k - k0) * nj * ni);
        rowRanges(s, slice(k), j0, j1, I0, I1, ni, rowLo + at, rowHi + at, lo, hi);
    }
    blockKinds(
        s, K, J0, J1, I0, I1,
        [&](std::int64_t k, std::int64_t j) {
            const std::size_t at = std::size_t(((k - k0) * nj + j - j0) * ni);
            return std::pair<const float*, const float*>(rowLo + at, rowHi + at);
        },
        level, above, exteriorInside, kind);
}

/// Layer K's tiles (the blocks of kind `tileKind`, the other side from the background) and leaves
/// (columns [I0, I1), every row) added to the tree; the leaves, still empty, appended to `leaves`.
void addLayer(Tree& tree, std::int64_t K, std::int64_t by, std::int64_t I0, std::int64_t I1, const std::uint8_t* kind,
              std::uint8_t tileKind, float tileValue, std::vector<Leaf*>& leaves) {
    for (std::int64_t J = 0; J < by; ++J)
        for (std::int64_t I = I0; I < I1; ++I) {
            const std::uint8_t c = kind[std::size_t(J * (I1 - I0) + I - I0)];
            const openvdb::Coord o(int(8 * I), int(8 * J), int(8 * K));
            if (c == tileKind) tree.addTile(1, o, tileValue, true);
            if (c == kLeaf) leaves.push_back(tree.touchLeaf(o));
        }
}

/// A leaf's voxels as they are; those past the array inactive, `outsideValue`.
template <class Slice>
void fillLeaf(Leaf& leaf, const Shape& s, const Slice& slice, float outsideValue) {
    const openvdb::Coord o = leaf.origin();
    if (o.x() + 8 <= s.nx && o.y() + 8 <= s.ny && o.z() + 8 <= s.nz) {  // wholly in the array: rows of 8 at once
        float* buffer = leaf.buffer().data();                           // x slowest, z fastest
        for (int dz = 0; dz < 8; ++dz) {
            const float* values = slice(o.z() + dz);
            for (int dy = 0; dy < 8; ++dy) {
                const float* row = values + std::size_t((o.y() + dy) * s.nx + o.x());
                for (int dx = 0; dx < 8; ++dx) buffer[(dx << 6) | (dy << 3) | dz] = row[dx];
            }
        }
        leaf.setValuesOn();
        return;
    }
    for (int dz = 0; dz < 8; ++dz)
        for (int dy = 0; dy < 8; ++dy)
            for (int dx = 0; dx < 8; ++dx) {
                const std::int64_t i = o.x() + dx, j = o.y() + dy, k = o.z() + dz;
                const openvdb::Index offset = Leaf::coordToOffset(openvdb::Coord(int(i), int(j), int(k)));
                if (i < s.nx && j < s.ny && k < s.nz)
                    leaf.setValueOn(offset, slice(k)[std::size_t(j * s.nx + i)]);
                else
                    leaf.setValueOff(offset, outsideValue);
            }
}

/// The grid's background, and which blocks become tiles of what: the outside extreme as background and
/// the inside blocks tiles of the other; where the exterior is inside (below the level, toGrid's
/// minimum), the minimum as background and the outside blocks tiles of the maximum.
struct Fill {
    float background;
    std::uint8_t tileKind;
    float tileValue;
};
Fill fillOf(bool above, bool exteriorInside, float lo, float hi) {
    if (above) return {lo, kInside, hi};
    if (exteriorInside) return {lo, kOutside, hi};
    return {hi, kInside, lo};
}

openvdb::FloatGrid::Ptr emptyGrid(const glm::dmat4& indexToWorld, const std::string& format, bool above,
                                  float outsideValue) {
    auto grid = openvdb::FloatGrid::create(outsideValue);
    grid->setTransform(transformOf(indexToWorld));
    grid->setGridClass(openvdb::GRID_FOG_VOLUME);
    grid->insertMeta("isoforge_inside", openvdb::StringMetadata(above ? "above" : "below"));
    grid->insertMeta("source_format", openvdb::StringMetadata(format));
    return grid;
}

std::uint64_t treeBytes(const Tree& tree) {
    const std::vector<openvdb::Index32> n = tree.nodeCount();                   // leaves, then internal nodes by level
    return std::uint64_t(n[0]) * (sizeof(Leaf) + Leaf::SIZE * sizeof(float)) +  // a leaf's values are apart
           std::uint64_t(n[1]) * sizeof(Tree::RootNodeType::ChildNodeType::ChildNodeType) +
           std::uint64_t(n[2]) * sizeof(Tree::RootNodeType::ChildNodeType);
}

/// Removes the leaves and tiles at x >= x0, and the nodes left empty. (Tree::clip would also prune
/// leaves of one value into tiles, which the mesher does not visit.)
void dropFrom(Tree& tree, int x0) {
    std::vector<openvdb::Coord> drop;
    for (auto leaf = tree.cbeginLeaf(); leaf; ++leaf)
        if (leaf->origin().x() >= x0) drop.push_back(leaf->origin());
    auto tile = tree.cbeginValueOn();
    tile.setMaxDepth(Tree::ValueOnCIter::LEAF_DEPTH - 1);
    for (; tile; ++tile)
        if (tile.getCoord().x() >= x0) drop.push_back(tile.getCoord());
    for (const openvdb::Coord& o : drop) tree.addTile(1, o, tree.background(), false);
    openvdb::tools::pruneInactive(tree);
}

}  // namespace

openvdb::FloatGrid::Ptr toGridNearLevel(const VolumeView& v, float level, bool insideAbove,
                                        std::pair<float, float>* range, bool exteriorOutside) {
    initializeOpenVdb();
    if (v.xOffset != 0) throw std::invalid_argument("toGridNearLevel takes a whole volume (xOffset 0)");
    const Shape s(v.dims);
    const bool exteriorInside = !insideAbove && !exteriorOutside;
    if (s.nx <= 0 || s.ny <= 0 || s.nz <= 0) {
        if (range) *range = {0.f, 0.f};
        return openvdb::FloatGrid::create(0.f);
    }
    const auto slice = [&](std::int64_t k) { return v.values + std::size_t(k * s.ny * s.nx); };
    // Per layer of blocks (parallel), in a buffer each thread reuses.
    const float inf = std::numeric_limits<float>::infinity();
    std::vector<std::uint8_t> kind(std::size_t(s.bx * s.by * s.bz));
    std::vector<float> layerLo(std::size_t(s.bz), inf), layerHi(std::size_t(s.bz), -inf);
    tbb::enumerable_thread_specific<std::vector<float>> scratch;
    tbb::parallel_for(std::int64_t{0}, s.bz, [&](std::int64_t K) {
        classifyBlocks(s, K, 0, s.by, 0, s.bx, slice, level, insideAbove, exteriorInside,
                       kind.data() + std::size_t(K * s.by * s.bx), scratch.local(), layerLo[std::size_t(K)],
                       layerHi[std::size_t(K)]);
    });
    const float minimum = *std::min_element(layerLo.begin(), layerLo.end());
    const float maximum = *std::max_element(layerHi.begin(), layerHi.end());
    if (range) *range = {minimum, maximum};
    const Fill f = fillOf(insideAbove, exteriorInside, minimum, maximum);
    auto grid = emptyGrid(v.indexToWorld, v.format, insideAbove, f.background);
    std::vector<Leaf*> leaves;
    for (std::int64_t K = 0; K < s.bz; ++K)
        addLayer(grid->tree(), K, s.by, 0, s.bx, kind.data() + std::size_t(K * s.by * s.bx), f.tileKind, f.tileValue,
                 leaves);
    tbb::parallel_for(std::size_t{0}, leaves.size(),
                      [&](std::size_t n) { fillLeaf(*leaves[n], s, slice, f.background); });
    return grid;
}

std::uint64_t nearLevelWindowBytes(const VoxelSource& source) {
    const auto& d = source.header.dims;
    const auto n = [](std::int64_t a) { return std::uint64_t(std::max<std::int64_t>(a, 0)); };
    const std::uint64_t slice = n(d[0]) * n(d[1]), rows = n(d[1]) * ((n(d[0]) + 7) / 8) * 2 * sizeof(float);
    return std::min<std::uint64_t>(kRingSlices, n(d[2])) * (slice * sizeof(float) + rows) +
           slice * detail::typeSize(source.header.storedType);
}

NearLevelGrid nearLevelGrid(const VoxelSource& source, const NearLevelOptions& o) {
    initializeOpenVdb();
    const auto t0 = std::chrono::steady_clock::now();
    const Shape s(source.header.dims);
    const bool above = o.insideAbove, exteriorInside = !above && !o.exteriorOutside;
    const auto column = [&](std::int64_t x) {  // the first block column at or past x
        return std::clamp<std::int64_t>(x >= 0 ? x / 8 + (x % 8 != 0) : 0, 0, s.bx);
    };
    const std::int64_t I0 = column(o.xBegin);
    std::int64_t I1 = std::max(I0, column(o.xEnd));
    NearLevelGrid r;
    r.xEnd = o.xEnd;
    r.windowBytes = nearLevelWindowBytes(source);
    // The inside and outside values are the volume's extremes, known at the end: tiles and the
    // background take them then.
    auto grid = emptyGrid(source.header.indexToWorld, source.header.format, above, 0.f);
    Tree& tree = grid->tree();
    const std::int64_t slice = s.nx * s.ny;
    if (slice * s.nz <= 0) {
        r.grid = grid;
        return r;
    }
    // Layer K's blocks need slices 8K - 2 .. 8K + 9: twelve slices in a ring, and a thirteenth that the
    // next slice is read into while the main thread works on the last one.
    const std::int64_t kWindow = std::min<std::int64_t>(kRingSlices, s.nz);
    std::vector<float> ring;
    resizeLarge(ring, std::size_t(kWindow * slice));
    const auto sliceAt = [&](std::int64_t k) { return ring.data() + std::size_t((k % kWindow) * slice); };
    // Each slice's row ranges, found once as it arrives (a layer's blocks take those of twelve slices,
    // each slice serving one or two layers): lo then hi, rows of `stride` block columns from I0.
    const std::int64_t stride = std::max<std::int64_t>(I1 - I0, 1);
    std::vector<float> rowRing(std::size_t(kWindow * 2 * s.ny * stride));
    const auto rowsOf = [&](std::int64_t k) { return rowRing.data() + std::size_t((k % kWindow) * 2 * s.ny * stride); };
    const auto rangeRows = [&](std::int64_t k) {
        float* lo = rowsOf(k);
        tbb::parallel_for(tbb::blocked_range<std::int64_t>(0, s.ny, 16),
                          [&](const tbb::blocked_range<std::int64_t>& js) {
                              float l = 0, h = 0;  // the range comes from whole slices, below
                              rowRanges(s, sliceAt(k), js.begin(), js.end(), I0, I1, stride, lo + js.begin() * stride,
                                        lo + (s.ny + js.begin()) * stride, l, h);
                          });
    };
    std::vector<std::uint8_t> kind;
    std::vector<Leaf*> leaves;
    const auto buildLayer = [&](std::int64_t K) {
        const std::int64_t ni = I1 - I0;
        if (ni <= 0) return;
        kind.assign(std::size_t(s.by * ni), kOutside);
        const auto rows = [&](std::int64_t k, std::int64_t j) {
            const float* lo = rowsOf(k) + j * stride;
            return std::pair<const float*, const float*>(lo, lo + s.ny * stride);
        };
        tbb::parallel_for(tbb::blocked_range<std::int64_t>(0, s.by, 4),
                          [&](const tbb::blocked_range<std::int64_t>& js) {
                              blockKinds(s, K, js.begin(), js.end(), I0, I1, rows, o.level, above, exteriorInside,
                                         kind.data() + std::size_t(js.begin() * ni));
                          });
        leaves.clear();
        addLayer(tree, K, s.by, I0, I1, kind.data(), fillOf(above, exteriorInside, 0, 0).tileKind, 0.f, leaves);
        tbb::parallel_for(std::size_t{0}, leaves.size(), [&](std::size_t n) { fillLeaf(*leaves[n], s, sliceAt, 0.f); });
        // Over budget: drop the last slabs' blocks, as many as it takes.
        std::uint64_t bytes = treeBytes(tree);
        while (bytes > o.budgetBytes) {
            const auto e = std::lower_bound(o.narrowerEnds.begin(), o.narrowerEnds.end(), r.xEnd);
            if (e == o.narrowerEnds.begin())
                throw ResourceError(
                    (source.parts.empty() ? std::string("a volume") : source.parts.front().file.string()) +
                    ": the grid of one slab's blocks near the level outgrew its budget of " +
                    std::to_string(o.budgetBytes >> 20) + " MiB");
            r.xEnd = *(e - 1);
            I1 = std::max(I0, column(r.xEnd));
            dropFrom(tree, int(8 * I1));
            bytes = treeBytes(tree);
        }
    };
    SliceStream stream(source);
    // The file is read one slice ahead on another thread (its bytes and their conversion), into the slot
    // that no layer still to be built needs; what the main thread does is the same whatever the timing.
    const auto readInto = [&stream](float* out) {
        return std::async(std::launch::async, [&stream, out] { stream.read(1, out); });
    };
    std::future<void> next = readInto(sliceAt(0));
    float lo = 0, hi = 0;
    std::int64_t K = 0;  // the next layer to build
    if (o.progress) o.progress->begin("reading " + source.header.format + " slices");
    for (std::int64_t k = 0; k < s.nz; ++k) {
        float* values = sliceAt(k);
        next.get();
        if (k + 1 < s.nz) next = readInto(sliceAt(k + 1));
        if (k == 0) lo = hi = values[0];  // as DenseVolume::range, over the whole volume in order
        detail::extendRange(values, std::size_t(slice), lo, hi);
        if (I1 > I0) rangeRows(k);
        for (; K < s.bz && (k >= 8 * K + 9 || k + 1 == s.nz); ++K) buildLayer(K);
        if (o.progress) o.progress->update(std::size_t(k + 1), std::size_t(s.nz));
    }
    if (o.progress) o.progress->end();
    r.range = {lo, hi};
    const Fill f = fillOf(above, exteriorInside, lo, hi);
    tree.root().setBackground(f.background, true);  // and the leaves' voxels past the array
    auto tile = tree.beginValueOn();
    tile.setMaxDepth(Tree::ValueOnIter::LEAF_DEPTH - 1);  // tiles only
    for (; tile; ++tile) tile.setValue(f.tileValue);
    r.grid = grid;
    r.gridBytes = treeBytes(tree);
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return r;
}

}  // namespace isoforge::volume
