#pragma once
#include <cmath>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include "mesh/check.h"

namespace isoforge::test {

inline std::filesystem::path sourceDir() {
    return ISOFORGE_SOURCE_DIR;
}
inline std::filesystem::path sharedData() {
    return ISOFORGE_SHARED_DATA;
}

/// A fresh empty directory for a test's files.
inline std::filesystem::path scratchDir(const std::string& name) {
    auto d = std::filesystem::temp_directory_path() / ("isoforge-test-" + name + "-" + std::to_string(::getpid()));
    std::filesystem::remove_all(d);
    std::filesystem::create_directories(d);
    return d;
}

// Under AddressSanitizer CGAL's exact predicates run about 15 times slower: the release suite checks
// every mesh for intersecting triangle pairs, the sanitizer suite the ones up to this size.
#if defined(__SANITIZE_ADDRESS__)
inline constexpr std::size_t kSelfIntersectionCheckLimit = 150000;
#else
inline constexpr std::size_t kSelfIntersectionCheckLimit = ~std::size_t{0};
#endif

/// Asserts the mesh is a closed, 2-manifold, consistently and outward oriented surface without
/// degenerate triangles or intersecting triangle pairs; returns the report for further checks.
inline mesh::MeshReport expectClosedSurface(const mesh::TriMesh& m, const std::string& what) {
    mesh::MeshReport r = mesh::check(m, {.selfIntersections = m.triangleCount() <= kSelfIntersectionCheckLimit});
    EXPECT_GT(r.triangles, 0u) << what;
    EXPECT_EQ(r.selfIntersections.pairs, 0u)
        << what << ": first pair " << r.selfIntersections.first.first << ", " << r.selfIntersections.first.second;
    EXPECT_EQ(r.boundaryEdges, 0u) << what;
    EXPECT_EQ(r.nonManifoldEdges, 0u) << what;
    EXPECT_EQ(r.nonManifoldVertices, 0u) << what;
    EXPECT_EQ(r.misorientedEdges, 0u) << what;
    EXPECT_EQ(r.repeatedIndexTriangles, 0u) << what;
    EXPECT_EQ(r.zeroAreaTriangles, 0u) << what;
    EXPECT_EQ(r.duplicateTriangles, 0u) << what;
    EXPECT_EQ(r.usedVertices, r.vertices) << what << ": unreferenced vertices";
    EXPECT_GT(r.volume, 0.0) << what;
    EXPECT_TRUE(r.genus().has_value()) << what;
    return r;
}

/// The winding number of a mesh at q, from the solid angle of every triangle (van Oosterom and Strackee, in
/// double): the reference the library's faster signs are checked against.
inline double windingNumber(const mesh::TriMesh& m, const glm::dvec3& q) {
    double omega = 0;
    for (const glm::uvec3& t : m.triangles) {
        const glm::dvec3 a = glm::dvec3(m.positions[t.x]) - q, b = glm::dvec3(m.positions[t.y]) - q,
                         c = glm::dvec3(m.positions[t.z]) - q;
        const double la = glm::length(a), lb = glm::length(b), lc = glm::length(c);
        omega += 2 * std::atan2(glm::dot(a, glm::cross(b, c)),
                                la * lb * lc + glm::dot(a, b) * lc + glm::dot(b, c) * la + glm::dot(c, a) * lb);
    }
    return omega / (4 * M_PI);
}

}  // namespace isoforge::test
