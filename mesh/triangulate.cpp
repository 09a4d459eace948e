#include "mesh/triangulate.h"

#include <algorithm>
#include <cmath>

#include <glm/common.hpp>
#include <glm/vec2.hpp>

// Why our own: Debian 12 packages no C++ polygon triangulator of this size (mapbox's earcut only as
// Python bindings; libtess2 only inside Tulip), and CGAL's constrained triangulation would add its
// heavy headers and GMP to every build for faces of a few to a few hundred points. Ear clipping
// with the reflex-vertex test is the textbook method (Eberly, "Triangulation by Ear Clipping").

namespace isoforge::mesh {

namespace {

double cross(const glm::dvec2& a, const glm::dvec2& b, const glm::dvec2& c) {
    return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
}

/// Closed triangle test (points on an edge count as inside), for a counter-clockwise triangle.
bool inTriangle(const glm::dvec2& a, const glm::dvec2& b, const glm::dvec2& c, const glm::dvec2& p) {
    return cross(a, b, p) >= 0 && cross(b, c, p) >= 0 && cross(c, a, p) >= 0;
}

}  // namespace

std::vector<glm::uvec3> triangulateFace(std::span<const glm::vec3> points, std::span<const int> loop) {
    // Distinct consecutive points (a loop may repeat a point, or name two points at one place).
    std::vector<int> v;
    v.reserve(loop.size());
    for (int i : loop)
        if (v.empty() || (i != v.back() && points[std::size_t(i)] != points[std::size_t(v.back())])) v.push_back(i);
    while (v.size() > 1 && points[std::size_t(v.front())] == points[std::size_t(v.back())]) v.pop_back();
    std::vector<glm::uvec3> out;
    if (v.size() < 3) return out;
    const std::size_t n = v.size();
    out.reserve(n - 2);
    auto fan = [&](const std::vector<int>& ring) {
        for (std::size_t k = 1; k + 1 < ring.size(); ++k)
            out.emplace_back(unsigned(ring[0]), unsigned(ring[k]), unsigned(ring[k + 1]));
    };
    if (n == 3) {
        fan(v);
        return out;
    }

    // Newell's normal, and the projection onto the coordinate plane it is most parallel to, turned
    // so that the loop runs counter-clockwise there.
    glm::dvec3 normal(0.0);
    for (std::size_t k = 0; k < n; ++k) {
        const glm::dvec3 a(points[std::size_t(v[k])]), b(points[std::size_t(v[(k + 1) % n])]);
        normal += glm::dvec3((a.y - b.y) * (a.z + b.z), (a.z - b.z) * (a.x + b.x), (a.x - b.x) * (a.y + b.y));
    }
    const glm::dvec3 an = glm::abs(normal);
    const int axis = an.x >= an.y && an.x >= an.z ? 0 : (an.y >= an.z ? 1 : 2);
    if (!(an[axis] > 0)) {  // no area (or not finite): keep the face as a fan, the mesh drops empty triangles
        fan(v);
        return out;
    }
    int u = (axis + 1) % 3, w = (axis + 2) % 3;
    if (normal[axis] < 0) std::swap(u, w);
    std::vector<glm::dvec2> p(n);
    for (std::size_t k = 0; k < n; ++k) {
        const glm::vec3& q = points[std::size_t(v[k])];
        p[k] = glm::dvec2(q[u], q[w]);
    }

    std::vector<std::size_t> prev(n), next(n);
    for (std::size_t k = 0; k < n; ++k) {
        prev[k] = (k + n - 1) % n;
        next[k] = (k + 1) % n;
    }
    auto convex = [&](std::size_t k) { return cross(p[prev[k]], p[k], p[next[k]]) > 0; };
    bool allConvex = true;
    for (std::size_t k = 0; k < n && allConvex; ++k) allConvex = cross(p[prev[k]], p[k], p[next[k]]) >= 0;
    if (allConvex) {
        fan(v);
        return out;
    }

    // Only reflex (or straight) corners can lie inside an ear; keep them in a list.
    std::vector<char> alive(n, 1);
    std::vector<std::size_t> reflex;
    for (std::size_t k = 0; k < n; ++k)
        if (!convex(k)) reflex.push_back(k);
    auto isEar = [&](std::size_t k) {
        if (!convex(k)) return false;
        const std::size_t a = prev[k], c = next[k];
        for (std::size_t r : reflex) {
            if (!alive[r] || r == a || r == k || r == c) continue;
            if (p[r] == p[a] || p[r] == p[k] || p[r] == p[c]) continue;
            if (inTriangle(p[a], p[k], p[c], p[r])) return false;
        }
        return true;
    };
    auto clip = [&](std::size_t k) {
        out.emplace_back(unsigned(v[prev[k]]), unsigned(v[k]), unsigned(v[next[k]]));
        alive[k] = 0;
        next[prev[k]] = next[k];
        prev[next[k]] = prev[k];
    };

    std::size_t remaining = n, at = 0;
    // A hostile loop (many reflex points) is bounded: past this much work, what is left becomes a fan.
    std::size_t budget = 64 * n + 20'000'000;
    while (remaining > 3) {
        bool clipped = false;
        for (std::size_t tries = 0; tries < remaining; ++tries, at = next[at]) {
            budget = budget > reflex.size() ? budget - reflex.size() : 0;
            if (budget == 0) break;
            if (isEar(at)) {
                const std::size_t after = next[at];
                clip(at);
                at = after;
                clipped = true;
                break;
            }
        }
        if (budget == 0) break;
        if (!clipped) {
            // No ear: the loop crosses itself or has collapsed to a line. Clip the most convex corner
            // so that every point still ends up in a triangle.
            std::size_t best = at;
            double bestCross = -INFINITY;
            std::size_t k = at;
            for (std::size_t i = 0; i < remaining; ++i, k = next[k]) {
                const double c = cross(p[prev[k]], p[k], p[next[k]]);
                if (c > bestCross) {
                    bestCross = c;
                    best = k;
                }
            }
            at = next[best];
            clip(best);
        }
        --remaining;
    }
    std::vector<int> rest;
    for (std::size_t i = 0, k = at; i < remaining; ++i, k = next[k]) rest.push_back(v[k]);
    fan(rest);
    return out;
}

}  // namespace isoforge::mesh
