#include "volume/bricked.h"

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <vector>

#include <tbb/parallel_for.h>

namespace isoforge::volume {

namespace {

constexpr int kNode = 128;  // OpenVDB's level-1 internal nodes: where the sampler's visit starts
constexpr std::int64_t kOpen = std::int64_t{1} << 40;

using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point t) {
    return std::chrono::duration<double>(Clock::now() - t).count();
}

std::int64_t floorTo(std::int64_t a, std::int64_t b) {
    return (a >= 0 ? a / b : -((-a + b - 1) / b)) * b;
}

}  // namespace

std::vector<std::int64_t> slabOrigins(const implicit::Field& field, const SampleOptions& sample, int slabWidth) {
    if (slabWidth <= 0 || slabWidth % kNode)
        throw std::invalid_argument("the slab width is a positive multiple of 128 voxels");
    const auto [lo, hi] = sampleIndexRangeX(field, sample);
    std::vector<std::int64_t> origins;
    for (std::int64_t x = floorTo(lo, kNode); x <= hi; x += slabWidth) origins.push_back(x);
    return origins;
}

std::vector<std::size_t> partitionSlabs(const implicit::Field& field, const SampleOptions& sample, int slabWidth,
                                        int parts) {
    if (parts < 1) throw std::invalid_argument("at least one part");
    const std::vector<std::int64_t> origins = slabOrigins(field, sample, slabWidth);
    // Cost of a slab: a unit for its own overhead, and its top regions the surface may cross.
    std::vector<double> cost(origins.size(), 1.0);
    for (const auto& [x, regions] : surfaceRegionsByColumn(field, sample)) {
        const auto it = std::upper_bound(origins.begin(), origins.end(), x);
        if (it != origins.begin()) cost[static_cast<std::size_t>(it - origins.begin() - 1)] += double(regions);
    }
    double total = 0;
    for (double c : cost) total += c;
    // Part p ends where the running cost first reaches (p + 1) / parts of the total.
    std::vector<std::size_t> begin(static_cast<std::size_t>(parts) + 1, origins.size());
    begin[0] = 0;
    double running = 0;
    std::size_t s = 0;
    for (int p = 1; p < parts; ++p) {
        const double target = total * p / parts;
        while (s < origins.size() && running + cost[s] / 2 < target) running += cost[s++];
        begin[static_cast<std::size_t>(p)] = s;
    }
    return begin;
}

namespace {

/// A slab's grid: the voxels with x in [xBegin, xEnd), the rest background.
using SlabGrid = std::function<openvdb::FloatGrid::Ptr(std::int64_t xBegin, std::int64_t xEnd, SlabStats& stats)>;

std::size_t meshGridSlab(const SlabGrid& makeGrid, const implicit::Field* colorsFrom, const SlabOptions& options,
                         std::int64_t x0, std::int64_t x1, bool first, bool last, std::uint64_t vertexBase,
                         mesh::TriMesh& out, SlabStats& st) {
    // The slab, a block column below it (its cells' missing neighbours, its vertices' gradients) and
    // two above (the owners of its ghost vertices, and their lower neighbours).
    auto t0 = Clock::now();
    const openvdb::FloatGrid::Ptr grid = makeGrid(x0 - 8, x1 + 16, st);
    st.secondsSample += secondsSince(t0);

    t0 = Clock::now();
    MeshingOptions mo;
    mo.isovalue = options.isovalue;
    mo.inside = options.inside;
    mo.normals = options.normals;
    mo.worldSpace = !options.indexSpace;
    const SlabRange range{first ? -kOpen : x0, last ? kOpen : x1, vertexBase};
    MeshingStats ms;
    const std::size_t owned = extractSlab(*grid, mo, range, out, &ms);
    st.blocks += ms.blocks;
    if (options.colors && colorsFrom) {
        out.colors.resize(owned);
        tbb::parallel_for(std::size_t{0}, owned, [&](std::size_t i) {
            const glm::vec4 col = colorsFrom->colorAt(out.positions[i]);
            out.colors[i] = col.a > 0 ? glm::vec3(col) : glm::vec3(1.f);
        });
    } else {
        out.colors.clear();
    }
    st.secondsMesh += secondsSince(t0);
    st.vertices += owned;
    st.triangles += out.triangles.size();
    const std::uint64_t bytes = grid->memUsage() + out.positions.capacity() * 12 + out.normals.capacity() * 12 +
                                out.colors.capacity() * 12 + out.triangles.capacity() * 12;
    st.maxSlabBytes = std::max(st.maxSlabBytes, bytes);
    return owned;
}

void meshSlabsInOrder(const std::vector<std::int64_t>& origins, const SlabGrid& makeGrid,
                      const implicit::Field* colorsFrom, const SlabOptions& options,
                      const std::function<void(const SlabPiece&)>& sink, SlabStats& st) {
    if (options.progress) options.progress->begin("meshing slabs");
    std::uint64_t vertexBase = 0;
    mesh::TriMesh piece;
    for (std::size_t s = 0; s < origins.size(); ++s) {
        const std::int64_t x0 = origins[s], x1 = x0 + options.slabWidth;
        const std::size_t owned =
            meshGridSlab(makeGrid, colorsFrom, options, x0, x1, s == 0, s + 1 == origins.size(), vertexBase, piece, st);
        ++st.slabs;
        const auto t0 = Clock::now();
        sink(SlabPiece{piece, owned, vertexBase, x0, x1});
        st.secondsSink += secondsSince(t0);
        vertexBase += owned;
        if (options.progress) options.progress->update(s + 1, origins.size());
    }
    if (options.progress) options.progress->end();
}

SlabGrid fieldSlabs(const implicit::FieldPtr& field, const SlabOptions& options) {
    return [&field, &options](std::int64_t xBegin, std::int64_t xEnd, SlabStats& st) {
        SampleOptions so = options.sample;
        so.xBegin = xBegin;
        so.xEnd = xEnd;
        so.progress = nullptr;
        SampleStats ss;
        openvdb::FloatGrid::Ptr grid = sample(field, so, &ss);
        st.leaves += ss.leaves;
        return grid;
    };
}

}  // namespace

std::size_t meshSlab(const implicit::FieldPtr& field, const SlabOptions& options, std::int64_t x0, std::int64_t x1,
                     bool first, bool last, std::uint64_t vertexBase, mesh::TriMesh& out, SlabStats* stats) {
    SlabStats local;
    return meshGridSlab(fieldSlabs(field, options), field.get(), options, x0, x1, first, last, vertexBase, out,
                        stats ? *stats : local);
}

void meshBySlabs(const implicit::FieldPtr& field, const SlabOptions& options,
                 const std::function<void(const SlabPiece&)>& sink, SlabStats* stats) {
    SlabStats local;
    meshSlabsInOrder(slabOrigins(*field, options.sample, options.slabWidth), fieldSlabs(field, options), field.get(),
                     options, sink, stats ? *stats : local);
}

namespace {

SlabGrid volumeSlabs(const VolumeView& volume, const ToGridOptions& grid) {
    if (!grid.background) throw std::invalid_argument("a volume's slabs need the whole volume's background");
    return [&volume, &grid](std::int64_t xBegin, std::int64_t xEnd, SlabStats& st) {
        ToGridOptions o = grid;
        o.xBegin = xBegin;
        o.xEnd = xEnd;
        o.progress = nullptr;
        openvdb::FloatGrid::Ptr g = toGrid(volume, o);
        st.leaves += g->tree().leafCount();
        return g;
    };
}

}  // namespace

std::vector<std::int64_t> volumeSlabOrigins(const VolumeView& volume, int slabWidth) {
    if (slabWidth <= 0 || slabWidth % kNode)
        throw std::invalid_argument("the slab width is a positive multiple of 128 voxels");
    std::vector<std::int64_t> origins;
    for (std::int64_t x = 0; x < std::max<std::int64_t>(volume.dims[0], 1); x += slabWidth) origins.push_back(x);
    return origins;
}

std::size_t meshVolumeSlab(const VolumeView& volume, const ToGridOptions& grid, const SlabOptions& options,
                           std::int64_t x0, std::int64_t x1, bool first, bool last, std::uint64_t vertexBase,
                           mesh::TriMesh& out, SlabStats* stats) {
    SlabStats local;
    return meshGridSlab(volumeSlabs(volume, grid), nullptr, options, x0, x1, first, last, vertexBase, out,
                        stats ? *stats : local);
}

void meshVolumeBySlabs(const VolumeView& volume, const ToGridOptions& grid, const SlabOptions& options,
                       const std::function<void(const SlabPiece&)>& sink, SlabStats* stats) {
    const std::vector<std::int64_t> origins = volumeSlabOrigins(volume, options.slabWidth);
    SlabStats local;
    meshSlabsInOrder(origins, volumeSlabs(volume, grid), nullptr, options, sink, stats ? *stats : local);
}

void meshVolumeSourceBySlabs(const VoxelSource& source, const SlabOptions& options, std::uint64_t gridBudget,
                             const std::function<void(const SlabPiece&)>& sink, SlabStats* stats,
                             SourceSlabStats* sourceStats) {
    const VolumeView shape{nullptr, source.header.dims, source.header.indexToWorld, source.header.format};
    const std::vector<std::int64_t> origins = volumeSlabOrigins(shape, options.slabWidth);
    const auto slabEnd = [&](std::size_t i) { return origins[i] + options.slabWidth + 16; };  // with its halo
    SourceSlabStats local;
    SourceSlabStats& ss = sourceStats ? *sourceStats : local;
    NearLevelGrid pass;
    std::size_t first = 0, count = 0;  // the pass holds slabs [first, first + count)
    // The pass holding a slab; the next pass is read when the walk reaches its first slab.
    const SlabGrid fromPass = [&](std::int64_t xBegin, std::int64_t, SlabStats& st) {
        const std::size_t s = std::size_t((xBegin + 8) / options.slabWidth);
        if (ss.passes == 0 || s >= first + count) {
            pass = NearLevelGrid{};  // the last pass's grid goes before the next one's comes
            NearLevelOptions no;
            no.level = options.isovalue;
            no.insideAbove = options.inside != InsideSide::Below;  // Auto: a volume's grid says above
            no.xBegin = origins[s] - 8;
            no.xEnd = slabEnd(origins.size() - 1);
            for (std::size_t i = s; i + 1 < origins.size(); ++i) no.narrowerEnds.push_back(slabEnd(i));
            no.budgetBytes = gridBudget;
            pass = nearLevelGrid(source, no);
            first = s;
            count = 0;
            while (s + count < origins.size() && slabEnd(s + count) <= pass.xEnd) ++count;
            ++ss.passes;
            ss.windowBytes = pass.windowBytes;
            ss.gridBytes = std::max(ss.gridBytes, pass.gridBytes);
            ss.range = pass.range;
            ss.secondsRead += pass.seconds;
            st.leaves += pass.grid->tree().leafCount();
        }
        return pass.grid;  // each slab meshes its own blocks of it
    };
    SlabStats localSlabs;
    meshSlabsInOrder(origins, fromPass, nullptr, options, sink, stats ? *stats : localSlabs);
}

std::size_t meshGridSlab(const openvdb::FloatGrid::Ptr& grid, const SlabOptions& options, std::int64_t x0,
                         std::int64_t x1, bool first, bool last, std::uint64_t vertexBase, mesh::TriMesh& out,
                         SlabStats* stats) {
    SlabStats local;
    const SlabGrid same = [&grid](std::int64_t, std::int64_t, SlabStats&) { return grid; };
    return meshGridSlab(same, nullptr, options, x0, x1, first, last, vertexBase, out, stats ? *stats : local);
}

void meshGridBySlabs(const openvdb::FloatGrid& grid, const SlabOptions& options,
                     const std::function<void(const SlabPiece&)>& sink, SlabStats* stats) {
    if (options.slabWidth <= 0 || options.slabWidth % kNode)
        throw std::invalid_argument("the slab width is a positive multiple of 128 voxels");
    // The first slab is open below and the last open above: any run of origins covers every block.
    openvdb::CoordBBox box = grid.evalActiveVoxelBoundingBox();
    openvdb::CoordBBox leaves;
    grid.tree().evalLeafBoundingBox(leaves);
    box.expand(leaves);
    std::vector<std::int64_t> origins;
    if (box.empty())
        origins.push_back(0);
    else
        for (std::int64_t x = floorTo(box.min().x(), kNode); x <= box.max().x(); x += options.slabWidth)
            origins.push_back(x);
    const SlabGrid same = [&grid](std::int64_t, std::int64_t, SlabStats&) {
        return openvdb::ConstPtrCast<openvdb::FloatGrid>(grid.copy());  // shares the tree: no copy of the voxels
    };
    SlabStats local;
    meshSlabsInOrder(origins, same, nullptr, options, sink, stats ? *stats : local);
}

}  // namespace isoforge::volume
