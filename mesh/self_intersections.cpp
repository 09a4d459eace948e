// Built alone into isoforge_mesh_exact: CGAL's headers are heavy and want -frounding-math.
#include "mesh/self_intersections.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/box_intersection_d.h>
#include <CGAL/intersections.h>
#include <glm/geometric.hpp>
#include <glm/vec2.hpp>

namespace isoforge::mesh {

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = K::Point_3;
using Box = CGAL::Box_intersection_d::Box_with_info_d<double, 3, std::size_t>;

}  // namespace

namespace {

/// True when the points `q` (those not shared with the triangle p0 p1 p2) all lie clearly on one side of its
/// plane, in double arithmetic with a margin far above its rounding (the inputs are floats: their differences
/// are exact in double, the cross and dot products are within a few units in the last place).
bool oneSideOfPlane(const glm::dvec3& p0, const glm::dvec3& p1, const glm::dvec3& p2, const glm::dvec3* q, int count) {
    const glm::dvec3 e1 = p1 - p0, e2 = p2 - p0;
    const glm::dvec3 n = glm::cross(e1, e2);
    const double scale = glm::length(e1) * glm::length(e2);
    int above = 0, below = 0;
    for (int k = 0; k < count; ++k) {
        const glm::dvec3 d = q[k] - p0;
        const double s = glm::dot(n, d), err = 1e-12 * scale * glm::length(d);
        above += s > err;
        below += s < -err;
    }
    return above == count || below == count;
}

/// True when the triangles are clearly apart, decided in double arithmetic without shared vertices:
/// their boxes do not overlap, or their projections along the dominant axis of one's normal are
/// separated by a line through an edge, by a margin far above rounding (a point common to both
/// triangles would project to a point common to both projections). Pairs of a flat region lie
/// exactly in one plane, where CGAL's filters always fall back to exact arithmetic: this settles
/// the ones that are apart.
bool clearlyApart(const std::array<glm::vec3, 3>& pa, const std::array<glm::vec3, 3>& pb) {
    for (int ax = 0; ax < 3; ++ax) {
        const float loA = std::min({pa[0][ax], pa[1][ax], pa[2][ax]}),
                    hiA = std::max({pa[0][ax], pa[1][ax], pa[2][ax]});
        const float loB = std::min({pb[0][ax], pb[1][ax], pb[2][ax]}),
                    hiB = std::max({pb[0][ax], pb[1][ax], pb[2][ax]});
        if (hiA < loB || hiB < loA) return true;  // exact: comparisons of the input floats
    }
    const glm::dvec3 a0(pa[0]), a1(pa[1]), a2(pa[2]);
    const glm::dvec3 n = glm::abs(glm::cross(a1 - a0, a2 - a0));
    const int drop = n.x >= n.y && n.x >= n.z ? 0 : (n.y >= n.z ? 1 : 2);
    const int u = (drop + 1) % 3, v = (drop + 2) % 3;
    const std::array<glm::dvec2, 3> A{glm::dvec2(pa[0][u], pa[0][v]), glm::dvec2(pa[1][u], pa[1][v]),
                                      glm::dvec2(pa[2][u], pa[2][v])};
    const std::array<glm::dvec2, 3> B{glm::dvec2(pb[0][u], pb[0][v]), glm::dvec2(pb[1][u], pb[1][v]),
                                      glm::dvec2(pb[2][u], pb[2][v])};
    // Side of q against the line p0 -> p1, and a bound on its rounding error.
    auto side = [](const glm::dvec2& p0, const glm::dvec2& p1, const glm::dvec2& q, double& err) {
        const glm::dvec2 d = p1 - p0, e = q - p0;
        err = 1e-12 * (std::abs(d.x * e.y) + std::abs(d.y * e.x));
        return d.x * e.y - d.y * e.x;
    };
    auto separates = [&](const std::array<glm::dvec2, 3>& T, const std::array<glm::dvec2, 3>& other) {
        for (int k = 0; k < 3; ++k) {
            const glm::dvec2 &p0 = T[k], &p1 = T[(k + 1) % 3];
            double err = 0;
            const double own = side(p0, p1, T[(k + 2) % 3], err);
            if (!(std::abs(own) > err)) continue;  // a sliver in projection: no use
            bool all = true;
            for (int j = 0; j < 3 && all; ++j) {
                const double s = side(p0, p1, other[j], err);
                all = own > 0 ? s < -err : s > err;
            }
            if (all) return true;
        }
        return false;
    };
    if (separates(A, B) || separates(B, A)) return true;
    // Or one lies clearly on one side of the other's plane (Moller's first test).
    const std::array<glm::dvec3, 3> da{glm::dvec3(pa[0]), glm::dvec3(pa[1]), glm::dvec3(pa[2])},
        db{glm::dvec3(pb[0]), glm::dvec3(pb[1]), glm::dvec3(pb[2])};
    return oneSideOfPlane(da[0], da[1], da[2], db.data(), 3) || oneSideOfPlane(db[0], db[1], db[2], da.data(), 3);
}

}  // namespace

bool trianglesIntersect(const std::array<glm::vec3, 3>& pa, const std::array<unsigned, 3>& a,
                        const std::array<glm::vec3, 3>& pb, const std::array<unsigned, 3>& b) {
    bool sharesVertex = false;
    for (unsigned i : a)
        for (unsigned j : b) sharesVertex = sharesVertex || i == j;
    if (!sharesVertex && clearlyApart(pa, pb)) return false;
    // Points by vertex id, so that a shared vertex is one point (the first triangle's).
    const std::array<Point, 6> pts{Point(pa[0].x, pa[0].y, pa[0].z), Point(pa[1].x, pa[1].y, pa[1].z),
                                   Point(pa[2].x, pa[2].y, pa[2].z), Point(pb[0].x, pb[0].y, pb[0].z),
                                   Point(pb[1].x, pb[1].y, pb[1].z), Point(pb[2].x, pb[2].y, pb[2].z)};
    auto pt = [&](unsigned id) -> const Point& {
        for (int k = 0; k < 3; ++k)
            if (a[k] == id) return pts[k];
        for (int k = 0; k < 3; ++k)
            if (b[k] == id) return pts[3 + k];
        return pts[0];
    };
    if (CGAL::collinear(pts[0], pts[1], pts[2]) || CGAL::collinear(pts[3], pts[4], pts[5])) return false;
    int shared = 0;
    int ia = -1, ib = -1;  // positions of one shared vertex in each
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            if (a[i] == b[j]) {
                ++shared;
                ia = i;
                ib = j;
            }
    bool hit = false;
    if (shared >= 3) {
        hit = true;  // the same triangle twice
    } else if (shared == 2) {
        // The vertices not shared: r of a, q of b. They fold onto each other when coplanar and on
        // the same side of the common edge.
        int ra = 0, rb = 0;
        for (int i = 0; i < 3; ++i) {
            if (std::find(b.begin(), b.end(), a[i]) == b.end()) ra = i;
            if (std::find(a.begin(), a.end(), b[i]) == a.end()) rb = i;
        }
        const Point& p = pt(a[(ra + 1) % 3]);
        const Point& q = pt(a[(ra + 2) % 3]);
        const Point& r = pt(a[ra]);
        const Point& s2 = pt(b[rb]);
        // In double first: the other vertex clearly across the edge needs no exact arithmetic (flat
        // regions make every neighbouring pair exactly coplanar, where the filter always fails).
        const glm::dvec3 P0(p.x(), p.y(), p.z()), Q0(q.x(), q.y(), q.z()), R0(r.x(), r.y(), r.z()),
            S0(s2.x(), s2.y(), s2.z());
        const glm::dvec3 e = Q0 - P0, nr = glm::cross(e, R0 - P0), ns = glm::cross(e, S0 - P0);
        if (glm::dot(nr, ns) < -1e-6 * glm::length(nr) * glm::length(ns))
            hit = false;  // a fold needs both on one side
        else
            hit = CGAL::coplanar(p, q, r, s2) && CGAL::coplanar_orientation(p, q, r, s2) == CGAL::POSITIVE;
    } else if (shared == 1) {
        const Point& v = pt(a[ia]);
        const Point &a1 = pt(a[(ia + 1) % 3]), &a2 = pt(a[(ia + 2) % 3]);
        const Point &b1 = pt(b[(ib + 1) % 3]), &b2 = pt(b[(ib + 2) % 3]);
        // In double first, for the coplanar pairs of flat regions (where CGAL's filter always fails):
        // two triangles with a common apex in one plane overlap exactly when their angles at the apex
        // overlap; clearly apart needs no exact arithmetic.
        const glm::dvec3 V0(v.x(), v.y(), v.z()), A1(a1.x(), a1.y(), a1.z()), A2(a2.x(), a2.y(), a2.z()),
            B1(b1.x(), b1.y(), b1.z()), B2(b2.x(), b2.y(), b2.z());
        const glm::dvec3 na = glm::cross(A1 - V0, A2 - V0), nb = glm::cross(B1 - V0, B2 - V0);
        const double la = glm::length(na), lb = glm::length(nb);
        bool apart = false;
        if (la > 0 && lb > 0 && glm::dot(na, nb) > (1.0 - 1e-12) * la * lb) {
            const glm::dvec3 n = na / la;
            const double size =
                std::max({glm::length(A1 - V0), glm::length(A2 - V0), glm::length(B1 - V0), glm::length(B2 - V0)});
            bool flat = true;
            for (const glm::dvec3& w : {B1, B2}) flat = flat && std::abs(glm::dot(w - V0, n)) < 1e-9 * size;
            if (flat) {
                // In the plane, each triangle's angle at the apex is a sector under pi, counter-clockwise
                // about n from its first edge to its second. Their interiors are apart when neither
                // sector holds a bounding ray of the other; "holds" as a sine of at least -1e-6 from both
                // bounding rays (far above rounding), so that a ray on or near a boundary goes to the
                // exact test below.
                const glm::dvec3 x = glm::normalize(A1 - V0), y = glm::cross(n, x);
                auto dir = [&](const glm::dvec3& w) {
                    return glm::normalize(glm::dvec2(glm::dot(w - V0, x), glm::dot(w - V0, y)));
                };
                const glm::dvec2 a1d = dir(A1), a2d = dir(A2), b1d = dir(B1), b2d = dir(B2);
                auto cross2 = [](const glm::dvec2& p, const glm::dvec2& q) { return p.x * q.y - p.y * q.x; };
                auto clearlyOutside = [&](const glm::dvec2& from, const glm::dvec2& to, const glm::dvec2& w) {
                    return cross2(from, w) < -1e-6 || cross2(w, to) < -1e-6;
                };
                apart = cross2(a1d, a2d) > 1e-6 && cross2(b1d, b2d) > 1e-6 && clearlyOutside(a1d, a2d, b1d) &&
                        clearlyOutside(a1d, a2d, b2d) && clearlyOutside(b1d, b2d, a1d) && clearlyOutside(b1d, b2d, a2d);
            }
        }
        // Not in one plane: when b's other two corners lie clearly on one side of a's plane (or a's of b's),
        // the two meet at the apex only.
        const glm::dvec3 otherB[2] = {B1, B2}, otherA[2] = {A1, A2};
        if (!apart) apart = oneSideOfPlane(V0, A1, A2, otherB, 2) || oneSideOfPlane(V0, B1, B2, otherA, 2);
        if (apart)
            hit = false;
        else
            hit = CGAL::do_intersect(K::Segment_3(a1, a2), K::Triangle_3(v, b1, b2)) ||
                  CGAL::do_intersect(K::Segment_3(b1, b2), K::Triangle_3(v, a1, a2));
    } else {
        hit = CGAL::do_intersect(K::Triangle_3(pt(a[0]), pt(a[1]), pt(a[2])),
                                 K::Triangle_3(pt(b[0]), pt(b[1]), pt(b[2])));
    }
    return hit;
}

SelfIntersections selfIntersections(const TriMesh& mesh, std::size_t limit) {
    SelfIntersections result;
    const auto& P = mesh.positions;
    std::vector<Box> boxes;
    boxes.reserve(mesh.triangles.size());
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
        const glm::uvec3 tri = mesh.triangles[t];
        if (tri.x >= P.size() || tri.y >= P.size() || tri.z >= P.size()) continue;
        if (tri.x == tri.y || tri.y == tri.z || tri.z == tri.x) continue;
        const Point a(P[tri.x].x, P[tri.x].y, P[tri.x].z), b(P[tri.y].x, P[tri.y].y, P[tri.y].z),
            c(P[tri.z].x, P[tri.z].y, P[tri.z].z);
        if (CGAL::collinear(a, b, c)) continue;
        const auto bb = a.bbox() + b.bbox() + c.bbox();
        boxes.emplace_back(bb, t);
    }
    std::vector<std::pair<std::size_t, std::size_t>> found;
    bool stop = false;
    auto test = [&](const Box& ba, const Box& bb) {
        if (stop) return;
        std::size_t s = ba.info(), t = bb.info();
        if (s > t) std::swap(s, t);
        const glm::uvec3 A = mesh.triangles[s], B = mesh.triangles[t];
        const std::array<glm::vec3, 3> pa{P[A.x], P[A.y], P[A.z]}, pb{P[B.x], P[B.y], P[B.z]};
        const bool hit = trianglesIntersect(pa, {A.x, A.y, A.z}, pb, {B.x, B.y, B.z});
        if (!hit) return;
        found.emplace_back(s, t);
        if (found.size() >= limit) stop = true;
    };
    CGAL::box_self_intersection_d<CGAL::Sequential_tag>(boxes.begin(), boxes.end(), test);
    result.pairs = found.size();
    result.limited = stop;
    if (!found.empty()) result.first = *std::min_element(found.begin(), found.end());
    return result;
}

}  // namespace isoforge::mesh
