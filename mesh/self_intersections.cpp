// Built alone into isoforge_mesh_exact: CGAL's headers are heavy and want -frounding-math.
#include "mesh/self_intersections.h"

#include <algorithm>
#include <array>
#include <vector>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/box_intersection_d.h>
#include <CGAL/intersections.h>

namespace isoforge::mesh {

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = K::Point_3;
using Box = CGAL::Box_intersection_d::Box_with_info_d<double, 3, std::size_t>;

}  // namespace

SelfIntersections selfIntersections(const TriMesh& mesh, std::size_t limit) {
    SelfIntersections result;
    const auto& P = mesh.positions;
    std::vector<Point> points;
    points.reserve(P.size());
    for (const auto& p : P) points.emplace_back(p.x, p.y, p.z);
    std::vector<Box> boxes;
    boxes.reserve(mesh.triangles.size());
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
        const glm::uvec3 tri = mesh.triangles[t];
        if (tri.x >= P.size() || tri.y >= P.size() || tri.z >= P.size()) continue;
        if (tri.x == tri.y || tri.y == tri.z || tri.z == tri.x) continue;
        const Point &a = points[tri.x], &b = points[tri.y], &c = points[tri.z];
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
        std::array<unsigned, 3> a{A.x, A.y, A.z}, b{B.x, B.y, B.z};
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
            const Point& p = points[a[(ra + 1) % 3]];
            const Point& q = points[a[(ra + 2) % 3]];
            const Point& r = points[a[ra]];
            const Point& s2 = points[b[rb]];
            hit = CGAL::coplanar(p, q, r, s2) && CGAL::coplanar_orientation(p, q, r, s2) == CGAL::POSITIVE;
        } else if (shared == 1) {
            const Point& v = points[a[ia]];
            const Point &a1 = points[a[(ia + 1) % 3]], &a2 = points[a[(ia + 2) % 3]];
            const Point &b1 = points[b[(ib + 1) % 3]], &b2 = points[b[(ib + 2) % 3]];
            hit = CGAL::do_intersect(K::Segment_3(a1, a2), K::Triangle_3(v, b1, b2)) ||
                  CGAL::do_intersect(K::Segment_3(b1, b2), K::Triangle_3(v, a1, a2));
        } else {
            hit = CGAL::do_intersect(K::Triangle_3(points[a[0]], points[a[1]], points[a[2]]),
                                     K::Triangle_3(points[b[0]], points[b[1]], points[b[2]]));
        }
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
