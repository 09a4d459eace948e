// Out-of-core meshing in slabs (volume/bricked.h) and the streaming writer (mesh/stream_writer.h):
// the pieces make the same mesh, and the same file bytes, as the in-memory path.
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "core/error.h"
#include "csg/scene.h"
#include "implicit/blobby.h"
#include "implicit/shape_spec.h"
#include "implicit/tape.h"
#include "mesh/io.h"
#include "mesh/stream_writer.h"
#include "test_util.h"
#include "volume/bricked.h"
#include "volume/marching_cubes.h"
#include "volume/sample.h"
#include "volume/surface.h"
#include "volume/vdb_io.h"

using namespace isoforge;

namespace {
struct Init {
    Init() { volume::initializeOpenVdb(); }
} init;

/// The in-memory path: the whole grid, then the whole mesh, with the scene's colours.
mesh::TriMesh wholeMesh(const implicit::FieldPtr& f, const volume::SampleOptions& so, bool normals) {
    volume::SurfaceOptions opt;
    opt.normals = normals;
    return volume::meshSurface(*volume::sample(f, so), f, opt);
}

/// The slabs' pieces concatenated.
mesh::TriMesh slabMesh(const implicit::FieldPtr& f, const volume::SampleOptions& so, bool normals, int width,
                       volume::SlabStats* stats = nullptr) {
    volume::SlabOptions o;
    o.sample = so;
    o.normals = normals;
    o.colors = true;
    o.slabWidth = width;
    mesh::TriMesh all;
    bool anyColor = false;
    volume::meshBySlabs(
        f, o,
        [&](const volume::SlabPiece& p) {
            EXPECT_EQ(p.vertexBase, all.positions.size());
            all.positions.insert(all.positions.end(), p.mesh.positions.begin(), p.mesh.positions.begin() + p.owned);
            if (normals)
                all.normals.insert(all.normals.end(), p.mesh.normals.begin(), p.mesh.normals.begin() + p.owned);
            all.colors.insert(all.colors.end(), p.mesh.colors.begin(), p.mesh.colors.end());
            for (const auto& c : p.mesh.colors) anyColor = anyColor || c != glm::vec3(1.f);
            all.triangles.insert(all.triangles.end(), p.mesh.triangles.begin(), p.mesh.triangles.end());
            // Ghost vertices are the next slab's: every index stays below the slab's vertices and ghosts.
            for (const glm::uvec3& t : p.mesh.triangles)
                for (int k = 0; k < 3; ++k) {
                    EXPECT_GE(t[k], p.vertexBase);
                    EXPECT_LT(t[k] - p.vertexBase, p.mesh.positions.size());
                }
        },
        stats);
    if (!anyColor || all.triangles.empty()) all.colors.clear();  // as the scene mesher keeps them
    return all;
}

void expectSameMesh(const mesh::TriMesh& a, const mesh::TriMesh& b, const std::string& what) {
    ASSERT_EQ(a.positions.size(), b.positions.size()) << what;
    ASSERT_EQ(a.triangles.size(), b.triangles.size()) << what;
    EXPECT_TRUE(a.positions == b.positions) << what;
    EXPECT_TRUE(a.triangles == b.triangles) << what;
    EXPECT_TRUE(a.normals == b.normals) << what;
    EXPECT_TRUE(a.colors == b.colors) << what;
}

implicit::FieldPtr scene(const std::string& text) {
    return csg::parseScene(text, "slabs.isf").root;
}

struct Case {
    std::string what;
    implicit::FieldPtr field;
    float voxel;
};

std::vector<Case> cases() {
    const float v = 1.f / 128;  // 1 unit = 128 voxels: faces at integers lie on slab planes
    return {
        {"sphere", implicit::parseShape("sphere(r=1.3)"), 0.01f},
        // Faces exactly on slab planes (x = -128, 128 voxels): values equal to the iso on the seams.
        {"box on the seams", implicit::parseShape("box(x=2, y=1.4, z=1)"), v},
        // A sphere whose extreme points touch the planes x = +-128 voxels: tangent to the seams.
        {"sphere tangent to the seams", implicit::parseShape("sphere(r=1)"), v},
        {"torus", implicit::parseShape("torus(R=1, r=0.3)"), 0.01f},
        // Far apart: the slabs between them hold nothing.
        {"two spheres, empty slabs between",
         scene("sphere(0.5); translate([6, 0, 0]) sphere(0.5); translate([-5, 1, 0]) cube(0.4);"), 0.01f},
        // Colours from CSG colour nodes, on both sides of seams.
        {"coloured CSG",
         scene("color(\"red\") difference() { cube(2, center = true); sphere(1.2); } "
               "translate([1.5, 0, 0]) color([0, 0, 1]) sphere(0.6);"),
         0.013f},
        // Not a distance: values, not a narrow band; inside regions as tiles.
        {"algebraic surface",
         implicit::makeTapeField(implicit::parseExpression("x^4 + y^4 + z^4 - 1"),
                                 implicit::Box3{glm::vec3(-2.f), glm::vec3(2.f)}, "quartic"),
         0.012f},
    };
}

}  // namespace

TEST(Slabs, PiecesMakeTheInMemoryMesh) {
    // Slabs of 128 and 256 voxels; normals (gradients across the seams) with the narrower.
    for (const Case& c : cases())
        for (const auto& [width, normals] : {std::pair{128, false}, std::pair{128, true}, std::pair{256, false}}) {
            volume::SampleOptions so;
            so.voxelSize = c.voxel;
            if (!c.field->isDistance()) so.clip = implicit::Box3{glm::vec3(-2.f), glm::vec3(2.f)};
            const mesh::TriMesh whole = wholeMesh(c.field, so, normals);
            volume::SlabStats st;
            const mesh::TriMesh pieces = slabMesh(c.field, so, normals, width, &st);
            const std::string what = c.what + ", slabs of " + std::to_string(width) + (normals ? ", normals" : "");
            EXPECT_GT(st.slabs, 1u) << what;
            expectSameMesh(whole, pieces, what);
            if (width == 128 && !normals) test::expectClosedSurface(pieces, what);
        }
}

TEST(Slabs, ColoursAreKept) {
    volume::SampleOptions so;
    so.voxelSize = 0.013f;
    const mesh::TriMesh m = slabMesh(cases()[5].field, so, false, 128);
    ASSERT_FALSE(m.colors.empty());
    bool red = false, blue = false;
    for (const auto& c : m.colors) {
        red = red || c == glm::vec3(1, 0, 0);
        blue = blue || c == glm::vec3(0, 0, 1);
    }
    EXPECT_TRUE(red && blue);
}

TEST(Slabs, EverySlabWorksOnlyOnItsOwnBlocksAndAHalo) {
    // Work stays proportional to the surface: the slabs together sample the whole grid's leaves and
    // mesh its blocks, plus three block columns of halo per seam. A sphere of radius 330 voxels has
    // 128^3 inside tiles, which a slab must cut at its sides (no surface made up beyond them).
    volume::SampleOptions so;
    so.voxelSize = 0.004f;
    const auto field = implicit::parseShape("sphere(r=1.32)");
    volume::SampleStats whole;
    const auto grid = volume::sample(field, so, &whole);
    ASSERT_GT(whole.tiles, 0u);
    volume::MeshingStats ms;
    const mesh::TriMesh m = volume::extractIsosurface(*grid, {}, &ms);
    volume::SlabStats st;
    volume::SlabOptions o;
    o.sample = so;
    std::size_t triangles = 0;
    volume::meshBySlabs(
        field, o, [&](const volume::SlabPiece& p) { triangles += p.mesh.triangles.size(); }, &st);
    EXPECT_EQ(triangles, m.triangles.size());
    EXPECT_GE(st.slabs, 5u);
    EXPECT_GE(st.leaves, whole.leaves);
    EXPECT_LT(double(st.leaves), 1.5 * double(whole.leaves));
    EXPECT_LT(double(st.blocks), 1.5 * double(ms.blocks));
}

TEST(Slabs, ASlabsGridIsBackgroundBeyondIt) {
    // The inside of this sphere has 128^3 tiles; a slab that cuts one keeps only its 8^3 tiles within.
    volume::SampleOptions so;
    so.voxelSize = 0.004f;
    so.xBegin = -8;
    so.xEnd = 144;
    const auto grid = volume::sample(implicit::parseShape("sphere(r=1.32)"), so);
    const float background = grid->background();
    std::size_t tiles = 0, leaves = 0;
    auto it = grid->tree().cbeginValueAll();
    it.setMaxDepth(openvdb::FloatTree::ValueAllCIter::LEAF_DEPTH - 1);
    for (; it; ++it) {
        if (*it == background) continue;
        openvdb::CoordBBox box;
        it.getBoundingBox(box);
        ++tiles;
        EXPECT_GE(box.min().x(), so.xBegin) << box;
        EXPECT_LT(box.max().x(), so.xEnd) << box;
    }
    for (auto leaf = grid->tree().cbeginLeaf(); leaf; ++leaf) {
        ++leaves;
        EXPECT_GE(leaf->origin().x(), so.xBegin);
        EXPECT_LT(leaf->origin().x(), so.xEnd);
    }
    EXPECT_GT(tiles, 0u);
    EXPECT_GT(leaves, 0u);
}

TEST(Slabs, ASlabThatOutgrowsTheLimitIsRefused) {
    volume::SlabOptions o;
    o.sample.voxelSize = 0.002f;
    o.sample.memoryLimit = 1 << 20;  // 1 MiB: a slab of this sphere has far more leaves
    EXPECT_THROW(volume::meshBySlabs(implicit::parseShape("sphere(r=1)"), o, [](const volume::SlabPiece&) {}),
                 ResourceError);
}

TEST(Slabs, ExtractSlabRefusesRangesOffTheBlocks) {
    auto grid = volume::sample(implicit::parseShape("sphere(r=1)"), {.voxelSize = 0.1f});
    mesh::TriMesh out;
    EXPECT_THROW(volume::extractSlab(*grid, {}, {.x0 = 3, .x1 = 16}, out), std::invalid_argument);
    EXPECT_THROW(volume::extractSlab(*grid, {}, {.x0 = 16, .x1 = 16}, out), std::invalid_argument);
}

namespace {
std::string fileBytes(const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}
}  // namespace

TEST(StreamWriter, PiecesWriteTheSameBytesAsTheWholeMesh) {
    const auto dir = test::scratchDir("stream-writer");
    volume::SampleOptions so;
    so.voxelSize = 0.02f;
    mesh::TriMesh m = wholeMesh(cases()[5].field, so, true);
    ASSERT_FALSE(m.colors.empty());
    for (const std::string ext : {".ply", ".obj", ".stl"})
        for (bool ascii : {false, true})
            for (int variant = 0; variant < 3; ++variant) {  // colours; no colours; colours all white (dropped)
                mesh::TriMesh w = m;
                if (variant == 1) w.colors.clear();
                mesh::TriMesh written = w;
                if (variant == 2) {
                    w.colors.assign(w.positions.size(), glm::vec3(1.f));
                    written.colors.clear();
                }
                const auto whole = dir / ("whole" + ext), pieces = dir / ("pieces" + ext);
                std::filesystem::remove(pieces);
                mesh::writeMesh(whole, written, {ascii});
                mesh::MeshStreamWriter writer(pieces, {.ascii = ascii, .normals = true, .colors = !w.colors.empty()});
                // Triangles before the vertices they use, as slabs hand on ghosts.
                const std::size_t tHalf = w.triangles.size() / 2, vhalf = w.positions.size() / 3;
                const auto pos = [&](std::uint32_t i) -> const glm::vec3& { return w.positions[i]; };
                writer.addTriangles(std::span(w.triangles).first(tHalf), pos);
                writer.addVertices(std::span(w.positions).first(vhalf), std::span(w.normals).first(vhalf),
                                   w.colors.empty() ? std::span<const glm::vec3>()
                                                    : std::span<const glm::vec3>(w.colors).first(vhalf));
                writer.addVertices(std::span(w.positions).subspan(vhalf), std::span(w.normals).subspan(vhalf),
                                   w.colors.empty() ? std::span<const glm::vec3>()
                                                    : std::span<const glm::vec3>(w.colors).subspan(vhalf));
                writer.addTriangles(std::span(w.triangles).subspan(tHalf), pos);
                EXPECT_FALSE(std::filesystem::exists(pieces));  // nothing before commit
                writer.commit();
                EXPECT_EQ(fileBytes(whole), fileBytes(pieces)) << ext << (ascii ? " ascii" : "") << " " << variant;
            }
    // Nothing is left beside the outputs (the scratch files are anonymous).
    std::size_t files = 0;
    for (const auto& e : std::filesystem::directory_iterator(dir)) files += !e.path().filename().string().empty();
    EXPECT_EQ(files, 6u);
    std::filesystem::remove_all(dir);
}

TEST(StreamWriter, NoFileWithoutCommitAndGlbIsRefused) {
    const auto dir = test::scratchDir("stream-writer-abort");
    {
        mesh::MeshStreamWriter w(dir / "a.ply", {});
        const glm::vec3 p[3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
        w.addVertices(p, {}, {});
    }
    EXPECT_TRUE(std::filesystem::is_empty(dir));
    EXPECT_THROW(mesh::MeshStreamWriter(dir / "a.glb", {}), IoError);
    std::filesystem::remove_all(dir);
}

TEST(Slabs, PartitionsAreContiguousBalancedAndCoverEverySlab) {
    // Two spheres at the ends of a long box of empty space: the slabs with surface go to different
    // parts, and no part is left with only empty slabs while another holds both spheres.
    const auto field = csg::parseScene("sphere(1); translate([20, 0, 0]) sphere(1);", "p.isf").root;
    volume::SampleOptions so;
    so.voxelSize = 0.01f;
    const std::size_t slabs = volume::slabOrigins(*field, so, 128).size();
    for (int parts : {1, 2, 3, 4, 7, 40}) {
        const std::vector<std::size_t> begin = volume::partitionSlabs(*field, so, 128, parts);
        ASSERT_EQ(begin.size(), static_cast<std::size_t>(parts) + 1);
        EXPECT_EQ(begin.front(), 0u);
        EXPECT_EQ(begin.back(), slabs);
        for (int p = 0; p < parts; ++p) EXPECT_LE(begin[p], begin[p + 1]);
        EXPECT_EQ(begin, volume::partitionSlabs(*field, so, 128, parts));  // deterministic
    }
    // Two parts: one sphere each (the split lies between them, not at the middle slab count).
    const std::vector<std::size_t> two = volume::partitionSlabs(*field, so, 128, 2);
    const std::vector<std::int64_t> origins = volume::slabOrigins(*field, so, 128);
    const std::int64_t split = origins[two[1]];
    EXPECT_GT(split, 100);         // past the first sphere (x <= 100 voxels)
    EXPECT_LE(split, 2000 - 100);  // before the second (x >= 1900 voxels)
}
