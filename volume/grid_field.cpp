#include "volume/grid_field.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <unordered_map>

#include <openvdb/tools/Interpolation.h>
#include <tbb/enumerable_thread_specific.h>

#include "volume/marching_cubes.h"
#include "volume/vdb_io.h"

namespace isoforge::volume {

using implicit::Box3;
using implicit::Interval;

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

std::uint64_t leafKey(const openvdb::Coord& c) {
    auto part = [](int v) { return static_cast<std::uint64_t>(static_cast<std::uint32_t>(v >> 3) & 0x1fffffu); };
    return part(c.x()) | (part(c.y()) << 21) | (part(c.z()) << 42);
}

class GridField final : public implicit::Field {
public:
    GridField(openvdb::FloatGrid::ConstPtr grid, float iso, bool insideBelow, std::string what)
        : grid_(std::move(grid)),
          iso_(iso),
          sign_(insideBelow ? 1.f : -1.f),
          what_(std::move(what)),
          accessors_([this] { return Accessor(grid_->tree()); }) {
        const auto& tree = grid_->tree();
        float lo = tree.background(), hi = tree.background();
        for (auto leaf = tree.cbeginLeaf(); leaf; ++leaf) {
            float a = kInf, b = -kInf;
            for (auto v = leaf->cbeginValueAll(); v; ++v) {
                a = std::min(a, *v);
                b = std::max(b, *v);
            }
            ranges_.emplace(leafKey(leaf->origin()), std::make_pair(a, b));
            lo = std::min(lo, a);
            hi = std::max(hi, b);
        }
        for (auto t = tree.cbeginValueAll(); t; ++t)
            if (!t.isVoxelValue()) {
                lo = std::min(lo, *t);
                hi = std::max(hi, *t);
            }
        all_ = toField(lo, hi);
        // Outside the active bounding box the grid holds its background value.
        const openvdb::CoordBBox active = grid_->evalActiveVoxelBoundingBox();
        if (sign_ * (tree.background() - iso_) <= 0.f) {
            box_ = Box3::everything();
        } else if (!active.empty()) {
            const openvdb::BBoxd w = grid_->transform().indexToWorld(
                openvdb::BBoxd(active.min().asVec3d() - 1.0, active.max().asVec3d() + 1.0));
            box_ = {glm::vec3(glm::dvec3(w.min().x(), w.min().y(), w.min().z())),
                    glm::vec3(glm::dvec3(w.max().x(), w.max().y(), w.max().z()))};
        }
        levelSet_ = grid_->getGridClass() == openvdb::GRID_LEVEL_SET && insideBelow;
    }

    float value(const glm::vec3& p) const override {
        const openvdb::Vec3d ijk = grid_->transform().worldToIndex(openvdb::Vec3d(p.x, p.y, p.z));
        auto& acc = accessors_.local();
        return sign_ * (openvdb::tools::BoxSampler::sample(acc, ijk) - iso_);
    }
    Interval bound(const Box3& b) const override {
        if (!b.isBounded()) return all_;
        // The index box covering b (all eight corners: the transform may rotate), plus the
        // neighbours that trilinear interpolation reads.
        openvdb::BBoxd ib;
        for (int k = 0; k < 8; ++k) {
            const openvdb::Vec3d w(k & 1 ? b.max.x : b.min.x, k & 2 ? b.max.y : b.min.y, k & 4 ? b.max.z : b.min.z);
            ib.expand(grid_->transform().worldToIndex(w));
        }
        const openvdb::Coord lo = openvdb::Coord::floor(ib.min()) - openvdb::Coord(1),
                             hi = openvdb::Coord::floor(ib.max()) + openvdb::Coord(1);
        const openvdb::Coord l0(lo.x() & ~7, lo.y() & ~7, lo.z() & ~7), l1(hi.x() & ~7, hi.y() & ~7, hi.z() & ~7);
        const double leaves =
            double((l1.x() - l0.x()) / 8 + 1) * ((l1.y() - l0.y()) / 8 + 1) * ((l1.z() - l0.z()) / 8 + 1);
        if (leaves > 4096) return all_;
        float a = kInf, c = -kInf;
        const auto& tree = grid_->tree();
        for (int x = l0.x(); x <= l1.x(); x += 8)
            for (int y = l0.y(); y <= l1.y(); y += 8)
                for (int z = l0.z(); z <= l1.z(); z += 8) {
                    const openvdb::Coord o(x, y, z);
                    if (auto it = ranges_.find(leafKey(o)); it != ranges_.end()) {
                        a = std::min(a, it->second.first);
                        c = std::max(c, it->second.second);
                    } else {
                        const float v = tree.getValue(o);  // a tile or the background: constant over the leaf
                        a = std::min(a, v);
                        c = std::max(c, v);
                    }
                }
        return toField(a, c);
    }
    Box3 bounds() const override { return box_; }
    bool isDistance() const override { return levelSet_; }
    std::string describe() const override { return what_; }

private:
    using Accessor = openvdb::tree::ValueAccessor<const openvdb::FloatTree, false>;
    Interval toField(float lo, float hi) const {
        return sign_ > 0 ? Interval{lo - iso_, hi - iso_} : Interval{iso_ - hi, iso_ - lo};
    }

    openvdb::FloatGrid::ConstPtr grid_;
    float iso_, sign_;
    std::string what_;
    std::unordered_map<std::uint64_t, std::pair<float, float>> ranges_;
    Interval all_;
    Box3 box_;
    bool levelSet_ = false;
    mutable tbb::enumerable_thread_specific<Accessor> accessors_;
};

}  // namespace

implicit::FieldPtr makeGridField(const std::filesystem::path& path, float iso, const std::optional<std::string>& name) {
    openvdb::FloatGrid::Ptr grid = readFloatGrid(path, name);
    const bool below = insideIsBelow(*grid, InsideSide::Auto);
    char isoText[32];
    std::snprintf(isoText, sizeof isoText, "%g", iso);
    return std::make_shared<GridField>(grid, iso, below,
                                       "volume(\"" + path.filename().string() + "\", iso=" + isoText + ")");
}

}  // namespace isoforge::volume
