#include "volume/sample.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <unistd.h>
#include <glm/common.hpp>
#include <glm/vector_relational.hpp>

#include "core/error.h"
#include "core/number_text.h"
#include "implicit/primitives.h"
#include "volume/leaf_sampler.h"

namespace isoforge::volume {

using implicit::Box3;
using implicit::FieldPtr;
using openvdb::Coord;

Box3 sampleDomain(const implicit::Field& field, const Box3& clip) {
    return field.bounds().intersect(clip);
}

float voxelSizeForResolution(const Box3& domain, int n) {
    if (n <= 0) throw std::invalid_argument("resolution must be positive");
    const glm::vec3 s = domain.size();
    return std::max({s.x, s.y, s.z}) / static_cast<float>(n);
}

namespace {

constexpr int kTop = 128;  // top-level regions: OpenVDB's internal nodes of level 1
constexpr std::uint64_t kBytesPerLeaf = 512 * 4 + 64 + 96;

struct Job {
    Coord origin;
    FieldPtr field;
};
struct Tile {
    Coord origin;
    int level;  // OpenVDB tile level: 1 = 8^3, 2 = 128^3
};
struct TopResult {
    std::vector<Job> leaves;
    std::vector<Tile> tiles;
    std::uint64_t bounds = 0;
};

class Sampler {
public:
    Sampler(float voxel, float band, bool distance, std::uint64_t maxLeaves, std::int64_t xBegin, std::int64_t xEnd)
        : voxel_(voxel), band_(band), distance_(distance), maxLeaves_(maxLeaves), xBegin_(xBegin), xEnd_(xEnd) {}

    void visit(const Coord& origin, int size, const FieldPtr& f, TopResult& out) {
        if (abort_.load(std::memory_order_relaxed)) return;
        if (origin.x() >= xEnd_ || std::int64_t{origin.x()} + size <= xBegin_) return;  // outside the slab
        // Box of the voxel centres of the region; for non-distance fields one voxel more on each
        // side, so that every voxel next to a sign change is sampled.
        const float m = distance_ ? 0.f : voxel_;
        const Box3 box{
            glm::vec3(origin.x(), origin.y(), origin.z()) * voxel_ - glm::vec3(m),
            glm::vec3(origin.x() + size - 1, origin.y() + size - 1, origin.z() + size - 1) * voxel_ + glm::vec3(m)};
        const implicit::Interval b = f->bound(box);
        ++out.bounds;
        const float outsideAbove = distance_ ? band_ : 0.f;
        if (b.lo >= outsideAbove) return;           // all outside (or beyond the band): background
        if (b.hi <= -outsideAbove && b.hi < 0.f) {  // all inside: tiles
            // Within a slab only: beyond it the grid stays background, as the mesher of a slab expects.
            if (size == kTop && origin.x() >= xBegin_ && std::int64_t{origin.x()} + size <= xEnd_)
                out.tiles.push_back({origin, 2});
            else
                for (int x = 0; x < size; x += 8) {
                    if (origin.x() + x >= xEnd_ || std::int64_t{origin.x()} + x + 8 <= xBegin_) continue;
                    for (int y = 0; y < size; y += 8)
                        for (int z = 0; z < size; z += 8) out.tiles.push_back({origin.offsetBy(x, y, z), 1});
                }
            return;
        }
        if (size == 8) {  // a leaf samples its 512 voxel centres: the field pruned to their box
            out.leaves.push_back({origin, implicit::simplified(f, box)});
            if (leafCount_.fetch_add(1, std::memory_order_relaxed) + 1 > maxLeaves_) abort_ = true;
            return;
        }
        const FieldPtr g = implicit::simplified(f, box);
        const int h = size / 2;
        for (int i = 0; i < 8; ++i)
            visit(origin.offsetBy((i & 1) * h, ((i >> 1) & 1) * h, ((i >> 2) & 1) * h), h, g, out);
    }
    bool aborted() const { return abort_; }

private:
    float voxel_, band_;
    bool distance_;
    std::uint64_t maxLeaves_;
    std::int64_t xBegin_, xEnd_;
    std::atomic<std::uint64_t> leafCount_{0};
    std::atomic<bool> abort_{false};
};

/// Index range of the voxels to consider (voxel i is centred at i * voxel): the domain and a margin.
std::pair<glm::dvec3, glm::dvec3> indexRange(const Box3& domain, float voxel, float band) {
    const float margin = band + 2.f * voxel;
    return {glm::floor(glm::dvec3(domain.min - glm::vec3(margin)) / double(voxel)),
            glm::ceil(glm::dvec3(domain.max + glm::vec3(margin)) / double(voxel))};
}

/// Estimate: leaves along a surface like the domain's box, as thick as the band.
double boxArea(const glm::dvec3& extent) {
    return 2.0 * (extent.x * extent.y + extent.y * extent.z + extent.z * extent.x);
}

double gridBytesEstimate(const glm::dvec3& extent, bool distance, float halfWidth) {
    const double area = boxArea(extent);
    const double thickness = std::ceil((distance ? 2.0 * halfWidth : 2.0) / 8.0) + 1.0;
    return area / 64.0 * thickness * kBytesPerLeaf;
}

int floorDiv(int a, int b) {
    return a >= 0 ? a / b : -((-a + b - 1) / b);
}

}  // namespace

namespace {

/// indexRange() of the domain sample() would take for `field` under `o`; none when it is empty or unbounded.
std::optional<std::pair<glm::dvec3, glm::dvec3>> indexRangeOf(const implicit::Field& field, const SampleOptions& o) {
    const Box3 domain = sampleDomain(field, o.clip);
    if (!domain.isBounded() || domain.isEmpty() || !(o.voxelSize > 0)) return std::nullopt;
    return indexRange(domain, o.voxelSize, field.isDistance() ? o.halfWidth * o.voxelSize : 0.f);
}

}  // namespace

std::pair<std::int64_t, std::int64_t> sampleIndexRangeX(const implicit::Field& field, const SampleOptions& o) {
    const auto range = indexRangeOf(field, o);
    if (!range) return {0, -1};
    const auto [lo, hi] = *range;
    return {static_cast<std::int64_t>(lo.x), static_cast<std::int64_t>(hi.x)};
}

double estimateSampleBytes(const implicit::Field& field, const SampleOptions& o) {
    const auto range = indexRangeOf(field, o);
    if (!range) return 0;
    const auto [lo, hi] = *range;
    return gridBytesEstimate(hi - lo + 1.0, field.isDistance(), o.halfWidth);
}

double estimateSurfaceVoxels(const implicit::Field& field, const SampleOptions& o) {
    const auto range = indexRangeOf(field, o);
    if (!range) return 0;
    const auto [lo, hi] = *range;
    return boxArea(hi - lo + 1.0);
}

std::vector<std::pair<std::int64_t, std::uint64_t>> surfaceRegionsByColumn(const implicit::Field& field,
                                                                           const SampleOptions& o) {
    const auto range = indexRangeOf(field, o);
    if (!range) return {};
    const auto [lo, hi] = *range;
    const bool distance = field.isDistance();
    const float voxel = o.voxelSize, band = distance ? o.halfWidth * voxel : 0.f;
    const auto top = [](double v) { return static_cast<std::int64_t>(std::floor(v / kTop)); };
    const std::int64_t x0 = top(lo.x), x1 = top(hi.x), y0 = top(lo.y), y1 = top(hi.y), z0 = top(lo.z), z1 = top(hi.z);
    std::vector<std::pair<std::int64_t, std::uint64_t>> columns(static_cast<std::size_t>(x1 - x0 + 1));
    tbb::parallel_for(std::int64_t{0}, x1 - x0 + 1, [&](std::int64_t i) {
        std::uint64_t count = 0;
        const float m = distance ? 0.f : voxel;
        for (std::int64_t y = y0; y <= y1; ++y)
            for (std::int64_t z = z0; z <= z1; ++z) {
                // The sampler's first test of a top region (Sampler::visit).
                const glm::vec3 origin(float((x0 + i) * kTop), float(y * kTop), float(z * kTop));
                const Box3 box{origin * voxel - glm::vec3(m), (origin + glm::vec3(kTop - 1)) * voxel + glm::vec3(m)};
                const implicit::Interval b = field.bound(box);
                const float outsideAbove = distance ? band : 0.f;
                count += !(b.lo >= outsideAbove) && !(b.hi <= -outsideAbove && b.hi < 0.f);
            }
        columns[static_cast<std::size_t>(i)] = {(x0 + i) * kTop, count};
    });
    return columns;
}

openvdb::FloatGrid::Ptr sample(const FieldPtr& field, const SampleOptions& o, SampleStats* statsOut) {
    const auto t0 = std::chrono::steady_clock::now();
    if (!(o.voxelSize > 0) || !std::isfinite(o.voxelSize)) throw std::invalid_argument("voxel size must be positive");
    if (!(o.halfWidth >= 1.f)) throw std::invalid_argument("narrow-band half-width must be at least 1 voxel");
    SampleStats stats;
    stats.distance = field->isDistance();
    const float voxel = o.voxelSize;
    const float band = o.halfWidth * voxel;
    const float background = stats.distance ? band : 1.f;

    const Box3 domain = sampleDomain(*field, o.clip);
    if (!domain.isBounded())
        throw std::invalid_argument(field->describe() + " is unbounded: give a box to sample it in");
    if (domain.isEmpty()) {
        auto empty = openvdb::FloatGrid::create(background);
        empty->setTransform(openvdb::math::Transform::createLinearTransform(voxel));
        if (stats.distance) empty->setGridClass(openvdb::GRID_LEVEL_SET);
        return empty;
    }
    // Where the clip box cuts the field's bounds, sample the intersection with the box, so that the
    // surface closes on the box instead of running on into the margin.
    const Box3 own = field->bounds();
    const bool cut = !own.isBounded() || glm::any(glm::lessThan(own.min, o.clip.min)) ||
                     glm::any(glm::greaterThan(own.max, o.clip.max));
    const FieldPtr f = cut && o.clip.isBounded() ? implicit::makeClipped(field, o.clip) : field;

    const double maxIndex = double{1 << 30};
    const auto [lo, hi] = indexRange(domain, voxel, stats.distance ? band : 0.f);
    const glm::dvec3 extent = hi - lo + 1.0;
    const double bytesEstimate = gridBytesEstimate(extent, stats.distance, o.halfWidth);
    stats.estimatedBytes = bytesEstimate > 1.8e19 ? ~std::uint64_t{0} : static_cast<std::uint64_t>(bytesEstimate);
    const std::uint64_t limit = o.memoryLimit ? o.memoryLimit : physicalMemory() / 2;
    std::ostringstream dims;
    dims << static_cast<long long>(extent.x) << " x " << static_cast<long long>(extent.y) << " x "
         << static_cast<long long>(extent.z) << " voxels";
    const bool slab = o.xBegin > -(std::int64_t{1} << 40) || o.xEnd < (std::int64_t{1} << 40);
    if ((!slab && bytesEstimate > static_cast<double>(limit)) || std::abs(lo.x) > maxIndex ||
        std::abs(hi.x) > maxIndex || std::abs(lo.y) > maxIndex || std::abs(hi.y) > maxIndex ||
        std::abs(lo.z) > maxIndex || std::abs(hi.z) > maxIndex)
        throw ResourceError("sampling " + field->describe() + " at voxel size " + std::to_string(voxel) + " (" +
                            dims.str() + ") would need about " + bytesText(bytesEstimate) + "; the limit is " +
                            bytesText(static_cast<double>(limit)) + ". Use a larger voxel size or a lower resolution.");

    auto grid = openvdb::FloatGrid::create(background);
    grid->setTransform(openvdb::math::Transform::createLinearTransform(voxel));
    if (stats.distance)
        grid->setGridClass(openvdb::GRID_LEVEL_SET);
    else
        grid->insertMeta("isoforge_inside", openvdb::StringMetadata("below"));

    const Coord ilo(static_cast<int>(lo.x), static_cast<int>(lo.y), static_cast<int>(lo.z));
    const Coord ihi(static_cast<int>(hi.x), static_cast<int>(hi.y), static_cast<int>(hi.z));
    std::vector<Coord> tops;
    for (int x = floorDiv(ilo.x(), kTop); x <= floorDiv(ihi.x(), kTop); ++x) {
        if (x * std::int64_t{kTop} >= o.xEnd || (x + 1) * std::int64_t{kTop} <= o.xBegin) continue;
        for (int y = floorDiv(ilo.y(), kTop); y <= floorDiv(ihi.y(), kTop); ++y)
            for (int z = floorDiv(ilo.z(), kTop); z <= floorDiv(ihi.z(), kTop); ++z)
                tops.emplace_back(x * kTop, y * kTop, z * kTop);
    }

    // Top-down, in parallel over top regions; results kept per region for a deterministic order.
    Sampler sampler(voxel, band, stats.distance, std::max<std::uint64_t>(limit / kBytesPerLeaf, 1), o.xBegin, o.xEnd);
    std::vector<TopResult> results(tops.size());
    if (o.progress) o.progress->begin("sampling");
    std::atomic<std::size_t> done{0};
    tbb::parallel_for(std::size_t{0}, tops.size(), [&](std::size_t i) {
        sampler.visit(tops[i], kTop, f, results[i]);
        if (o.progress) o.progress->update(++done, 2 * tops.size());
    });
    if (sampler.aborted())
        throw ResourceError("sampling " + field->describe() + " outgrew the memory limit of " +
                            bytesText(static_cast<double>(limit)) + " (the surface is larger than " + dims.str() +
                            " suggested). Use a larger voxel size.");
    std::vector<Job> jobs;
    for (TopResult& r : results) {
        stats.boundsEvaluated += r.bounds;
        stats.tiles += r.tiles.size();
        for (Job& j : r.leaves) jobs.push_back(std::move(j));
    }
    stats.leaves = jobs.size();

    // Leaves: 512 points each, in parallel.
    using Leaf = openvdb::FloatTree::LeafNodeType;
    std::vector<std::unique_ptr<Leaf>> leaves(jobs.size());
    std::vector<std::uint8_t> allInside(jobs.size(), 0);
    std::atomic<std::uint64_t> evaluated{0};
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, jobs.size(), 16), [&](const auto& r) {
        LeafSampler ls(voxel, background, stats.distance);
        for (std::size_t j = r.begin(); j != r.end(); ++j) {
            const Coord& c = jobs[j].origin;
            const std::span<const float> values = ls.sample(*jobs[j].field, c);
            auto leaf = std::make_unique<Leaf>(c, background, false);
            bool anyActive = false, inside = true;
            for (int i = 0; i < 512; ++i) {
                float v = values[i];
                if (std::isnan(v)) v = background;  // outside the field's domain (sqrt of negatives...)
                inside = inside && v < 0.f;
                if (!stats.distance || std::abs(v) < background) {
                    leaf->setValueOn(static_cast<openvdb::Index>(i), v);
                    anyActive = true;
                } else {
                    leaf->setValueOff(static_cast<openvdb::Index>(i), v < 0.f ? -background : background);
                }
            }
            if (anyActive)
                leaves[j] = std::move(leaf);
            else
                allInside[j] = inside;
        }
        evaluated += ls.evaluated();
        if (o.progress)
            o.progress->update(tops.size() + (r.end() * tops.size()) / std::max<std::size_t>(jobs.size(), 1),
                               2 * tops.size());
    });
    stats.pointsEvaluated = evaluated;
    if (o.progress) o.progress->end();

    auto& tree = grid->tree();
    for (const TopResult& r : results)
        for (const Tile& t : r.tiles) tree.addTile(static_cast<openvdb::Index>(t.level), t.origin, -background, false);
    for (std::size_t j = 0; j < jobs.size(); ++j) {
        if (leaves[j])
            tree.addLeaf(leaves[j].release());
        else if (allInside[j])
            tree.addTile(1, jobs[j].origin, -background, false);
    }
    stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (statsOut) *statsOut = stats;
    return grid;
}

}  // namespace isoforge::volume
