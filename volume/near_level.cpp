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
/// The layers of cells it holds (below): a layer of blocks needs three, and up to six are still needed
/// when the last slice is in (the cells past the array's end).
constexpr std::int64_t kCellRing = 8;

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

/// Block ranges from cells. A cell is four voxels a side, offset by two: along an axis of b blocks,
/// cell c (0 .. 2b) covers voxels [4c - 2, 4c + 2) of the array. Block B's window, its voxels and
/// the two beyond them each way, [8B - 2, 8B + 10), is exactly cells 2B, 2B + 1 and 2B + 2. So the
/// voxels are each read once (into their cell) and a block takes the range of 27 cells; the reads
/// go down columns (x fastest, one element-wise min and max per voxel), never across a row.
constexpr std::int64_t cellOf(std::int64_t voxel) {
    return (voxel + 2) / 4;
}
constexpr std::int64_t cellsOf(std::int64_t blocks) {
    return 2 * blocks + 1;
}

/// A layer of cells in the making (one z cell, all its y cells, the x cells of block columns
/// [I0, I1)): the ranges of each y cell's voxel columns, x from i0, as slices arrive.
struct CellColumns {
    std::int64_t i0 = 0, i1 = 0;  ///< the voxels of the block columns and their two each side
    std::int64_t ncy = 0;
    std::vector<float> lo, hi;  ///< [cy * (i1 - i0) + i - i0]

    CellColumns(const Shape& s, std::int64_t I0, std::int64_t I1)
        : i0(std::max<std::int64_t>(8 * I0 - 2, 0)),
          i1(std::min(8 * I1 + 10, s.nx)),
          ncy(cellsOf(s.by)),
          lo(std::size_t(ncy * std::max<std::int64_t>(i1 - i0, 0))),
          hi(lo.size()) {}

    void reset() {
        std::fill(lo.begin(), lo.end(), std::numeric_limits<float>::infinity());
        std::fill(hi.begin(), hi.end(), -std::numeric_limits<float>::infinity());
    }

    /// Slice `values` (x fastest) folded in: y cells [cy0, cy1).
    void fold(const Shape& s, const float* values, std::int64_t cy0, std::int64_t cy1) {
        const std::int64_t w = i1 - i0;
        for (std::int64_t cy = cy0; cy < cy1; ++cy) {
            float* l = lo.data() + std::size_t(cy * w);
            float* h = hi.data() + std::size_t(cy * w);
            for (std::int64_t j = std::max<std::int64_t>(4 * cy - 2, 0); j < std::min(4 * cy + 2, s.ny); ++j) {
                const float* p = values + std::size_t(j * s.nx + i0);
                for (std::int64_t i = 0; i < w; ++i) {  // element-wise: vectorized
                    l[i] = std::min(l[i], p[i]);
                    h[i] = std::max(h[i], p[i]);
                }
            }
        }
    }
};

/// One z cell's ranges over the y cells and the x cells 2 * I0 .. 2 * I1 (ncx of them):
/// lo[cy * ncx + cx - 2 * I0], hi likewise.
struct CellLayer {
    std::int64_t cx0 = 0, ncx = 0;
    std::vector<float> lo, hi;

    CellLayer(const Shape& s, std::int64_t I0, std::int64_t I1)
        : cx0(2 * I0), ncx(I1 > I0 ? cellsOf(I1 - I0) : 0), lo(std::size_t(cellsOf(s.by) * ncx)), hi(lo.size()) {}

    /// Cell rows [cy0, cy1) from their columns' ranges; rangeLo and rangeHi take the range of those cells.
    void finish(const CellColumns& c, std::int64_t cy0, std::int64_t cy1, float& rangeLo, float& rangeHi) {
        const float inf = std::numeric_limits<float>::infinity();
        const std::int64_t w = c.i1 - c.i0;
        for (std::int64_t cy = cy0; cy < cy1; ++cy) {
            const float* l = c.lo.data() + std::size_t(cy * w);
            const float* h = c.hi.data() + std::size_t(cy * w);
            for (std::int64_t cx = cx0; cx < cx0 + ncx; ++cx) {
                float a = inf, b = -inf;
                for (std::int64_t i = std::max(4 * cx - 2, c.i0); i < std::min(4 * cx + 2, c.i1); ++i) {
                    a = std::min(a, l[i - c.i0]);
                    b = std::max(b, h[i - c.i0]);
                }
                lo[std::size_t(cy * ncx + cx - cx0)] = a;
                hi[std::size_t(cy * ncx + cx - cx0)] = b;
                rangeLo = std::min(rangeLo, a);
                rangeHi = std::max(rangeHi, b);
            }
        }
    }
};

/// The kinds of layer K's blocks in rows [J0, J1) and columns [I0, I1) (kind[(J - J0) * (I1 - I0) + I - I0]),
/// from its three layers of cells, z cells 2K, 2K + 1 and 2K + 2 (whose columns start at block I0).
void blockKinds(const Shape& s, std::int64_t K, std::int64_t J0, std::int64_t J1, std::int64_t I0, std::int64_t I1,
                const std::array<const CellLayer*, 3>& cells, float level, bool above, bool exteriorInside,
                std::uint8_t* kind) {
    const float inf = std::numeric_limits<float>::infinity();
    const std::int64_t ni = I1 - I0;
    for (std::int64_t J = J0; J < J1; ++J)
        for (std::int64_t I = I0; I < I1; ++I) {
            float l = inf, h = -inf;
            for (const CellLayer* c : cells)
                for (std::int64_t cy = 2 * J; cy <= 2 * J + 2; ++cy) {
                    const std::size_t at = std::size_t(cy * c->ncx + 2 * (I - I0));
                    for (std::size_t cx = at; cx <= at + 2; ++cx) {
                        l = std::min(l, c->lo[cx]);
                        h = std::max(h, c->hi[cx]);
                    }
                }
            const bool past = 8 * I - 2 < 0 || 8 * J - 2 < 0 || 8 * K - 2 < 0 || 8 * I + 10 > s.nx ||
                              8 * J + 10 > s.ny || 8 * K + 10 > s.nz;
            const bool in = (past && exteriorInside) || (above ? h > level : l < level);
            const bool out = (past && !exteriorInside) || (above ? l <= level : h >= level);
            kind[std::size_t((J - J0) * ni + I - I0)] = in && out ? kLeaf : (in ? kInside : kOutside);
        }
}

/// Layer K's tiles (the blocks of kind `tileKind`, the other side from the background) added to the tree
/// (columns [I0, I1), every row); the origins of its leaves appended to `leaves`.
void addLayer(Tree& tree, std::int64_t K, std::int64_t by, std::int64_t I0, std::int64_t I1, const std::uint8_t* kind,
              std::uint8_t tileKind, float tileValue, std::vector<openvdb::Coord>& leaves) {
    for (std::int64_t J = 0; J < by; ++J)
        for (std::int64_t I = I0; I < I1; ++I) {
            const std::uint8_t c = kind[std::size_t(J * (I1 - I0) + I - I0)];
            const openvdb::Coord o(int(8 * I), int(8 * J), int(8 * K));
            if (c == tileKind) tree.addTile(1, o, tileValue, true);
            if (c == kLeaf) leaves.push_back(o);
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

/// The leaves at `origins`, made and filled in parallel (each thread's allocations, and the first touch of
/// their pages, apart: made one by one in the tree they were a third of a dense volume's time), then
/// added to the tree. Their voxels past the array are inactive, `outsideValue`.
template <class Slice>
void addLeaves(Tree& tree, const std::vector<openvdb::Coord>& origins, const Shape& s, const Slice& slice,
               float outsideValue) {
    std::vector<Leaf*> made(origins.size(), nullptr);
    try {
        tbb::parallel_for(std::size_t{0}, origins.size(), [&](std::size_t n) {
            made[n] = new Leaf(origins[n], outsideValue, false);  // as Tree::touchLeaf makes it in the background
            fillLeaf(*made[n], s, slice, outsideValue);
        });
    } catch (...) {
        for (Leaf* leaf : made) delete leaf;
        throw;
    }
    for (Leaf* leaf : made) tree.addLeaf(leaf);  // the tree owns it
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
    // The cells, a layer of them per task (each thread reusing its columns), then the blocks' kinds.
    const float inf = std::numeric_limits<float>::infinity();
    const std::int64_t ncz = cellsOf(s.bz);
    std::vector<CellLayer> cells(std::size_t(ncz), CellLayer(s, 0, s.bx));
    std::vector<float> layerLo(std::size_t(ncz), inf), layerHi(std::size_t(ncz), -inf);
    tbb::enumerable_thread_specific<CellColumns> columns([&] { return CellColumns(s, 0, s.bx); });
    tbb::parallel_for(std::int64_t{0}, ncz, [&](std::int64_t cz) {
        CellColumns& c = columns.local();
        c.reset();
        for (std::int64_t k = std::max<std::int64_t>(4 * cz - 2, 0); k < std::min(4 * cz + 2, s.nz); ++k)
            c.fold(s, slice(k), 0, c.ncy);
        cells[std::size_t(cz)].finish(c, 0, c.ncy, layerLo[std::size_t(cz)], layerHi[std::size_t(cz)]);
    });
    std::vector<std::uint8_t> kind(std::size_t(s.bx * s.by * s.bz));
    tbb::parallel_for(std::int64_t{0}, s.bz, [&](std::int64_t K) {
        const std::size_t z = std::size_t(2 * K);
        blockKinds(s, K, 0, s.by, 0, s.bx, {&cells[z], &cells[z + 1], &cells[z + 2]}, level, insideAbove,
                   exteriorInside, kind.data() + std::size_t(K * s.by * s.bx));
    });
    const float minimum = *std::min_element(layerLo.begin(), layerLo.end());
    const float maximum = *std::max_element(layerHi.begin(), layerHi.end());
    if (range) *range = {minimum, maximum};
    const Fill f = fillOf(insideAbove, exteriorInside, minimum, maximum);
    auto grid = emptyGrid(v.indexToWorld, v.format, insideAbove, f.background);
    std::vector<openvdb::Coord> leaves;
    for (std::int64_t K = 0; K < s.bz; ++K)
        addLayer(grid->tree(), K, s.by, 0, s.bx, kind.data() + std::size_t(K * s.by * s.bx), f.tileKind, f.tileValue,
                 leaves);
    addLeaves(grid->tree(), leaves, s, slice, f.background);
    return grid;
}

std::uint64_t nearLevelWindowBytes(const VoxelSource& source) {
    const auto& d = source.header.dims;
    const auto n = [](std::int64_t a) { return std::uint64_t(std::max<std::int64_t>(a, 0)); };
    const auto cells = [&](std::int64_t a) { return std::uint64_t(cellsOf(std::int64_t((n(a) + 7) / 8))); };
    const std::uint64_t slice = n(d[0]) * n(d[1]), pair = 2 * sizeof(float);  // a range: lo and hi
    return std::min<std::uint64_t>(kRingSlices, n(d[2])) * slice * sizeof(float) +
           slice * detail::typeSize(source.header.storedType) +          // the slice being read
           cells(d[1]) * n(d[0]) * pair +                                // a z cell's columns
           std::uint64_t(kCellRing) * cells(d[1]) * cells(d[0]) * pair;  // the ring of cells
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
    // Each slice folded into its z cell's columns as it arrives; a z cell's ranges found when its last
    // slice is in, kept in a ring (block columns [I0, I1) as they were at the start: a pass that narrows
    // its slab classifies fewer of them).
    CellColumns columns(s, I0, I1);
    columns.reset();
    std::vector<CellLayer> cellRing(std::size_t(kCellRing), CellLayer(s, I0, I1));
    const auto cellsAt = [&](std::int64_t cz) -> CellLayer& { return cellRing[std::size_t(cz % kCellRing)]; };
    const auto foldSlice = [&](std::int64_t k) {
        tbb::parallel_for(
            tbb::blocked_range<std::int64_t>(0, columns.ncy, 4),
            [&](const tbb::blocked_range<std::int64_t>& cy) { columns.fold(s, sliceAt(k), cy.begin(), cy.end()); });
        if (k + 1 < s.nz && cellOf(k + 1) == cellOf(k)) return;
        CellLayer& cells = cellsAt(cellOf(k));
        tbb::parallel_for(tbb::blocked_range<std::int64_t>(0, columns.ncy, 4),
                          [&](const tbb::blocked_range<std::int64_t>& cy) {
                              float l = 0, h = 0;  // the range comes from whole slices, below
                              cells.finish(columns, cy.begin(), cy.end(), l, h);
                          });
        columns.reset();
        if (k + 1 == s.nz)  // the z cells past the array see none of it
            for (std::int64_t cz = cellOf(k) + 1; cz < cellsOf(s.bz); ++cz) {
                CellLayer& past = cellsAt(cz);
                std::fill(past.lo.begin(), past.lo.end(), std::numeric_limits<float>::infinity());
                std::fill(past.hi.begin(), past.hi.end(), -std::numeric_limits<float>::infinity());
            }
    };
    std::vector<std::uint8_t> kind;
    std::vector<openvdb::Coord> leaves;
    const auto buildLayer = [&](std::int64_t K) {
        const std::int64_t ni = I1 - I0;
        if (ni <= 0) return;
        kind.assign(std::size_t(s.by * ni), kOutside);
        const std::array<const CellLayer*, 3> cells{&cellsAt(2 * K), &cellsAt(2 * K + 1), &cellsAt(2 * K + 2)};
        tbb::parallel_for(tbb::blocked_range<std::int64_t>(0, s.by, 4),
                          [&](const tbb::blocked_range<std::int64_t>& js) {
                              blockKinds(s, K, js.begin(), js.end(), I0, I1, cells, o.level, above, exteriorInside,
                                         kind.data() + std::size_t(js.begin() * ni));
                          });
        leaves.clear();
        addLayer(tree, K, s.by, I0, I1, kind.data(), fillOf(above, exteriorInside, 0, 0).tileKind, 0.f, leaves);
        addLeaves(tree, leaves, s, sliceAt, 0.f);
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
        if (I1 > I0) foldSlice(k);
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
