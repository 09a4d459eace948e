#include <cmath>
#include <fstream>

#include <tiny_gltf.h>
#include <glm/geometric.hpp>

#include <gtest/gtest.h>

#include <csignal>
#include <cstdlib>
#include "core/atomic_file.h"
#include "core/error.h"
#include "mesh/check.h"
#include "mesh/io.h"
#include "test_util.h"

using namespace isoforge;
using namespace isoforge::mesh;

namespace {
TriMesh octahedron() {
    TriMesh m;
    m.positions = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    m.triangles = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
    for (auto p : m.positions) m.normals.push_back(p);
    return m;
}
void spit(const std::filesystem::path& p, const std::string& s) {
    std::ofstream out(p, std::ios::binary);
    out << s;
}
std::string slurp(const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}
std::string errorOf(const std::filesystem::path& p) {
    try {
        readMesh(p);
    } catch (const IoError& e) {
        return e.what();
    }
    return "";
}
}  // namespace

TEST(MeshIo, RoundTripsEveryFormat) {
    const auto dir = test::scratchDir("meshio");
    const TriMesh m = octahedron();
    for (const char* name : {"a.ply", "b.obj", "c.stl"}) {
        writeMesh(dir / name, m);
        TriMesh back = readMesh(dir / name);
        ASSERT_EQ(back.triangles.size(), m.triangles.size()) << name;
        EXPECT_EQ(back.positions.size(), m.positions.size()) << name;
        // STL stores no shared vertices (the reader welds them in order of appearance): compare corners.
        for (std::size_t t = 0; t < m.triangles.size(); ++t)
            for (int k = 0; k < 3; ++k)
                EXPECT_EQ(back.positions[back.triangles[t][k]], m.positions[m.triangles[t][k]]) << name;
        EXPECT_TRUE(check(back).isValidClosedSurface()) << name;
    }
    writeMesh(dir / "d.ply", m, {.ascii = true});
    EXPECT_EQ(slurp(dir / "d.ply").rfind("ply\nformat ascii", 0), 0u);
    TriMesh back = readMesh(dir / "d.ply");
    EXPECT_EQ(back.positions, m.positions);
    EXPECT_EQ(back.normals, m.normals);
    EXPECT_EQ(readMesh(dir / "a.ply").normals, m.normals);
    EXPECT_THROW(writeMesh(dir / "x.xyz", m), IoError);
    std::filesystem::remove_all(dir);
}

TEST(MeshIo, ReadsRealMeshesMadeByOtherTools) {
    const auto dir = test::sharedData() / "meshes";
    if (!std::filesystem::exists(dir)) GTEST_SKIP();
    const auto bunny = check(readMesh(dir / "bunny/bunny.ply"));
    EXPECT_EQ(bunny.vertices, 35947u);
    EXPECT_EQ(bunny.triangles, 69451u);
    EXPECT_GT(bunny.boundaryEdges, 0u);  // the scanned bunny has holes
    EXPECT_FALSE(bunny.isWatertight());

    const auto cow = check(readMesh(dir / "cow/cow.obj"));
    EXPECT_TRUE(cow.isWatertight()) << cow.toString();
    EXPECT_GT(cow.triangles, 3263u);  // quads split into triangles

    const auto vase = check(readMesh(dir / "vase/Vase.stl"));
    EXPECT_EQ(vase.triangles, 10910u);
    EXPECT_TRUE(vase.isWatertight()) << vase.toString();
}

TEST(MeshIo, BadFilesNameTheFileAndThePosition) {
    const auto dir = test::scratchDir("meshbad");
    spit(dir / "garbage.obj", "v 0 0 0\nv 1 0 0\nv 0 1 zero\nf 1 2 3\n");
    EXPECT_NE(errorOf(dir / "garbage.obj").find("garbage.obj:3:"), std::string::npos) << errorOf(dir / "garbage.obj");
    spit(dir / "index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n");
    EXPECT_NE(errorOf(dir / "index.obj").find("index.obj:4:"), std::string::npos);
    spit(dir / "noface.obj", "v 0 0 0\n");
    EXPECT_NE(errorOf(dir / "noface.obj").find("no faces"), std::string::npos);

    writeMesh(dir / "good.ply", octahedron());
    const std::string good = slurp(dir / "good.ply");
    spit(dir / "cut.ply", good.substr(0, good.size() - 7));
    EXPECT_NE(errorOf(dir / "cut.ply").find("truncated"), std::string::npos) << errorOf(dir / "cut.ply");
    spit(dir / "header.ply",
         "ply\nformat binary_little_endian 1.0\nelement vertex 99999999999\nproperty float x\n"
         "property float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n");
    EXPECT_NE(errorOf(dir / "header.ply").find("header.ply:3"), std::string::npos) << errorOf(dir / "header.ply");
    spit(dir / "magic.ply", "plx\n");
    EXPECT_NE(errorOf(dir / "magic.ply").find("magic.ply:1:"), std::string::npos);
    spit(dir / "type.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\nend_header\n");
    EXPECT_NE(errorOf(dir / "type.ply").find("type.ply:4:"), std::string::npos) << errorOf(dir / "type.ply");
    spit(dir / "ascii.ply",
         "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
         "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1\n3 0 1 2\n");
    EXPECT_NE(errorOf(dir / "ascii.ply").find("ascii.ply:"), std::string::npos);
    spit(dir / "badidx.ply",
         "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
         "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 5\n");
    EXPECT_NE(errorOf(dir / "badidx.ply").find("names vertex 5"), std::string::npos) << errorOf(dir / "badidx.ply");
    // CI's fuzz_mesh_readers (UBSan): an index of 3.3e78 was converted to long long for this message, and a
    // list length past 2^64 would have been converted to an integer.
    const std::string header =
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
        "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
        "end_header\n0 0 0\n1 0 0\n0 1 0\n";
    spit(dir / "hugeidx.ply",
         header + "3 0 1 3333333333333333333333333333333333333333333333333333333333333333333333333333331\n");
    EXPECT_NE(errorOf(dir / "hugeidx.ply").find("hugeidx.ply:12: face 0 names vertex 3.3333333333333334e+78, but"),
              std::string::npos)
        << errorOf(dir / "hugeidx.ply");
    spit(dir / "hugelist.ply", header + "1e30 0 1 2\n");
    EXPECT_NE(errorOf(dir / "hugelist.ply").find("list length 1e+30"), std::string::npos)
        << errorOf(dir / "hugelist.ply");

    writeMesh(dir / "good.stl", octahedron());
    const std::string stl = slurp(dir / "good.stl");
    spit(dir / "cut.stl", stl.substr(0, stl.size() - 10));
    EXPECT_NE(errorOf(dir / "cut.stl").find("truncated"), std::string::npos);
    EXPECT_NE(errorOf(dir / "missing.ply").find("cannot open"), std::string::npos);
    EXPECT_NE(errorOf(dir / "x.3ds").find("unknown mesh extension"), std::string::npos);
    std::filesystem::remove_all(dir);
}

TEST(MeshIo, FailedWritesLeaveNoFileAndKeepTheOldOne) {
    const auto dir = test::scratchDir("meshatomic");
    EXPECT_THROW(writeMesh(dir / "missing/dir/a.ply", octahedron()), IoError);
    spit(dir / "keep.ply", "old contents");
    // A directory where the file should go: the rename fails, the temporary file is removed.
    std::filesystem::create_directories(dir / "taken.ply" / "x");
    EXPECT_THROW(writeMesh(dir / "taken.ply", octahedron()), IoError);
    EXPECT_EQ(slurp(dir / "keep.ply"), "old contents");
    int files = 0;
    for (auto& e : std::filesystem::directory_iterator(dir)) files += e.is_regular_file();
    EXPECT_EQ(files, 1);  // only keep.ply: no temporary left behind
    std::filesystem::remove_all(dir);
}

namespace {
volatile std::sig_atomic_t stopped = 0;
int regularFiles(const std::filesystem::path& dir) {
    int n = 0;
    for (auto& e : std::filesystem::directory_iterator(dir)) n += e.is_regular_file();
    return n;
}
}  // namespace

TEST(MeshIo, AWriteStoppedBySignalLeavesNoTemporary) {
    GTEST_FLAG_SET(death_test_style, "threadsafe");               // each child runs this test again from the start
    const char* given = std::getenv("ISOFORGE_TEST_SIGNAL_DIR");  // the parent's directory, in a child
    const auto dir = given ? std::filesystem::path(given) : test::scratchDir("meshsignal");
    if (!given) ::setenv("ISOFORGE_TEST_SIGNAL_DIR", dir.c_str(), 1);
    // Ctrl-C, kill, or mpirun ending a job: the process ends by the signal, its hidden file is gone.
    for (int sig : {SIGTERM, SIGINT, SIGHUP}) {
        EXPECT_EXIT(
            {
                AtomicFile f(dir / "a.ply");
                f.write("partial contents");
                std::raise(sig);
            },
            testing::KilledBySignal(sig), "");
        EXPECT_EQ(regularFiles(dir), 0) << "signal " << sig;
    }
    // A program with its own handler goes on: its handler runs, the file stays until the writer is unwound.
    EXPECT_EXIT(
        {
            std::signal(SIGTERM, [](int) { stopped = 1; });
            bool present = false;
            {
                AtomicFile f(dir / "b.ply");
                f.write("partial contents");
                std::raise(SIGTERM);
                present = std::filesystem::exists(f.temporaryPath());
            }
            std::_Exit(stopped && present ? 3 : 4);
        },
        testing::ExitedWithCode(3), "");
    EXPECT_EQ(regularFiles(dir), 0);
    EXPECT_TRUE(std::filesystem::exists(dir));
    // A committed file stays whatever comes after.
    EXPECT_EXIT(
        {
            AtomicFile f(dir / "c.ply");
            f.write("whole");
            f.commit();
            std::raise(SIGTERM);
        },
        testing::KilledBySignal(SIGTERM), "");
    EXPECT_EQ(slurp(dir / "c.ply"), "whole");
    ::unsetenv("ISOFORGE_TEST_SIGNAL_DIR");
    std::filesystem::remove_all(dir);
}

TEST(MeshIo, ReadsOffAndCoffAndRefusesBadOnes) {
    const auto dir = test::scratchDir("meshoff");
    // The cow written as OFF (quads and triangles as in its OBJ) reads back to the same surface.
    const TriMesh cow = readMesh(test::sharedData() / "meshes/cow/cow.obj");
    std::string off = "OFF\n# the VTK cow\n" + std::to_string(cow.positions.size()) + " " +
                      std::to_string(cow.triangles.size()) + " 0\n";
    for (const auto& p : cow.positions)
        off += std::to_string(p.x) + " " + std::to_string(p.y) + " " + std::to_string(p.z) + "\n";
    for (const auto& t : cow.triangles)
        off += "3 " + std::to_string(t.x) + " " + std::to_string(t.y) + " " + std::to_string(t.z) + "\n";
    spit(dir / "cow.off", off);
    const TriMesh back = readMesh(dir / "cow.off");
    EXPECT_EQ(back.triangles, cow.triangles);
    EXPECT_NEAR(signedVolume(back), signedVolume(cow), 1e-4 * signedVolume(cow));
    // COFF with byte colours, comments and a quad.
    spit(dir / "c.off",
         "COFF\n4 1 0\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n# comment\n1 1 0 0 0 255 255\n0 1 0 "
         "255 255 255 255\n4 0 1 2 3\n");
    const TriMesh c = readMesh(dir / "c.off");
    EXPECT_EQ(c.triangles.size(), 2u);
    ASSERT_EQ(c.colors.size(), 4u);
    EXPECT_FLOAT_EQ(c.colors[1].g, 1.f);
    // Bad ones: position in the message, no crash.
    spit(dir / "bad1.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n");
    EXPECT_NE(errorOf(dir / "bad1.off").find("bad1.off:6:"), std::string::npos) << errorOf(dir / "bad1.off");
    spit(dir / "bad2.off", "OFF\n999999999 1 0\n0 0 0\n");
    EXPECT_NE(errorOf(dir / "bad2.off").find("more than a file of"), std::string::npos) << errorOf(dir / "bad2.off");
    spit(dir / "bad3.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n");
    EXPECT_NE(errorOf(dir / "bad3.off").find("file ends after 2 of 3 vertices"), std::string::npos)
        << errorOf(dir / "bad3.off");
    spit(dir / "bad4.off", "PLY\n");
    EXPECT_NE(errorOf(dir / "bad4.off").find("expected OFF or COFF"), std::string::npos);
}

TEST(MeshIo, WritesGlbThatTinyGltfReadsBack) {
    // The cow, coloured by height, with normals: read back by tinygltf's own loader.
    mesh::TriMesh m = mesh::readMesh(test::sourceDir() / "data/cow.obj");
    const mesh::Bounds b = mesh::bounds(m);
    for (const glm::vec3& p : m.positions) {
        const float t = (p.y - b.min.y) / (b.max.y - b.min.y);
        m.colors.emplace_back(t, 0.5f, 1.0f - t);
        m.normals.push_back(glm::normalize(p - 0.5f * (b.min + b.max) + glm::vec3(1e-3f)));
    }
    const auto dir = test::scratchDir("glb");
    mesh::writeMesh(dir / "cow.glb", m);

    std::ifstream in(dir / "cow.glb", std::ios::binary);
    char magic[4];
    in.read(magic, 4);
    EXPECT_EQ(std::string(magic, 4), "glTF");

    tinygltf::Model model;
    tinygltf::TinyGLTF loader;
    std::string err, warn;
    ASSERT_TRUE(loader.LoadBinaryFromFile(&model, &err, &warn, (dir / "cow.glb").string())) << err;
    EXPECT_TRUE(err.empty()) << err;
    ASSERT_EQ(model.meshes.size(), 1u);
    const tinygltf::Primitive& prim = model.meshes[0].primitives.at(0);
    auto floats = [&](const std::string& attribute) {
        const tinygltf::Accessor& a = model.accessors.at(std::size_t(prim.attributes.at(attribute)));
        const tinygltf::BufferView& v = model.bufferViews.at(std::size_t(a.bufferView));
        EXPECT_EQ(a.componentType, TINYGLTF_COMPONENT_TYPE_FLOAT);
        EXPECT_EQ(a.count, m.positions.size());
        const auto* f = reinterpret_cast<const float*>(model.buffers[0].data.data() + v.byteOffset + a.byteOffset);
        return std::vector<float>(f, f + 3 * a.count);
    };
    const std::vector<float> pos = floats("POSITION"), col = floats("COLOR_0"), nrm = floats("NORMAL");
    for (std::size_t i = 0; i < m.positions.size(); ++i)
        for (int c = 0; c < 3; ++c) {
            ASSERT_EQ(pos[3 * i + std::size_t(c)], m.positions[i][c]);
            ASSERT_EQ(nrm[3 * i + std::size_t(c)], m.normals[i][c]);
            // glTF colours are linear: sRGB 0.5 is linear 0.214.
            const float s = m.colors[i][c];
            const float linear = s <= 0.04045f ? s / 12.92f : std::pow((s + 0.055f) / 1.055f, 2.4f);
            ASSERT_NEAR(col[3 * i + std::size_t(c)], linear, 1e-6f);
        }
    const tinygltf::Accessor& pa = model.accessors.at(std::size_t(prim.attributes.at("POSITION")));
    EXPECT_EQ(pa.minValues, (std::vector<double>{b.min.x, b.min.y, b.min.z}));
    const tinygltf::Accessor& ia = model.accessors.at(std::size_t(prim.indices));
    ASSERT_EQ(ia.componentType, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT);
    ASSERT_EQ(ia.count, 3 * m.triangles.size());
    const auto* idx = reinterpret_cast<const std::uint32_t*>(
        model.buffers[0].data.data() + model.bufferViews.at(std::size_t(ia.bufferView)).byteOffset);
    for (std::size_t t = 0; t < m.triangles.size(); ++t)
        for (int c = 0; c < 3; ++c) ASSERT_EQ(idx[3 * t + std::size_t(c)], m.triangles[t][c]);
    EXPECT_THROW(mesh::readMesh(dir / "cow.glb"), IoError);  // an output format only, said clearly
}
