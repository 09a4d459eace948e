#include "mesh/check.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <sstream>
#include <vector>

#include <tbb/parallel_sort.h>
#include <glm/geometric.hpp>

namespace isoforge::mesh {

namespace {

struct UnionFind {
    std::vector<std::uint32_t> parent;
    explicit UnionFind(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0u); }
    std::uint32_t find(std::uint32_t x) {
        while (parent[x] != x) {
            parent[x] = parent[parent[x]];
            x = parent[x];
        }
        return x;
    }
    void unite(std::uint32_t a, std::uint32_t b) {
        a = find(a);
        b = find(b);
        if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
};

// A directed half-edge of triangle `tri`, from its corner `corner` to the next corner.
struct HalfEdge {
    std::uint64_t key;  // (min vertex << 32) | max vertex
    std::uint32_t tri;
    std::uint8_t corner;
    bool forward;  // from == min vertex
};

}  // namespace

std::optional<long long> MeshReport::genus() const {
    if (!isWatertight() || !isVertexManifold() || !isOriented()) return std::nullopt;
    long long twiceGenus = 2 * static_cast<long long>(components) - eulerCharacteristic;
    if (twiceGenus < 0 || twiceGenus % 2 != 0) return std::nullopt;
    return twiceGenus / 2;
}

MeshReport check(const TriMesh& mesh, const CheckOptions& options) {
    if (options.weldByPosition) {
        TriMesh welded = mesh;
        const std::size_t n = weldIdenticalPositions(welded);
        CheckOptions o = options;
        o.weldByPosition = false;
        MeshReport r = check(welded, o);
        r.weldedVertices = n;
        return r;
    }
    MeshReport r;
    const std::size_t nv = mesh.positions.size();
    r.vertices = nv;
    r.triangles = mesh.triangles.size();

    // Triangles usable for topology: valid indices, three distinct vertices.
    std::vector<std::uint8_t> valid(mesh.triangles.size(), 1);
    std::vector<std::uint8_t> used(nv, 0);
    for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
        const glm::uvec3& t = mesh.triangles[i];
        if (t.x >= nv || t.y >= nv || t.z >= nv) {
            ++r.outOfRangeIndices;
            valid[i] = 0;
            continue;
        }
        used[t.x] = used[t.y] = used[t.z] = 1;
        if (t.x == t.y || t.y == t.z || t.x == t.z) {
            ++r.repeatedIndexTriangles;
            valid[i] = 0;
            continue;
        }
        const glm::dvec3 a(mesh.positions[t.x]), b(mesh.positions[t.y]), c(mesh.positions[t.z]);
        const glm::dvec3 n = glm::cross(b - a, c - a);
        const double scale = std::max({glm::dot(b - a, b - a), glm::dot(c - a, c - a), glm::dot(c - b, c - b)});
        const double n2 = glm::dot(n, n);
        if (!(n2 > 1e-24 * scale * scale)) ++r.zeroAreaTriangles;
        r.area += 0.5 * std::sqrt(n2);
        r.volume += glm::dot(a, glm::cross(b, c)) / 6.0;
    }
    r.usedVertices = static_cast<std::size_t>(std::count(used.begin(), used.end(), 1));

    // Duplicate triangles: same vertex set.
    {
        std::vector<std::array<std::uint32_t, 3>> keys;
        keys.reserve(mesh.triangles.size());
        for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
            if (!valid[i]) continue;
            std::array<std::uint32_t, 3> k{mesh.triangles[i].x, mesh.triangles[i].y, mesh.triangles[i].z};
            std::sort(k.begin(), k.end());
            keys.push_back(k);
        }
        tbb::parallel_sort(keys.begin(), keys.end());
        for (std::size_t i = 1; i < keys.size(); ++i) r.duplicateTriangles += keys[i] == keys[i - 1];
    }

    // Edges: sort half-edges by undirected key.
    std::vector<HalfEdge> half;
    half.reserve(3 * mesh.triangles.size());
    for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
        if (!valid[i]) continue;
        const glm::uvec3& t = mesh.triangles[i];
        for (int k = 0; k < 3; ++k) {
            std::uint32_t a = t[k], b = t[(k + 1) % 3];
            std::uint64_t key = (std::uint64_t{std::min(a, b)} << 32) | std::max(a, b);
            half.push_back({key, static_cast<std::uint32_t>(i), static_cast<std::uint8_t>(k), a < b});
        }
    }
    tbb::parallel_sort(half.begin(), half.end(), [](const HalfEdge& x, const HalfEdge& y) {
        return x.key != y.key ? x.key < y.key : x.tri < y.tri;
    });

    // Fans around vertices: triangle corners (3 * tri + corner) joined across manifold edges.
    UnionFind corners(3 * mesh.triangles.size());
    UnionFind vertexComponents(nv);
    for (std::size_t i = 0; i < half.size();) {
        std::size_t j = i;
        while (j < half.size() && half[j].key == half[i].key) ++j;
        ++r.edges;
        const std::size_t count = j - i;
        const auto a = static_cast<std::uint32_t>(half[i].key >> 32);
        const auto b = static_cast<std::uint32_t>(half[i].key & 0xffffffffu);
        vertexComponents.unite(a, b);
        if (count == 1) {
            ++r.boundaryEdges;
        } else if (count > 2) {
            ++r.nonManifoldEdges;
        } else {
            const HalfEdge& e0 = half[i];
            const HalfEdge& e1 = half[i + 1];
            if (e0.forward == e1.forward) ++r.misorientedEdges;
            // Join the corners at a and at b in both triangles.
            auto cornerOf = [&](const HalfEdge& e, std::uint32_t v) {
                const glm::uvec3& t = mesh.triangles[e.tri];
                int k = t.x == v ? 0 : (t.y == v ? 1 : 2);
                return 3 * e.tri + static_cast<std::uint32_t>(k);
            };
            corners.unite(cornerOf(e0, a), cornerOf(e1, a));
            corners.unite(cornerOf(e0, b), cornerOf(e1, b));
        }
        i = j;
    }
    std::vector<std::uint32_t> fans(nv, 0);
    for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
        if (!valid[i]) continue;
        for (int k = 0; k < 3; ++k) {
            std::uint32_t c = static_cast<std::uint32_t>(3 * i + k);
            if (corners.find(c) == c) ++fans[mesh.triangles[i][k]];
        }
    }
    r.nonManifoldVertices =
        static_cast<std::size_t>(std::count_if(fans.begin(), fans.end(), [](auto f) { return f > 1; }));

    // Components and their volumes.
    std::vector<double> componentVolume(nv, 0.0);
    for (std::size_t v = 0; v < nv; ++v)
        if (used[v] && vertexComponents.find(static_cast<std::uint32_t>(v)) == v) ++r.components;
    for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
        if (!valid[i]) continue;
        const glm::uvec3& t = mesh.triangles[i];
        const glm::dvec3 a(mesh.positions[t.x]), b(mesh.positions[t.y]), c(mesh.positions[t.z]);
        componentVolume[vertexComponents.find(t.x)] += glm::dot(a, glm::cross(b, c)) / 6.0;
    }
    if (r.isWatertight())
        for (std::size_t v = 0; v < nv; ++v)
            if (used[v] && vertexComponents.find(static_cast<std::uint32_t>(v)) == v && componentVolume[v] < 0.0)
                ++r.negativeComponents;

    r.eulerCharacteristic = static_cast<long long>(r.usedVertices) - static_cast<long long>(r.edges) +
                            static_cast<long long>(r.triangles - r.outOfRangeIndices - r.repeatedIndexTriangles);
    if (options.selfIntersections) {
        r.selfIntersectionsChecked = true;
        r.selfIntersections = selfIntersections(mesh);
    }
    return r;
}

std::string MeshReport::toString() const {
    std::ostringstream s;
    auto yesNo = [](bool b) { return b ? "yes" : "NO"; };
    s << "vertices        " << vertices;
    if (usedVertices != vertices) s << " (" << usedVertices << " used)";
    if (weldedVertices) s << " (and " << weldedVertices << " copies sharing a position, counted as one)";
    s << "\ntriangles       " << triangles << "\nedges           " << edges;
    s << "\nwatertight      " << yesNo(isWatertight());
    if (boundaryEdges) s << "  (" << boundaryEdges << " boundary edges)";
    s << "\nedge-manifold   " << yesNo(isEdgeManifold());
    if (nonManifoldEdges) s << "  (" << nonManifoldEdges << " edges with 3+ triangles)";
    s << "\nvertex-manifold " << yesNo(isVertexManifold());
    if (nonManifoldVertices) s << "  (" << nonManifoldVertices << " vertices with several fans)";
    s << "\noriented        " << yesNo(isOriented());
    if (misorientedEdges) s << "  (" << misorientedEdges << " edges traversed twice the same way)";
    s << "\noutward         " << yesNo(volume > 0.0);
    if (negativeComponents)
        s << "  (" << negativeComponents << " components enclose negative volume: cavities or inside-out)";
    s << "\ndegenerate      ";
    if (!hasDegenerates())
        s << "none";
    else {
        s << "YES:";
        if (repeatedIndexTriangles) s << " " << repeatedIndexTriangles << " repeated-index";
        if (zeroAreaTriangles) s << " " << zeroAreaTriangles << " zero-area";
        if (duplicateTriangles) s << " " << duplicateTriangles << " duplicate";
        if (outOfRangeIndices) s << " " << outOfRangeIndices << " out-of-range";
    }
    s << "\ncomponents      " << components;
    s << "\neuler           " << eulerCharacteristic;
    if (auto g = genus())
        s << "\ngenus           " << *g;
    else
        s << "\ngenus           n/a (not a closed oriented manifold)";
    s.precision(7);
    s << "\narea            " << area << "\nvolume          " << volume;
    if (!isWatertight()) s << " (not closed: meaningless)";
    if (selfIntersectionsChecked) {
        s << "\nself-intersect  ";
        if (selfIntersections.pairs == 0)
            s << "none";
        else {
            s << "YES: " << selfIntersections.pairs << (selfIntersections.limited ? "+" : "")
              << " intersecting triangle pairs, first triangles " << selfIntersections.first.first << " and "
              << selfIntersections.first.second;
        }
    }
    s << "\n";
    return s.str();
}

}  // namespace isoforge::mesh
