#include "mesh/crease_normals.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <utility>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <glm/geometric.hpp>

namespace isoforge::mesh {

namespace {

/// Each vertex's triangles (CSR: slots from start[v] to start[v + 1]), in triangle order.
struct VertexTriangles {
    std::vector<std::size_t> start;
    std::vector<std::uint32_t> triangle;
};

VertexTriangles vertexTriangles(const TriMesh& m) {
    VertexTriangles vt;
    const std::size_t n = m.positions.size();
    vt.start.assign(n + 1, 0);
    for (const glm::uvec3& t : m.triangles)
        for (int k = 0; k < 3; ++k)
            if (t[k] < n) ++vt.start[t[k] + 1];
    std::partial_sum(vt.start.begin(), vt.start.end(), vt.start.begin());
    vt.triangle.resize(vt.start.back());
    std::vector<std::size_t> next(vt.start.begin(), vt.start.end() - 1);
    for (std::size_t t = 0; t < m.triangles.size(); ++t)
        for (int k = 0; k < 3; ++k)
            if (m.triangles[t][k] < n) vt.triangle[next[m.triangles[t][k]]++] = std::uint32_t(t);
    return vt;
}

}  // namespace

std::size_t splitNormalsAtCreases(TriMesh& m, double angleDegrees) {
    const std::size_t n = m.positions.size();
    if (m.normals.size() != n || !(angleDegrees < 180.0) || m.triangles.empty()) return 0;
    const double cosAngle = std::cos(angleDegrees * M_PI / 180.0);
    const std::vector<glm::uvec3> tris = m.triangles;  // read while m.triangles is rewritten
    const auto& P = m.positions;
    std::vector<glm::dvec3> faceNormal(tris.size());
    tbb::parallel_for(std::size_t{0}, tris.size(), [&](std::size_t t) {
        const glm::uvec3& f = tris[t];
        if (f.x >= n || f.y >= n || f.z >= n) return;  // left as it is (faceNormal zero)
        const glm::dvec3 a(P[f.x]), b(P[f.y]), c(P[f.z]);
        const glm::dvec3 nn = glm::cross(b - a, c - a);
        const double len = glm::length(nn);
        faceNormal[t] = len > 0 ? nn / len : glm::dvec3(0.0);
    });
    const VertexTriangles vt = vertexTriangles(m);

    // 1. The sides around each vertex (union-find over its triangles, joined across the edges they share
    // with it where their normals are near enough; a triangle without area joins its neighbours), labelled
    // in the order of their first triangles.
    std::vector<std::uint32_t> side(vt.triangle.size());
    std::vector<std::uint32_t> sides(n, 1);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1024), [&](const tbb::blocked_range<std::size_t>& r) {
        std::vector<std::pair<std::uint32_t, std::uint32_t>> ends;  // (other vertex, local triangle)
        std::vector<std::uint32_t> parent, label;
        for (std::size_t v = r.begin(); v != r.end(); ++v) {
            const std::size_t s0 = vt.start[v], d = vt.start[v + 1] - s0;
            if (d < 2) continue;
            ends.clear();
            parent.resize(d);
            std::iota(parent.begin(), parent.end(), 0u);
            for (std::size_t i = 0; i < d; ++i) {
                const glm::uvec3& f = tris[vt.triangle[s0 + i]];
                for (int k = 0; k < 3; ++k)
                    if (f[k] != v) ends.emplace_back(f[k], std::uint32_t(i));
            }
            std::sort(ends.begin(), ends.end());
            auto find = [&](std::uint32_t x) {
                while (parent[x] != x) x = parent[x] = parent[parent[x]];
                return x;
            };
            for (std::size_t i = 0; i < ends.size();) {
                std::size_t j = i + 1;
                while (j < ends.size() && ends[j].first == ends[i].first) ++j;
                for (std::size_t p = i; p < j; ++p)
                    for (std::size_t q = p + 1; q < j; ++q) {
                        const glm::dvec3 &np = faceNormal[vt.triangle[s0 + ends[p].second]],
                                         &nq = faceNormal[vt.triangle[s0 + ends[q].second]];
                        const bool flat = glm::dot(np, np) == 0 || glm::dot(nq, nq) == 0;
                        if (flat || glm::dot(np, nq) >= cosAngle) {
                            const std::uint32_t a = find(ends[p].second), b = find(ends[q].second);
                            if (a != b) parent[std::max(a, b)] = std::min(a, b);
                        }
                    }
                i = j;
            }
            label.assign(d, ~0u);
            std::uint32_t count = 0;
            for (std::size_t i = 0; i < d; ++i) {
                const std::uint32_t root = find(std::uint32_t(i));
                if (label[root] == ~0u) label[root] = count++;
                side[s0 + i] = label[root];
            }
            sides[v] = count;
        }
    });

    // 2. Copies for the second and later sides, numbered in vertex order.
    std::vector<std::size_t> firstCopy(n);
    std::size_t added = 0;
    for (std::size_t v = 0; v < n; ++v) {
        firstCopy[v] = n + added;
        added += sides[v] - 1;
    }
    if (added == 0) return 0;
    m.positions.resize(n + added);
    m.normals.resize(n + added);
    const bool colors = m.colors.size() == n;
    if (colors) m.colors.resize(n + added);

    // 3. Each side's normal and its triangles' corners.
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1024), [&](const tbb::blocked_range<std::size_t>& r) {
        std::vector<glm::dvec3> sum;
        for (std::size_t v = r.begin(); v != r.end(); ++v) {
            if (sides[v] < 2) continue;
            const std::size_t s0 = vt.start[v], d = vt.start[v + 1] - s0;
            sum.assign(sides[v], glm::dvec3(0.0));
            for (std::size_t i = 0; i < d; ++i) {
                const std::uint32_t t = vt.triangle[s0 + i];
                const glm::uvec3& f = tris[t];
                int k = 0;
                while (f[k] != v) ++k;
                const glm::dvec3 p(P[v]), e1 = glm::dvec3(P[f[(k + 1) % 3]]) - p,
                                          e2 = glm::dvec3(P[f[(k + 2) % 3]]) - p;
                const double l1 = glm::length(e1), l2 = glm::length(e2);
                const double angle =
                    l1 > 0 && l2 > 0 ? std::acos(std::clamp(glm::dot(e1, e2) / (l1 * l2), -1.0, 1.0)) : 0;
                sum[side[s0 + i]] += angle * faceNormal[t];
                if (side[s0 + i] > 0) {
                    const auto copy = static_cast<unsigned>(firstCopy[v] + side[s0 + i] - 1);
                    for (int c = 0; c < 3; ++c)
                        if (f[c] == v) m.triangles[t][c] = copy;
                }
            }
            for (std::uint32_t s = 0; s < sides[v]; ++s) {
                const double len = glm::length(sum[s]);
                const glm::vec3 normal = len > 0 ? glm::vec3(sum[s] / len) : m.normals[v];
                const std::size_t at = s == 0 ? v : firstCopy[v] + s - 1;
                if (s > 0) {
                    m.positions[at] = P[v];
                    if (colors) m.colors[at] = m.colors[v];
                }
                m.normals[at] = normal;
            }
        }
    });
    return added;
}

}  // namespace isoforge::mesh
