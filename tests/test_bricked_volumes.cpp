// Meshing volumes in slabs (volume/bricked.h): a real CT series and a .vdb grid give, slab by slab,
// the mesh of the whole grid, byte for byte.
#include <gtest/gtest.h>

#include "test_util.h"
#include "volume/bricked.h"
#include "volume/dense_grid.h"
#include "volume/dense_volume.h"
#include "volume/marching_cubes.h"
#include "volume/vdb_io.h"

using namespace isoforge;

namespace {

mesh::TriMesh concatenate(const std::function<void(const std::function<void(const volume::SlabPiece&)>&)>& run) {
    mesh::TriMesh all;
    run([&](const volume::SlabPiece& p) {
        EXPECT_EQ(p.vertexBase, all.positions.size());
        all.positions.insert(all.positions.end(), p.mesh.positions.begin(), p.mesh.positions.begin() + p.owned);
        if (!p.mesh.normals.empty())
            all.normals.insert(all.normals.end(), p.mesh.normals.begin(), p.mesh.normals.begin() + p.owned);
        all.triangles.insert(all.triangles.end(), p.mesh.triangles.begin(), p.mesh.triangles.end());
    });
    return all;
}

void expectSame(const mesh::TriMesh& a, const mesh::TriMesh& b, const std::string& what) {
    ASSERT_EQ(a.positions.size(), b.positions.size()) << what;
    ASSERT_EQ(a.triangles.size(), b.triangles.size()) << what;
    EXPECT_TRUE(a.positions == b.positions) << what;
    EXPECT_TRUE(a.normals == b.normals) << what;
    EXPECT_TRUE(a.triangles == b.triangles) << what;
}

}  // namespace

TEST(SlabsOfVolumes, ACtSeriesInSlabsIsTheWholeGridsMesh) {
    // 512 x 512 x 48 CT (LPS, a real scanner's series): four slabs of 128 columns, bone and skin.
    const volume::DenseVolume v = volume::readVolume(test::sharedData() / "volumes/ct-abdomen-dicom/series");
    const volume::VolumeView view{v.values.data(), v.dims, v.indexToWorld, v.format};
    volume::ToGridOptions go;
    go.background = v.range().first;
    const openvdb::FloatGrid::Ptr whole = volume::toGrid(v);
    for (float iso : {300.f, -500.f})
        for (bool normals : {false, true}) {
            volume::MeshingOptions mo;
            mo.isovalue = iso;
            mo.normals = normals;
            const mesh::TriMesh expected = volume::extractIsosurface(*whole, mo);
            volume::SlabOptions so;
            so.isovalue = iso;
            so.normals = normals;
            volume::SlabStats st;
            const mesh::TriMesh pieces =
                concatenate([&](const auto& sink) { volume::meshVolumeBySlabs(view, go, so, sink, &st); });
            const std::string what = "iso " + std::to_string(iso) + (normals ? ", normals" : "");
            EXPECT_EQ(st.slabs, 4u) << what;
            EXPECT_GT(expected.triangles.size(), 100000u) << what;
            expectSame(expected, pieces, what);
            // A slab's grid and mesh are less than the whole grid and mesh.
            EXPECT_LT(st.maxSlabBytes, whole->memUsage() + expected.triangles.size() * 24) << what;
        }
    EXPECT_THROW(volume::meshVolumeBySlabs(view, {}, {}, [](const volume::SlabPiece&) {}), std::invalid_argument);
}

TEST(SlabsOfVolumes, AGridInMemoryMeshedInSlabsIsItsMesh) {
    const openvdb::FloatGrid::Ptr grid = volume::readFloatGrid(test::sourceDir() / "data/sphere.vdb");
    for (bool normals : {false, true}) {
        volume::MeshingOptions mo;
        mo.normals = normals;
        const mesh::TriMesh expected = volume::extractIsosurface(*grid, mo);
        volume::SlabOptions so;
        so.normals = normals;
        volume::SlabStats st;
        const mesh::TriMesh pieces =
            concatenate([&](const auto& sink) { volume::meshGridBySlabs(*grid, so, sink, &st); });
        EXPECT_GT(st.slabs, 1u);
        expectSame(expected, pieces, normals ? "normals" : "plain");
    }
}
