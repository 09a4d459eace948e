#include "mesh/triangulate.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <unordered_map>

#include <glm/common.hpp>
#include <glm/geometric.hpp>
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

/// Whether d lies strictly inside the circle through the counter-clockwise triangle a, b, c.
bool inCircle(const glm::dvec2& a, const glm::dvec2& b, const glm::dvec2& c, const glm::dvec2& d) {
    const glm::dvec2 A = a - d, B = b - d, C = c - d;
    const double la = glm::dot(A, A), lb = glm::dot(B, B), lc = glm::dot(C, C);
    const double det = A.x * (B.y * lc - lb * C.y) - A.y * (B.x * lc - lb * C.x) + la * (B.x * C.y - B.y * C.x);
    const double scale = std::max({la, lb, lc});
    return det > 1e-9 * scale * scale;  // cocircular points (a rectangle) are left as they are
}

/// Lawson's flips to the constrained Delaunay triangulation of the loop in its projection, which
/// is what OpenSCAD's libtess2 makes (TESS_CONSTRAINED_DELAUNAY_TRIANGLES). For planar faces any
/// triangulation is the same surface; for non-planar ones the diagonal decides the solid (OpenSCAD's
/// issue 1061, a stack of twisted quads: 2.5% of its volume). Edges of the loop are never flipped.
void delaunayFlips(const std::vector<glm::dvec2>& p, std::vector<glm::uvec3>& tris) {
    const std::size_t n = p.size();
    if (tris.size() < 2) return;
    auto key = [n](unsigned a, unsigned b) { return std::uint64_t(std::min(a, b)) * n + std::max(a, b); };
    auto boundary = [n](unsigned a, unsigned b) { return (a + 1) % n == b || (b + 1) % n == a; };
    std::unordered_map<std::uint64_t, std::array<std::size_t, 2>> sides;  // interior edge -> its two triangles
    auto link = [&](std::size_t t) {
        for (int k = 0; k < 3; ++k) {
            const unsigned a = tris[t][k], b = tris[t][(k + 1) % 3];
            if (boundary(a, b)) continue;
            auto [it, added] = sides.try_emplace(key(a, b), std::array<std::size_t, 2>{t, t});
            if (!added) it->second[1] = t;
        }
    };
    for (std::size_t t = 0; t < tris.size(); ++t) link(t);
    std::vector<std::uint64_t> work;
    for (const auto& [k, s] : sides) work.push_back(k);
    std::sort(work.begin(), work.end());   // a deterministic order
    std::size_t budget = 16 * n * n + 64;  // Lawson's flips end; hostile loops end sooner
    while (!work.empty() && budget-- > 0) {
        const std::uint64_t e = work.back();
        work.pop_back();
        auto it = sides.find(e);
        if (it == sides.end() || it->second[0] == it->second[1]) continue;
        const std::size_t t1 = it->second[0], t2 = it->second[1];
        const unsigned a = unsigned(e / n), b = unsigned(e % n);
        auto opposite = [&](std::size_t t) {
            for (int k = 0; k < 3; ++k)
                if (tris[t][k] != a && tris[t][k] != b) return tris[t][k];
            return a;
        };
        // Orient: (x, y, c) counter-clockwise in t1, d across the edge.
        unsigned x = a, y = b;
        for (int k = 0; k < 3; ++k)
            if (tris[t1][k] == b && tris[t1][(k + 1) % 3] == a) std::swap(x, y);
        const unsigned c = opposite(t1), d = opposite(t2);
        if (c == d || !(cross(p[x], p[y], p[c]) > 0) || !(cross(p[y], p[x], p[d]) > 0)) continue;
        // The new diagonal c-d must cross x-y: the quad x, d, y, c strictly convex.
        if (!(cross(p[c], p[d], p[y]) > 0 && cross(p[d], p[c], p[x]) > 0)) continue;
        if (!inCircle(p[x], p[y], p[c], p[d])) continue;
        // x-c stays with t1 and y-d with t2; y-c moves to t2, x-d to t1; x-y becomes c-d.
        auto move = [&](unsigned u, unsigned w, std::size_t from, std::size_t to) {
            auto s = sides.find(key(u, w));
            if (s == sides.end()) return;
            for (auto& side : s->second)
                if (side == from) side = to;
        };
        move(y, c, t1, t2);
        move(x, d, t2, t1);
        sides.erase(e);
        sides[key(c, d)] = {t1, t2};
        tris[t1] = glm::uvec3(x, d, c);
        tris[t2] = glm::uvec3(d, y, c);
        for (const auto& [u, w] : {std::pair{x, d}, {d, y}, {y, c}, {c, x}})
            if (!boundary(u, w)) work.push_back(key(u, w));
    }
}

/// The loop projected as libtess2 (OpenSCAD's tessellator) projects it: onto the coordinate plane
/// across the longest axis of the normal of the largest triangle made by the two points furthest
/// apart along the loop's widest axis and a third (libtess2's ComputeNormal, not Newell's normal:
/// for non-planar faces the two can pick different planes, and the Delaunay diagonal with them).
/// Mirrored so that the loop runs counter-clockwise.
std::vector<glm::dvec2> libtessProjection(std::span<const glm::vec3> points, const std::vector<int>& v) {
    auto at = [&](std::size_t k) { return glm::dvec3(points[std::size_t(v[k])]); };
    std::size_t lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
    for (std::size_t k = 1; k < v.size(); ++k)
        for (int i = 0; i < 3; ++i) {
            if (at(k)[i] < at(lo[i])[i]) lo[i] = k;
            if (at(k)[i] > at(hi[i])[i]) hi[i] = k;
        }
    int i = 0;
    if (at(hi[1])[1] - at(lo[1])[1] > at(hi[0])[0] - at(lo[0])[0]) i = 1;
    if (at(hi[2])[2] - at(lo[2])[2] > at(hi[i])[i] - at(lo[i])[i]) i = 2;
    const glm::dvec3 d1 = at(lo[i]) - at(hi[i]);
    glm::dvec3 normal(0, 0, 1);
    double best = 0;
    for (std::size_t k = 0; k < v.size(); ++k) {
        const glm::dvec3 t = glm::cross(d1, at(k) - at(hi[i]));
        if (glm::dot(t, t) > best) {
            best = glm::dot(t, t);
            normal = t;
        }
    }
    int axis = 0;
    if (std::abs(normal.y) > std::abs(normal.x)) axis = 1;
    if (std::abs(normal.z) > std::abs(normal[axis])) axis = 2;
    const int u = (axis + 1) % 3, w = (axis + 2) % 3;
    std::vector<glm::dvec2> q(v.size());
    double area = 0;
    for (std::size_t k = 0; k < v.size(); ++k) q[k] = glm::dvec2(at(k)[u], at(k)[w]);
    for (std::size_t k = 0; k < v.size(); ++k) {
        const glm::dvec2 &a = q[k], &b = q[(k + 1) % v.size()];
        area += a.x * b.y - a.y * b.x;
    }
    if (area < 0)
        for (auto& x : q) x.y = -x.y;
    return q;
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
    // Triangles are built on positions 0..n-1 of the loop, and named by point index at the end.
    auto fan = [&](const std::vector<std::size_t>& ring) {
        for (std::size_t k = 1; k + 1 < ring.size(); ++k)
            out.emplace_back(unsigned(ring[0]), unsigned(ring[k]), unsigned(ring[k + 1]));
    };
    auto named = [&] {
        for (auto& t : out) t = glm::uvec3(unsigned(v[t.x]), unsigned(v[t.y]), unsigned(v[t.z]));
        return out;
    };
    std::vector<std::size_t> whole(n);
    for (std::size_t k = 0; k < n; ++k) whole[k] = k;
    if (n == 3) {
        fan(whole);
        return named();
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
        fan(whole);
        return named();
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
        fan(whole);
        delaunayFlips(libtessProjection(points, v), out);
        return named();
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
        out.emplace_back(unsigned(prev[k]), unsigned(k), unsigned(next[k]));
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
    std::vector<std::size_t> rest;
    for (std::size_t i = 0, k = at; i < remaining; ++i, k = next[k]) rest.push_back(k);
    fan(rest);
    if (budget > 0) delaunayFlips(libtessProjection(points, v), out);
    return named();
}

std::vector<glm::uvec3> triangulateRegionXY(std::span<const glm::vec3> points, std::span<const int> outer,
                                            const std::vector<std::vector<int>>& holes) {
    std::vector<int> loop(outer.begin(), outer.end());
    if (loop.size() < 3) return {};
    auto area = [&](const std::vector<int>& l, double flipY) {
        double a = 0;
        for (std::size_t k = 0; k < l.size(); ++k) {
            const glm::vec3 &u = points[std::size_t(l[k])], &w = points[std::size_t(l[(k + 1) % l.size()])];
            a += (double(u.x) * w.y - double(u.y) * w.x) * flipY;
        }
        return a;
    };
    // Work as if the outer loop ran counter-clockwise (mirrored in y when it does not).
    const double flipY = area(loop, 1.0) >= 0 ? 1.0 : -1.0;
    auto at = [&](int i) { return glm::dvec2(points[std::size_t(i)].x, flipY * points[std::size_t(i)].y); };

    struct Hole {
        std::vector<int> loop;
        std::size_t right;  // its point of largest x
    };
    std::vector<Hole> order;
    for (const auto& h : holes) {
        if (h.size() < 3) continue;
        Hole hole{h, 0};
        if (area(hole.loop, flipY) > 0) std::reverse(hole.loop.begin(), hole.loop.end());  // holes run clockwise
        for (std::size_t k = 1; k < hole.loop.size(); ++k) {
            const glm::dvec2 a = at(hole.loop[k]), b = at(hole.loop[hole.right]);
            if (a.x > b.x || (a.x == b.x && a.y < b.y)) hole.right = k;
        }
        order.push_back(std::move(hole));
    }
    std::stable_sort(order.begin(), order.end(),
                     [&](const Hole& a, const Hole& b) { return at(a.loop[a.right]).x > at(b.loop[b.right]).x; });

    // Whether the segment from loop position k towards m leaves into the region (k's corner opens to it).
    auto locallyInside = [&](std::size_t k, const glm::dvec2& m) {
        const std::size_t n = loop.size();
        const glm::dvec2 a = at(loop[(k + n - 1) % n]), p = at(loop[k]), b = at(loop[(k + 1) % n]);
        const glm::dvec2 d = m - p;
        auto cr = [](const glm::dvec2& u, const glm::dvec2& v) { return u.x * v.y - u.y * v.x; };
        if (cr(p - a, b - p) >= 0) return cr(b - p, d) >= 0 && cr(d, a - p) >= 0;
        return !(cr(a - p, d) > 0 && cr(d, b - p) > 0);
    };
    for (const Hole& h : order) {
        const glm::dvec2 m = at(h.loop[h.right]);
        const std::size_t n = loop.size();
        // The nearest crossing of the ray from m towards +x with the loop, and the end of that edge
        // furthest along the ray.
        double best = INFINITY;
        std::size_t bridge = n;
        for (std::size_t k = 0; k < n; ++k) {
            const glm::dvec2 a = at(loop[k]), b = at(loop[(k + 1) % n]);
            if (!((a.y <= m.y && m.y <= b.y) || (b.y <= m.y && m.y <= a.y))) continue;
            if (a.y == b.y) {  // along the ray: its nearer end
                for (std::size_t e : {k, (k + 1) % n}) {
                    const glm::dvec2 v = at(loop[e]);
                    if (v.x >= m.x && v.x < best) best = v.x, bridge = e;
                }
                continue;
            }
            const double x = a.x + (m.y - a.y) * (b.x - a.x) / (b.y - a.y);
            if (!(x >= m.x && x < best)) continue;
            best = x;
            bridge = a.y == m.y ? k : b.y == m.y ? (k + 1) % n : (a.x >= b.x ? k : (k + 1) % n);
        }
        if (bridge == n) continue;
        const glm::dvec2 hit(best, m.y), end = at(loop[bridge]);
        if (end != hit) {
            // A point of the loop inside the triangle (m, hit, end) hides `end`: take the one nearest
            // the ray in angle (then in distance), which m sees.
            double bestTan = INFINITY, bestDist = INFINITY;
            std::size_t seen = n;
            for (std::size_t k = 0; k < n; ++k) {
                const glm::dvec2 v = at(loop[k]);
                if (k == bridge || !(v.x > m.x)) continue;
                const double c1 = cross(m, hit, v), c2 = cross(hit, end, v), c3 = cross(end, m, v);
                const bool in = (c1 >= 0 && c2 >= 0 && c3 >= 0) || (c1 <= 0 && c2 <= 0 && c3 <= 0);
                if (!in || !locallyInside(k, m)) continue;
                const double t = std::abs(m.y - v.y) / (v.x - m.x), dist = glm::dot(v - m, v - m);
                if (t < bestTan || (t == bestTan && dist < bestDist)) bestTan = t, bestDist = dist, seen = k;
            }
            if (seen != n) bridge = seen;
        }
        // A point the loop passes twice (an earlier bridge): the pass whose corner opens towards m.
        if (!locallyInside(bridge, m))
            for (std::size_t k = 0; k < n; ++k)
                if (at(loop[k]) == at(loop[bridge]) && locallyInside(k, m)) {
                    bridge = k;
                    break;
                }
        std::vector<int> joined(loop.begin(), loop.begin() + std::ptrdiff_t(bridge) + 1);
        for (std::size_t k = 0; k <= h.loop.size(); ++k) joined.push_back(h.loop[(h.right + k) % h.loop.size()]);
        joined.insert(joined.end(), loop.begin() + std::ptrdiff_t(bridge), loop.end());
        loop = std::move(joined);
    }
    return triangulateFace(points, loop);
}

}  // namespace isoforge::mesh
