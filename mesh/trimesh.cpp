#include "mesh/trimesh.h"

#include <algorithm>
#include <array>
#include <cstring>
#include <numeric>

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>
#include <glm/geometric.hpp>

namespace isoforge::mesh {

Bounds bounds(const TriMesh& mesh) {
    Bounds b;
    if (mesh.positions.empty()) return b;
    b.min = b.max = mesh.positions.front();
    for (const glm::vec3& p : mesh.positions) {
        b.min = glm::min(b.min, p);
        b.max = glm::max(b.max, p);
    }
    return b;
}

namespace {
template <class F>
double sumOverTriangles(const TriMesh& mesh, F f) {
    return tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, mesh.triangles.size(), 1 << 14), 0.0,
        [&](const tbb::blocked_range<std::size_t>& r, double acc) {
            for (std::size_t i = r.begin(); i != r.end(); ++i) {
                const glm::uvec3& t = mesh.triangles[i];
                acc += f(glm::dvec3(mesh.positions[t.x]), glm::dvec3(mesh.positions[t.y]),
                         glm::dvec3(mesh.positions[t.z]));
            }
            return acc;
        },
        std::plus<double>());
}
}  // namespace

double area(const TriMesh& mesh) {
    return sumOverTriangles(mesh, [](const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
        return 0.5 * glm::length(glm::cross(b - a, c - a));
    });
}

double signedVolume(const TriMesh& mesh) {
    return sumOverTriangles(mesh, [](const glm::dvec3& a, const glm::dvec3& b,
                                     const glm::dvec3& c) { return glm::dot(a, glm::cross(b, c)); }) /
           6.0;
}

std::size_t weldIdenticalPositions(TriMesh& mesh) {
    const std::size_t n = mesh.positions.size();
    std::vector<std::uint32_t> order(n);
    std::iota(order.begin(), order.end(), 0u);
    auto key = [&](std::uint32_t i) {
        std::array<std::uint32_t, 3> k;
        std::memcpy(k.data(), &mesh.positions[i], sizeof(k));
        return k;
    };
    std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) { return key(a) < key(b); });
    std::vector<std::uint32_t> representative(n);
    for (std::size_t i = 0; i < n;) {
        std::size_t j = i;
        while (j < n && key(order[j]) == key(order[i])) ++j;
        for (std::size_t k = i; k < j; ++k) representative[order[k]] = order[i];  // smallest index (stable)
        i = j;
    }
    std::vector<std::uint32_t> remap(n, 0);
    std::vector<glm::vec3> positions;
    std::vector<glm::vec3> normals, colors;
    positions.reserve(n);
    for (std::size_t i = 0; i < n; ++i) {
        if (representative[i] == i) {
            remap[i] = static_cast<std::uint32_t>(positions.size());
            positions.push_back(mesh.positions[i]);
            if (!mesh.normals.empty()) normals.push_back(mesh.normals[i]);
            if (!mesh.colors.empty()) colors.push_back(mesh.colors[i]);
        }
    }
    for (glm::uvec3& t : mesh.triangles)
        for (int k = 0; k < 3; ++k) t[k] = remap[representative[t[k]]];
    std::size_t removed = n - positions.size();
    mesh.positions = std::move(positions);
    mesh.normals = std::move(normals);
    mesh.colors = std::move(colors);
    return removed;
}

}  // namespace isoforge::mesh
