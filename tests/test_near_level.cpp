// Grids near one iso-level built while a volume file streams past (volume/near_level.h): the very grid
// toGridNearLevel makes of the volume in memory, over the whole width or an x range; and meshing a file
// in slabs from such grids, in one pass or several, gives the whole volume's mesh byte for byte.
#include <gtest/gtest.h>

#include <cstring>

#include <tbb/global_control.h>

#include "core/error.h"
#include "test_util.h"
#include "volume/bricked.h"
#include "volume/dense_grid.h"
#include "volume/marching_cubes.h"
#include "volume/near_level.h"
#include "volume/readers.h"
#include "volume/voxel_source.h"

using namespace isoforge;
namespace fs = std::filesystem;

namespace {

using Tree = openvdb::FloatGrid::TreeType;

/// Every leaf, tile and background value of `got` is `expected`'s, for the blocks with x in [x0, x1).
void expectSameBlocks(const openvdb::FloatGrid& expected, const openvdb::FloatGrid& got, int x0, int x1) {
    EXPECT_EQ(expected.background(), got.background());
    EXPECT_EQ(expected.getGridClass(), got.getGridClass());
    EXPECT_EQ(expected.metaValue<std::string>("isoforge_inside"), got.metaValue<std::string>("isoforge_inside"));
    std::size_t leaves = 0, tiles = 0;
    for (auto leaf = expected.tree().cbeginLeaf(); leaf; ++leaf) {
        if (leaf->origin().x() < x0 || leaf->origin().x() >= x1) continue;
        ++leaves;
        const Tree::LeafNodeType* other = got.tree().probeConstLeaf(leaf->origin());
        ASSERT_TRUE(other) << "no leaf at " << leaf->origin();
        EXPECT_EQ(std::memcmp(leaf->buffer().data(), other->buffer().data(), sizeof(float) * 512), 0)
            << "leaf at " << leaf->origin();
        EXPECT_TRUE(leaf->getValueMask() == other->getValueMask()) << "leaf at " << leaf->origin();
    }
    auto tile = expected.tree().cbeginValueOn();
    tile.setMaxDepth(Tree::ValueOnCIter::LEAF_DEPTH - 1);
    for (; tile; ++tile) {
        const openvdb::Coord o = tile.getCoord();
        if (o.x() < x0 || o.x() >= x1) continue;
        ++tiles;
        EXPECT_EQ(got.tree().getValue(o), *tile);
        EXPECT_TRUE(got.tree().isValueOn(o));
        EXPECT_FALSE(got.tree().probeConstLeaf(o));
    }
    EXPECT_EQ(got.tree().leafCount(), leaves);
    EXPECT_EQ(got.tree().activeTileCount(), tiles);
    EXPECT_GT(leaves, 10u);
}

}  // namespace

TEST(NearLevel, AStreamedGridIsTheGridOfTheVolumeInMemory) {
    // Real CT (a NRRD series of 93 files) at skin and bone, inside above and below, and the frog's tissue
    // labels (MetaImage): the same leaves, tiles and background as toGridNearLevel on the whole volume,
    // over the whole width and over one slab's x range with its halo.
    const fs::path vols = test::sharedData() / "volumes";
    for (const auto& [path, level] :
         std::vector<std::pair<fs::path, float>>{{vols / "headsq-ct-nrrd/quarter.nhdr", 500.f},
                                                 {vols / "headsq-ct-nrrd/quarter.nhdr", 1150.f},
                                                 {vols / "frog-tissue-labels/frogtissue.mhd", 3.5f}}) {
        const volume::DenseVolume v = volume::readVolume(path);
        const std::optional<volume::VoxelSource> source = volume::voxelSource(path);
        ASSERT_TRUE(source);
        const volume::VolumeView view{v.values.data(), v.dims, v.indexToWorld, v.format};
        for (const bool above : {true, false}) {
            SCOPED_TRACE(path.string() + " at " + std::to_string(level) + (above ? " above" : " below"));
            std::pair<float, float> range;
            const openvdb::FloatGrid::Ptr expected = volume::toGridNearLevel(view, level, above, &range);
            volume::NearLevelOptions o;
            o.level = level;
            o.insideAbove = above;
            o.exteriorOutside = true;
            const volume::NearLevelGrid whole = volume::nearLevelGrid(*source, o);
            EXPECT_EQ(whole.range, range);
            EXPECT_EQ(whole.range, v.range());
            expectSameBlocks(*expected, *whole.grid, -1 << 30, 1 << 30);
            // With toGrid's exterior (the minimum) instead: the grid the command line meshes.
            {
                volume::NearLevelOptions m = o;
                m.exteriorOutside = false;
                const volume::NearLevelGrid streamed = volume::nearLevelGrid(*source, m);
                const auto inMemory = volume::toGridNearLevel(view, level, above, nullptr, false);
                expectSameBlocks(*inMemory, *streamed.grid, -1 << 30, 1 << 30);
                EXPECT_EQ(streamed.grid->background(), range.first);  // toGrid's, either side
            }
            // Thirteen slices, the one being read, a layer of cell columns and a ring of eight layers of cells
            // (cells of four voxels: 2 * blocks + 1 along an axis; a range is 8 bytes).
            const auto nx = std::uint64_t(v.dims[0]), ny = std::uint64_t(v.dims[1]);
            const std::uint64_t cx = 2 * ((nx + 7) / 8) + 1, cy = 2 * ((ny + 7) / 8) + 1;
            EXPECT_EQ(whole.windowBytes, 13 * nx * ny * 4 +
                                             nx * ny * volume::detail::typeSize(source->header.storedType) +
                                             cy * nx * 8 + 8 * cy * cx * 8);
            if (v.dims[0] > 256) {
                o.xBegin = 120;
                o.xEnd = 272;
                const volume::NearLevelGrid part = volume::nearLevelGrid(*source, o);
                EXPECT_EQ(part.xEnd, 272);
                EXPECT_EQ(part.range, range);
                expectSameBlocks(*expected, *part.grid, 120, 272);
                EXPECT_LT(part.gridBytes, whole.gridBytes);
                // A budget of two slabs' grid: the pass drops the rest as it finds it does not fit.
                o.xBegin = -8;
                o.xEnd = 272;
                const std::uint64_t two = volume::nearLevelGrid(*source, o).gridBytes;
                o.xEnd = 1 << 20;
                o.narrowerEnds = {144, 272, 400};
                o.budgetBytes = two;
                const volume::NearLevelGrid cut = volume::nearLevelGrid(*source, o);
                EXPECT_EQ(cut.xEnd, 272);
                EXPECT_EQ(cut.range, range);
                expectSameBlocks(*expected, *cut.grid, -8, 272);
            }
        }
    }
}

TEST(NearLevel, AStreamedGridIsTheSameOnAnyThreadCount) {
    // The CT series at bone on 1, 2 and 3 threads: the same leaves, tiles, background and range, and the
    // whole volume's range (found in parallel chunks) is the same floats.
    const fs::path path = test::sharedData() / "volumes/headsq-ct-nrrd/quarter.nhdr";
    const std::optional<volume::VoxelSource> source = volume::voxelSource(path);
    ASSERT_TRUE(source);
    volume::NearLevelOptions o;
    o.level = 1150.f;
    openvdb::FloatGrid::Ptr reference;
    std::pair<float, float> range;
    for (int threads : {1, 2, 3}) {
        SCOPED_TRACE(std::to_string(threads) + " threads");
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
        const volume::NearLevelGrid g = volume::nearLevelGrid(*source, o);
        if (!reference) {
            reference = g.grid;
            range = g.range;
            continue;
        }
        EXPECT_EQ(std::memcmp(&g.range, &range, sizeof range), 0);
        expectSameBlocks(*reference, *g.grid, -1 << 30, 1 << 30);
    }
    std::vector<float> many(std::size_t(3) << 20);
    for (std::size_t i = 0; i < many.size(); ++i) many[i] = float((i * 2654435761u) % 1000003) - 5e5f;
    many[1 << 19] = -0.f;
    float lo = many[0], hi = many[0];
    volume::detail::extendRange(many.data(), many.size(), lo, hi);
    for (int threads : {1, 3}) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
        float a = many[0], b = many[0];
        volume::detail::extendRange(many.data(), many.size(), a, b);
        EXPECT_EQ(std::memcmp(&a, &lo, 4), 0);
        EXPECT_EQ(std::memcmp(&b, &hi, 4), 0);
    }
}

TEST(SlabsOfVolumes, AFileStreamedInPassesIsTheWholeGridsMesh) {
    // The frog's 500 x 470 x 136 tissue labels in four slabs: read once (the grid near the level of every
    // slab fits), or in several passes when a budget of the largest slab's grid makes the passes drop
    // their last slabs; inside above and below. The mesh is the whole volume's grid's, byte for byte.
    const fs::path path = test::sharedData() / "volumes/frog-tissue-labels/frogtissue.mhd";
    const volume::DenseVolume v = volume::readVolume(path);
    const std::optional<volume::VoxelSource> source = volume::voxelSource(path);
    ASSERT_TRUE(source);
    const openvdb::FloatGrid::Ptr whole = volume::toGrid(v);
    // The budget: the largest grid of one slab (with its halo), less than the four slabs' together.
    std::uint64_t budget = 0;
    for (std::int64_t x = 0; x < v.dims[0]; x += 128) {
        volume::NearLevelOptions o;
        o.level = 3.5f;
        o.xBegin = x - 8;
        o.xEnd = x + 128 + 16;
        budget = std::max(budget, volume::nearLevelGrid(*source, o).gridBytes);
    }
    for (const auto inside : {volume::InsideSide::Auto, volume::InsideSide::Below})
        for (const bool normals : {false, true}) {
            volume::MeshingOptions mo;
            mo.isovalue = 3.5f;
            mo.inside = inside;
            mo.normals = normals;
            const mesh::TriMesh expected = volume::extractIsosurface(*whole, mo);
            ASSERT_GT(expected.triangles.size(), 10000u);
            std::uint64_t oneGrid = 0;
            for (const bool fits : {true, false}) {
                SCOPED_TRACE(std::string(inside == volume::InsideSide::Below ? "below, " : "above, ") +
                             (normals ? "normals, " : "") + (fits ? "one pass" : "a slab's budget"));
                volume::SlabOptions so;
                so.isovalue = mo.isovalue;
                so.inside = inside;
                so.normals = normals;
                volume::SlabStats st;
                volume::SourceSlabStats ss;
                mesh::TriMesh pieces;
                volume::meshVolumeSourceBySlabs(
                    *source, so, fits ? ~std::uint64_t{0} : budget,
                    [&](const volume::SlabPiece& p) {
                        EXPECT_EQ(p.vertexBase, pieces.positions.size());
                        pieces.positions.insert(pieces.positions.end(), p.mesh.positions.begin(),
                                                p.mesh.positions.begin() + std::ptrdiff_t(p.owned));
                        if (normals)
                            pieces.normals.insert(pieces.normals.end(), p.mesh.normals.begin(),
                                                  p.mesh.normals.begin() + std::ptrdiff_t(p.owned));
                        pieces.triangles.insert(pieces.triangles.end(), p.mesh.triangles.begin(),
                                                p.mesh.triangles.end());
                    },
                    &st, &ss);
                EXPECT_EQ(st.slabs, 4u);
                EXPECT_EQ(ss.range, v.range());
                if (fits) {
                    EXPECT_EQ(ss.passes, 1u);
                    oneGrid = ss.gridBytes;
                } else {
                    EXPECT_GE(ss.passes, 2u);
                    EXPECT_LE(ss.gridBytes, budget);
                    EXPECT_LT(budget, oneGrid);
                }
                // Thirteen slices (twelve, and the next one read meanwhile) and the cells, not the volume.
                EXPECT_EQ(ss.windowBytes,
                          std::uint64_t(500) * 470 * (13 * 4 + 1) + std::uint64_t(119) * 500 * 8 + 8 * 119 * 127 * 8);
                EXPECT_TRUE(pieces.positions == expected.positions);
                EXPECT_TRUE(pieces.normals == expected.normals);
                EXPECT_TRUE(pieces.triangles == expected.triangles);
            }
        }
    // A budget too small for one slab's grid is refused.
    try {
        volume::SlabOptions so;
        so.isovalue = 3.5f;
        volume::meshVolumeSourceBySlabs(*source, so, 1, [](const volume::SlabPiece&) {});
        ADD_FAILURE() << "a budget of one byte was taken";
    } catch (const ResourceError& e) {
        EXPECT_NE(std::string(e.what()).find("outgrew"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("frogtissue"), std::string::npos) << e.what();
    }
}
