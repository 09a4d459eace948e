#include "volume/surface.h"

#include <array>
#include <stdexcept>
#include <vector>

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <glm/common.hpp>
#include <glm/mat3x3.hpp>
#include <glm/matrix.hpp>
#include <glm/vector_relational.hpp>

namespace isoforge::volume {

namespace {

glm::vec3 toWorld(const openvdb::math::Transform& xform, const glm::vec3& p) {
    const openvdb::Vec3d w = xform.indexToWorld(openvdb::Vec3d(p.x, p.y, p.z));
    return glm::vec3(float(w.x()), float(w.y()), float(w.z()));
}

/// The field pruned to boxes that come in mesh order, block by block, as sharpen() and the colours ask
/// for them: each thread keeps the field pruned to the block of 32 voxels holding a box's centre, and
/// that pruned to the block of 8 voxels (each with a quarter of its size to spare on every side), and
/// prunes the smallest that holds the box further for it. (By the centre, not the lowest corner: a box
/// starting near a block's far end spilled out of it, and 4,000 of example024's boxes pruned the
/// whole tree.) So the whole tree is bounded once per block rather
/// than once per box (a Menger sponge's 220 cubes took half of its --sharp time, mostly in the
/// probes of single feature cells). Pruning keeps the values there (implicit/field.h), so which
/// thread pruned what changes no output.
class PrunedField {
public:
    PrunedField(implicit::FieldPtr field, const openvdb::math::Transform& xform) : field_(std::move(field)) {
        const float voxel = float(xform.voxelSize()[0]);
        block_ = {32.f * voxel, 8.f * voxel};
    }

    implicit::FieldPtr operator()(const implicit::Box3& box) const {
        Slots& slots = slots_.local();
        implicit::FieldPtr f = field_;
        for (std::size_t level = 0; level < block_.size(); ++level) {
            const float size = block_[level], margin = 0.25f * size;
            if (!(size > 0)) break;
            const glm::vec3 cell = glm::floor(box.centre() / size);
            const implicit::Box3 region{cell * size - glm::vec3(margin), (cell + 1.f) * size + glm::vec3(margin)};
            if (!glm::all(glm::greaterThanEqual(box.min, region.min)) ||
                !glm::all(glm::lessThanEqual(box.max, region.max)))
                return implicit::simplified(f, box);
            // Direct-mapped by block: sharpen's vertex batches and crease candidates come in mesh order,
            // so a thread revisits the blocks of a slab of the grid, not only its last one.
            const glm::uvec3 c = glm::uvec3(glm::ivec3(cell));  // unsigned: the hash wraps instead of overflowing
            Slot& slot = slots[level][std::size_t((c.x * 73856093u) ^ (c.y * 19349663u) ^ (c.z * 83492791u)) % kWays];
            if (!slot.field || slot.cell != cell || slot.parent != f) {
                slot.cell = cell;
                slot.parent = f;
                slot.field = implicit::simplified(f, region);
            }
            f = slot.field;
        }
        // Within the finest block: its field as kept. Pruning again to a box of a few voxels (a cell's
        // probe, a batch of vertices) dropped little and cost more than the evaluations it saved.
        return f;
    }

private:
    struct Slot {
        glm::vec3 cell{0.f};
        implicit::FieldPtr parent, field;  // the field pruned to the cell's region, and what it was pruned from
    };
    static constexpr std::size_t kWays = 128;
    using Slots = std::array<std::array<Slot, kWays>, 2>;
    implicit::FieldPtr field_;
    std::array<float, 2> block_{};
    mutable tbb::enumerable_thread_specific<Slots> slots_;
};

/// Colours of the field's CSG colour nodes, per vertex (white where none is given); none when no node gives one.
/// Vertices go 64 at a time in mesh order, each batch asking the field pruned to its box.
void colourByMaterial(mesh::TriMesh& m, const implicit::FieldPtr& field, const openvdb::math::Transform& xform) {
    if (m.empty() || !field->hasMaterial()) return;
    m.colors.resize(m.positions.size());
    const PrunedField pruned(field, xform);
    constexpr std::size_t kBatch = 64;
    tbb::parallel_for(std::size_t{0}, (m.positions.size() + kBatch - 1) / kBatch, [&](std::size_t batch) {
        const std::size_t begin = batch * kBatch, end = std::min(m.positions.size(), begin + kBatch);
        implicit::Box3 box;
        for (std::size_t i = begin; i < end; ++i) {
            box.min = glm::min(box.min, m.positions[i]);
            box.max = glm::max(box.max, m.positions[i]);
        }
        const implicit::FieldPtr f = pruned(box);
        for (std::size_t i = begin; i < end; ++i) {
            const glm::vec4 col = f->colorAt(m.positions[i]);
            m.colors[i] = col.a > 0 ? glm::vec3(col) : glm::vec3(1.f);
        }
    });
    bool any = false;
    for (const auto& col : m.colors) any = any || col != glm::vec3(1.f);
    if (!any) m.colors.clear();
}

}  // namespace

mesh::TriMesh meshSurface(const openvdb::FloatGrid& grid, const implicit::FieldPtr& field,
                          const SurfaceOptions& options, SurfaceStats* stats) {
    if (options.maxError > 0 && options.indexSpace)
        throw std::invalid_argument("the simplification bound is in world units: not with index-space positions");
    SurfaceStats local;
    SurfaceStats& st = stats ? *stats : local;
    MeshingOptions opt;
    opt.isovalue = options.isovalue;
    opt.inside = options.inside;
    opt.normals = options.normals;
    opt.worldSpace = !options.indexSpace && !options.sharp;
    opt.progress = options.progress;
    mesh::TriMesh m = extractIsosurface(grid, opt, &st.meshing);
    if (options.sharp) {
        const openvdb::math::Transform& xform = grid.transform();
        if (field) {
            // Each batch evaluates the field pruned to its box (CSG children that cannot reach it dropped).
            const PrunedField prunedTo(field, xform);
            // Index to world is affine: the transpose of its linear part takes world gradients to index ones.
            const glm::vec3 origin = toWorld(xform, glm::vec3(0.f));
            const glm::mat3 toIndex = glm::transpose(glm::mat3(toWorld(xform, glm::vec3(1, 0, 0)) - origin,
                                                               toWorld(xform, glm::vec3(0, 1, 0)) - origin,
                                                               toWorld(xform, glm::vec3(0, 0, 1)) - origin));
            auto pruned = [&prunedTo, &xform, &toIndex](const glm::vec3& lo, const glm::vec3& hi) -> IndexValues {
                implicit::Box3 box;
                for (int c = 0; c < 8; ++c) {
                    const glm::vec3 w =
                        toWorld(xform, glm::vec3(c & 1 ? hi.x : lo.x, c & 2 ? hi.y : lo.y, c & 4 ? hi.z : lo.z));
                    box.min = glm::min(box.min, w);
                    box.max = glm::max(box.max, w);
                }
                const implicit::FieldPtr f = prunedTo(box);
                auto values = [f, &xform](std::span<const glm::vec3> p, std::span<float> out) {
                    std::vector<glm::vec3> world(p.size());
                    for (std::size_t i = 0; i < p.size(); ++i) world[i] = toWorld(xform, p[i]);
                    f->values(world, out);
                };
                // The field's own gradient (the active branch of min and max), per voxel: A^T g.
                auto gradients = [f, &xform, &toIndex](std::span<const glm::vec3> p, std::span<glm::vec3> out) {
                    for (std::size_t i = 0; i < p.size(); ++i) out[i] = toIndex * f->gradient(toWorld(xform, p[i]));
                };
                return IndexValues(values, gradients);
            };
            // The grid holds the field's own values at its points (iso-value 0, inside below): the edge ends.
            const bool fieldValues = options.isovalue == 0.f && insideIsBelow(grid, options.inside);
            sharpen(m, pruned, &st.sharpen, fieldValues ? &grid : nullptr);
        } else {
            sharpenWithGrid(m, grid, options.isovalue, insideIsBelow(grid, options.inside), &st.sharpen);
        }
        if (!options.indexSpace)
            tbb::parallel_for(std::size_t{0}, m.positions.size(),
                              [&](std::size_t i) { m.positions[i] = toWorld(xform, m.positions[i]); });
    }
    st.fullTriangles = m.triangleCount();
    if (options.maxError > 0) st.simplify = mesh::simplify(m, options.maxError);
    if (field && !options.indexSpace) colourByMaterial(m, field, grid.transform());
    return m;
}

}  // namespace isoforge::volume
