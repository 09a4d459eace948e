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

std::size_t meshSlab(const implicit::FieldPtr& field, const SlabOptions& options, std::int64_t x0, std::int64_t x1,
                     bool first, bool last, std::uint64_t vertexBase, mesh::TriMesh& out, SlabStats* stats) {
    SlabStats local;
    SlabStats& st = stats ? *stats : local;
    // The slab, a block column below it (its cells' missing neighbours, its vertices' gradients) and
    // two above (the owners of its ghost vertices, and their lower neighbours).
    SampleOptions so = options.sample;
    so.xBegin = x0 - 8;
    so.xEnd = x1 + 16;
    so.progress = nullptr;
    auto t0 = Clock::now();
    SampleStats ss;
    const openvdb::FloatGrid::Ptr grid = sample(field, so, &ss);
    st.secondsSample += secondsSince(t0);
    st.leaves += ss.leaves;

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
    if (options.colors) {
        out.colors.resize(owned);
        tbb::parallel_for(std::size_t{0}, owned, [&](std::size_t i) {
            const glm::vec4 col = field->colorAt(out.positions[i]);
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

void meshBySlabs(const implicit::FieldPtr& field, const SlabOptions& options,
                 const std::function<void(const SlabPiece&)>& sink, SlabStats* stats) {
    SlabStats local;
    SlabStats& st = stats ? *stats : local;
    const std::vector<std::int64_t> origins = slabOrigins(*field, options.sample, options.slabWidth);
    if (options.progress) options.progress->begin("meshing slabs");
    std::uint64_t vertexBase = 0;
    mesh::TriMesh piece;
    for (std::size_t s = 0; s < origins.size(); ++s) {
        const std::int64_t x0 = origins[s], x1 = x0 + options.slabWidth;
        const std::size_t owned =
            meshSlab(field, options, x0, x1, s == 0, s + 1 == origins.size(), vertexBase, piece, &st);
        ++st.slabs;
        const auto t0 = Clock::now();
        sink(SlabPiece{piece, owned, vertexBase, x0, x1});
        st.secondsSink += secondsSince(t0);
        vertexBase += owned;
        if (options.progress) options.progress->update(s + 1, origins.size());
    }
    if (options.progress) options.progress->end();
}

}  // namespace isoforge::volume
