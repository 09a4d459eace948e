#include "mesh/primitives.h"

#include <array>
#include <cmath>
#include <map>
#include <stdexcept>

#include <glm/geometric.hpp>

namespace isoforge::mesh {

namespace {

constexpr double kTwoPi = 6.283185307179586;

/// Adds triangle (a, b, c), counter-clockwise seen from outside.
void tri(TriMesh& m, std::uint32_t a, std::uint32_t b, std::uint32_t c) {
    m.triangles.emplace_back(a, b, c);
}
std::uint32_t vertex(TriMesh& m, glm::vec3 p) {
    m.positions.push_back(p);
    return static_cast<std::uint32_t>(m.positions.size() - 1);
}
glm::vec3 onCircle(double angle, float r, float z) {
    return {static_cast<float>(r * std::cos(angle)), static_cast<float>(r * std::sin(angle)), z};
}
void requireSides(int n, const char* what) {
    if (n < 3 || n > 4096) throw std::invalid_argument(std::string(what) + ": resolution must be 3..4096");
}

}  // namespace

TriMesh makeCube(int n) {
    if (n < 1 || n > 4096) throw std::invalid_argument("cube: resolution must be 1..4096");
    TriMesh m;
    // Vertices on the boundary of the integer lattice [0, n]^3, shared between faces by their coordinates.
    std::map<std::array<int, 3>, std::uint32_t> index;
    auto at = [&](std::array<int, 3> c) {
        auto [it, added] = index.try_emplace(c, 0u);
        if (added)
            it->second = vertex(m, glm::vec3(float(c[0]) / float(n) - 0.5f, float(c[1]) / float(n) - 0.5f,
                                             float(c[2]) / float(n) - 0.5f));
        return it->second;
    };
    for (int axis = 0; axis < 3; ++axis)
        for (int side = 0; side < 2; ++side) {
            // (u, v) span the face so that u x v points along +axis; the low face is wound the other way.
            const int u = (axis + 1) % 3, v = (axis + 2) % 3;
            for (int i = 0; i < n; ++i)
                for (int j = 0; j < n; ++j) {
                    std::array<std::array<int, 3>, 4> q;
                    for (int k = 0; k < 4; ++k) {
                        q[k][axis] = side * n;
                        q[k][u] = i + (k == 1 || k == 2);
                        q[k][v] = j + (k >= 2);
                    }
                    const std::uint32_t a = at(q[0]), b = at(q[1]), c = at(q[2]), d = at(q[3]);
                    if (side) {
                        tri(m, a, b, c);
                        tri(m, a, c, d);
                    } else {
                        tri(m, a, c, b);
                        tri(m, a, d, c);
                    }
                }
        }
    return m;
}

TriMesh makeCylinder(int n, float r, float h) {
    requireSides(n, "cylinder");
    TriMesh m;
    const float z0 = -0.5f * h, z1 = 0.5f * h;
    for (int i = 0; i < n; ++i) vertex(m, onCircle(kTwoPi * i / n, r, z0));
    for (int i = 0; i < n; ++i) vertex(m, onCircle(kTwoPi * i / n, r, z1));
    const std::uint32_t bottom = vertex(m, {0.f, 0.f, z0}), top = vertex(m, {0.f, 0.f, z1});
    const auto N = static_cast<std::uint32_t>(n);
    for (std::uint32_t i = 0; i < N; ++i) {
        const std::uint32_t j = (i + 1) % N;
        tri(m, i, j, N + j);  // side, counter-clockwise seen from outside
        tri(m, i, N + j, N + i);
        tri(m, bottom, j, i);  // bottom cap, seen from below
        tri(m, top, N + i, N + j);
    }
    return m;
}

TriMesh makeCone(int n, float r, float h) {
    requireSides(n, "cone");
    TriMesh m;
    const float z0 = -0.5f * h;
    for (int i = 0; i < n; ++i) vertex(m, onCircle(kTwoPi * i / n, r, z0));
    const std::uint32_t base = vertex(m, {0.f, 0.f, z0}), apex = vertex(m, {0.f, 0.f, 0.5f * h});
    const auto N = static_cast<std::uint32_t>(n);
    for (std::uint32_t i = 0; i < N; ++i) {
        const std::uint32_t j = (i + 1) % N;
        tri(m, i, j, apex);
        tri(m, base, j, i);
    }
    return m;
}

TriMesh makeUvSphere(int n, float r) {
    requireSides(n, "sphere");
    const int rings = std::max(2, n / 2);
    TriMesh m;
    const std::uint32_t south = vertex(m, {0.f, 0.f, -r});
    for (int k = 1; k < rings; ++k) {
        const double phi = M_PI * k / rings - M_PI / 2;  // latitude
        for (int i = 0; i < n; ++i)
            vertex(m, onCircle(kTwoPi * i / n, static_cast<float>(r * std::cos(phi)),
                               static_cast<float>(r * std::sin(phi))));
    }
    const std::uint32_t north = vertex(m, {0.f, 0.f, r});
    const auto N = static_cast<std::uint32_t>(n);
    auto ring = [&](int k, std::uint32_t i) { return 1 + static_cast<std::uint32_t>(k - 1) * N + i % N; };
    for (std::uint32_t i = 0; i < N; ++i) {
        tri(m, south, ring(1, i + 1), ring(1, i));
        tri(m, north, ring(rings - 1, i), ring(rings - 1, i + 1));
        for (int k = 1; k + 1 < rings; ++k) {
            tri(m, ring(k, i), ring(k, i + 1), ring(k + 1, i + 1));
            tri(m, ring(k, i), ring(k + 1, i + 1), ring(k + 1, i));
        }
    }
    return m;
}

TriMesh makeIcosphere(int levels, float r) {
    if (levels < 0 || levels > 8) throw std::invalid_argument("icosphere: subdivision levels must be 0..8");
    TriMesh m;
    const float t = (1.f + std::sqrt(5.f)) / 2.f;
    for (const glm::vec3 p : {glm::vec3(-1, t, 0), glm::vec3(1, t, 0), glm::vec3(-1, -t, 0), glm::vec3(1, -t, 0),
                              glm::vec3(0, -1, t), glm::vec3(0, 1, t), glm::vec3(0, -1, -t), glm::vec3(0, 1, -t),
                              glm::vec3(t, 0, -1), glm::vec3(t, 0, 1), glm::vec3(-t, 0, -1), glm::vec3(-t, 0, 1)})
        vertex(m, glm::normalize(p) * r);
    m.triangles = {{0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                   {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                   {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
    for (int level = 0; level < levels; ++level) {
        std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> mid;
        auto middle = [&](std::uint32_t a, std::uint32_t b) {
            auto [it, added] = mid.try_emplace({std::min(a, b), std::max(a, b)}, 0u);
            if (added) it->second = vertex(m, glm::normalize(m.positions[a] + m.positions[b]) * r);
            return it->second;
        };
        std::vector<glm::uvec3> next;
        next.reserve(m.triangles.size() * 4);
        for (const auto& f : m.triangles) {
            const std::uint32_t ab = middle(f.x, f.y), bc = middle(f.y, f.z), ca = middle(f.z, f.x);
            next.insert(next.end(), {{f.x, ab, ca}, {f.y, bc, ab}, {f.z, ca, bc}, {ab, bc, ca}});
        }
        m.triangles = std::move(next);
    }
    return m;
}

TriMesh makeTorus(int n, float R, float r) {
    requireSides(n, "torus");
    if (!(R > r && r > 0)) throw std::invalid_argument("torus: radii must satisfy R > r > 0");
    const int tube = std::max(3, n / 2);
    TriMesh m;
    for (int i = 0; i < n; ++i) {
        const double a = kTwoPi * i / n;
        for (int j = 0; j < tube; ++j) {
            const double b = kTwoPi * j / tube;
            const float rr = static_cast<float>(R + r * std::cos(b));
            vertex(m, onCircle(a, rr, static_cast<float>(r * std::sin(b))));
        }
    }
    auto at = [&](int i, int j) { return static_cast<std::uint32_t>((i % n) * tube + (j % tube)); };
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < tube; ++j) {
            tri(m, at(i, j), at(i + 1, j), at(i + 1, j + 1));
            tri(m, at(i, j), at(i + 1, j + 1), at(i, j + 1));
        }
    return m;
}

TriMesh makePrimitive(const std::string& name, int resolution) {
    if (name == "cube") return makeCube(resolution);
    if (name == "cylinder") return makeCylinder(resolution);
    if (name == "cone") return makeCone(resolution);
    if (name == "sphere") return makeUvSphere(resolution);
    if (name == "icosphere") return makeIcosphere(resolution);
    if (name == "torus") return makeTorus(resolution);
    throw std::invalid_argument("unknown primitive '" + name + "' (cube, cylinder, cone, sphere, icosphere, torus)");
}

std::vector<std::string> primitiveNames() {
    return {"cube", "cylinder", "cone", "sphere", "icosphere", "torus"};
}

}  // namespace isoforge::mesh
