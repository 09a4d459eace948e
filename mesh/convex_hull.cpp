// Built into isoforge_mesh_exact with the other CGAL users: CGAL's headers stay in this library.
#include "mesh/convex_hull.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/convex_hull_3.h>
#include <glm/geometric.hpp>

namespace isoforge::mesh {

namespace {
using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = K::Point_3;

/// Whether the points span three dimensions: two distinct points, a third off their line, a
/// fourth off their plane (exact predicates).
bool spansSpace(const std::vector<Point>& p) {
    std::size_t i = 1;
    while (i < p.size() && p[i] == p[0]) ++i;
    if (i == p.size()) return false;
    std::size_t j = i + 1;
    while (j < p.size() && CGAL::collinear(p[0], p[i], p[j])) ++j;
    if (j >= p.size()) return false;
    for (std::size_t k = j + 1; k < p.size(); ++k)
        if (CGAL::orientation(p[0], p[i], p[j], p[k]) != CGAL::COPLANAR) return true;
    return false;
}
}  // namespace

ConvexHull convexHull(std::span<const glm::dvec3> points) {
    std::vector<Point> p;
    p.reserve(points.size());
    for (const glm::dvec3& q : points) p.emplace_back(q.x, q.y, q.z);
    ConvexHull out;
    if (p.size() < 4 || !spansSpace(p)) return out;
    CGAL::Surface_mesh<Point> sm;
    CGAL::convex_hull_3(p.begin(), p.end(), sm);
    out.points.reserve(sm.number_of_vertices());
    for (auto v : sm.vertices()) {
        const Point& q = sm.point(v);
        out.points.emplace_back(q.x(), q.y(), q.z());
    }
    out.triangles.reserve(sm.number_of_faces());
    for (auto f : sm.faces()) {
        glm::uvec3 t(0);
        int k = 0;
        for (auto v : CGAL::vertices_around_face(sm.halfedge(f), sm))
            if (k < 3) t[k++] = static_cast<unsigned>(v.idx());
        out.triangles.push_back(t);
    }
    return out;
}

double volume(const ConvexHull& h) {
    double v = 0;
    for (const glm::uvec3& t : h.triangles) v += glm::dot(h.points[t.x], glm::cross(h.points[t.y], h.points[t.z]));
    return v / 6.0;
}

}  // namespace isoforge::mesh
