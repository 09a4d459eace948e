#include "csg/parts.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

#include "csg/nodes.h"
#include "csg/polytope.h"
#include "csg/profile.h"
#include "implicit/primitives.h"

namespace isoforge::csg {

namespace {

using Polygon = std::vector<glm::dvec3>;

/// Past this a hostile or absurd model is refused rather than left to run for minutes: the polygons
/// covering a difference (each subtracted part can split a polygon into one piece per face). Point
/// sums of one pair of convex parts have their bound in maxMinkowskiSums() (two 96-sided spheres make
/// 21 million).
constexpr std::size_t kMaxCoverPieces = 500'000;

/// OpenSCAD's generate_circle: `n` points of radius r, the first on +x, at its exact degree trigonometry.
void circle(std::vector<glm::dvec3>& out, double r, int n, double z) {
    for (int i = 0; i < n; ++i) {
        const double phi = 360.0 * i / n;
        out.emplace_back(r * cosDegrees(phi), r * sinDegrees(phi), z);
    }
}
Parts convexOf(std::vector<glm::dvec3> points) {
    Parts p;
    p.parts.push_back({std::move(points), {}, nullptr, nullptr});
    return p;
}

/// A convex part as half-spaces n . x <= d (unit normals), its triangles and its box.
struct Convex {
    std::vector<glm::dvec3> n;
    std::vector<double> d;
    std::vector<Polygon> faces;
    glm::dvec3 lo{INFINITY}, hi{-INFINITY};
    bool empty() const { return faces.empty(); }
};
/// The hull of a convex part: the one it keeps, or computed.
std::shared_ptr<const mesh::ConvexHull> hullOf(const Part& p) {
    return p.hull ? p.hull : std::make_shared<const mesh::ConvexHull>(mesh::convexHull(p.points));
}

Convex convexOfPart(const Part& p) {
    Convex c;
    const auto kept = hullOf(p);
    const mesh::ConvexHull& h = *kept;
    for (const glm::uvec3& t : h.triangles) {
        const glm::dvec3 a = h.points[t.x], b = h.points[t.y], q = h.points[t.z];
        const glm::dvec3 n = glm::cross(b - a, q - a);
        const double len = glm::length(n);
        if (!(len > 0)) continue;
        c.n.push_back(n / len);
        c.d.push_back(glm::dot(n / len, a));
        c.faces.push_back({a, b, q});
    }
    for (const glm::dvec3& q : h.points) {
        c.lo = glm::min(c.lo, q);
        c.hi = glm::max(c.hi, q);
    }
    return c;
}

/// The tolerance of "on a plane" for coordinates up to `scale`.
double tolerance(double scale) {
    return 1e-9 * std::max(scale, 1.0);
}
double extent(const Parts& p) {
    double e = 0;
    for (const Part& part : p.parts) {
        for (const glm::dvec3& q : part.points) e = std::max({e, std::abs(q.x), std::abs(q.y), std::abs(q.z)});
        for (const Polygon& poly : part.cover)
            for (const glm::dvec3& q : poly) e = std::max({e, std::abs(q.x), std::abs(q.y), std::abs(q.z)});
    }
    return e;
}

/// Sutherland-Hodgman: the part of a convex polygon where n . x <= d (within eps).
Polygon clip(const Polygon& p, const glm::dvec3& n, double d, double eps) {
    Polygon out;
    for (std::size_t i = 0; i < p.size(); ++i) {
        const glm::dvec3 &a = p[i], &b = p[(i + 1) % p.size()];
        const double da = glm::dot(n, a) - d, db = glm::dot(n, b) - d;
        const bool ina = da <= eps, inb = db <= eps;
        if (ina) out.push_back(a);
        if (ina != inb && (da < -eps || db < -eps)) out.push_back(a + (b - a) * (da / (da - db)));
    }
    return out;
}
bool hasArea(const Polygon& p, double eps) {
    if (p.size() < 3) return false;
    glm::dvec3 s(0.0);
    for (std::size_t i = 1; i + 1 < p.size(); ++i) s += glm::cross(p[i] - p[0], p[i + 1] - p[0]);
    return glm::length(s) > eps * eps;
}
/// The (Newell) normal of a polygon, not normalized: its orientation.
glm::dvec3 normalOf(const Polygon& p) {
    glm::dvec3 n(0.0);
    for (std::size_t i = 0; i < p.size(); ++i) {
        const glm::dvec3 &a = p[i], &b = p[(i + 1) % p.size()];
        n += glm::dvec3((a.y - b.y) * (a.z + b.z), (a.z - b.z) * (a.x + b.x), (a.x - b.x) * (a.y + b.y));
    }
    return n;
}
/// Whether the polygon lies on the plane n . x = d with its normal the same way as n.
bool onPlaneAlike(const Polygon& p, const glm::dvec3& n, double d, double eps) {
    for (const glm::dvec3& q : p)
        if (std::abs(glm::dot(n, q) - d) > eps) return false;
    return glm::dot(normalOf(p), n) > 0;
}
/// The convex polygon (a face of B, `n` its outward normal) clipped to the inside of a convex part
/// A; nothing where it lies on a face of A that faces the same way (A - B regularized keeps no
/// boundary there: B is on the inner side, nothing of A on the outer).
Polygon clipTo(Polygon p, const Convex& c, double eps, bool regularized = true) {
    for (std::size_t j = 0; j < c.n.size() && p.size() >= 3; ++j) {
        if (regularized && onPlaneAlike(p, c.n[j], c.d[j], eps)) return {};
        p = clip(p, c.n[j], c.d[j], eps);
    }
    return p;
}
/// Pieces (oriented outward from A - B) minus the interior of a convex part: a piece outside one
/// of its planes stays as it is, one across it becomes its parts outside each plane (overlapping
/// convex pieces), one inside goes. A piece on a face of the part that faces the same way is not
/// outside that face (regularized booleans: the part removes the boundary there).
void subtract(std::vector<Polygon>& pieces, const Convex& b, double eps) {
    std::vector<Polygon> out;
    for (Polygon& p : pieces) {
        glm::dvec3 lo(INFINITY), hi(-INFINITY);
        for (const glm::dvec3& q : p) lo = glm::min(lo, q), hi = glm::max(hi, q);
        bool apart = glm::any(glm::lessThan(hi, b.lo - eps)) || glm::any(glm::greaterThan(lo, b.hi + eps));
        std::vector<bool> alike(b.n.size());
        for (std::size_t j = 0; j < b.n.size() && !apart; ++j) {
            alike[j] = onPlaneAlike(p, b.n[j], b.d[j], eps);
            bool outside = !alike[j];
            for (const glm::dvec3& q : p) outside = outside && glm::dot(b.n[j], q) - b.d[j] >= -eps;
            apart = outside;
        }
        if (apart) {
            out.push_back(std::move(p));
            continue;
        }
        for (std::size_t j = 0; j < b.n.size(); ++j) {
            if (alike[j]) continue;
            Polygon q = clip(p, -b.n[j], -b.d[j], eps);
            if (hasArea(q, eps)) out.push_back(std::move(q));
        }
    }
    pieces = std::move(out);
}

std::vector<glm::dvec3> sums(const std::vector<glm::dvec3>& a, const std::vector<glm::dvec3>& b) {
    if (double(a.size()) * double(b.size()) > double(maxMinkowskiSums()))
        throw std::invalid_argument("minkowski() of parts of " + std::to_string(a.size()) + " and " +
                                    std::to_string(b.size()) + " vertices: more than " +
                                    std::to_string(maxMinkowskiSums()) + " sums (use fewer facets: $fn)");
    std::vector<glm::dvec3> s;
    s.reserve(a.size() * b.size());
    for (const glm::dvec3& p : a)
        for (const glm::dvec3& q : b) s.push_back(p + q);
    return s;
}
/// The convex part of the hull of the points, if it has a volume.
void addHull(Parts& out, const std::vector<glm::dvec3>& points) {
    auto h = std::make_shared<const mesh::ConvexHull>(mesh::convexHull(points));
    if (!h->empty()) out.parts.push_back({h->points, {}, nullptr, h});
}

}  // namespace

Parts cubeParts(glm::dvec3 size, bool center) {
    const glm::dvec3 lo = center ? -0.5 * size : glm::dvec3(0.0);
    std::vector<glm::dvec3> c;
    for (int i = 0; i < 8; ++i)
        c.push_back(lo + glm::dvec3(i & 1 ? size.x : 0.0, i & 2 ? size.y : 0.0, i & 4 ? size.z : 0.0));
    return convexOf(std::move(c));
}

Parts sphereParts(double r, int fragments) {
    // primitives.cc: (fragments + 1) / 2 rings at polar angles 180 (i + 0.5) / rings.
    const int rings = (fragments + 1) / 2;
    if (double(rings) * fragments > 4e6)
        throw std::invalid_argument("a sphere of " + std::to_string(fragments) + " fragments has " +
                                    std::to_string(std::int64_t(rings) * fragments) +
                                    " vertices: more than 4 million for hull() or minkowski()");
    std::vector<glm::dvec3> c;
    for (int i = 0; i < rings; ++i) {
        const double phi = 180.0 * (i + 0.5) / rings;
        circle(c, r * sinDegrees(phi), fragments, r * cosDegrees(phi));
    }
    return convexOf(std::move(c));
}

Parts cylinderParts(double r1, double r2, double h, bool center, int fragments) {
    const double z1 = center ? -h / 2 : 0.0, z2 = center ? h / 2 : h;
    std::vector<glm::dvec3> c;
    if (r1 > 0)
        circle(c, r1, fragments, z1);
    else
        c.emplace_back(0.0, 0.0, z1);
    if (r2 > 0)
        circle(c, r2, fragments, z2);
    else
        c.emplace_back(0.0, 0.0, z2);
    return convexOf(std::move(c));
}

Parts meshParts(std::vector<glm::dvec3> points, const std::vector<glm::uvec3>& triangles, implicit::FieldPtr solid) {
    // A mesh file is not a hand-written convex piece: not worth the hull.
    if (points.size() <= 20000) {
        const mesh::ConvexHull h = mesh::convexHull(points);
        double v = 0;
        for (const glm::uvec3& t : triangles) v += glm::dot(points[t.x], glm::cross(points[t.y], points[t.z])) / 6.0;
        const double hv = mesh::volume(h);
        if (!h.empty() && std::abs(hv - std::abs(v)) <= 1e-9 * hv) return convexOf(h.points);  // its own hull
    }
    Part m;
    m.solid = std::move(solid);
    for (const glm::uvec3& t : triangles) m.cover.push_back({points[t.x], points[t.y], points[t.z]});
    Parts p;
    p.parts.push_back(std::move(m));
    return p;
}

Parts pointParts(std::vector<glm::dvec3> points) {
    return convexOf(std::move(points));
}

Parts transformParts(Parts p, const glm::dmat4& m) {
    auto move = [&](glm::dvec3& q) { q = glm::dvec3(m * glm::dvec4(q, 1.0)); };
    for (Part& part : p.parts) {
        std::for_each(part.points.begin(), part.points.end(), move);
        for (Polygon& poly : part.cover) std::for_each(poly.begin(), poly.end(), move);
        if (part.solid) part.solid = implicit::makeTransformed(part.solid, glm::mat4(m));
        part.hull.reset();  // rounded, the moved points may not be exactly convex: hulled again
    }
    return p;
}

Parts uniteParts(const std::vector<const Parts*>& kids) {
    Parts out;
    for (const Parts* k : kids) out.parts.insert(out.parts.end(), k->parts.begin(), k->parts.end());
    return out;
}

std::optional<Parts> differenceParts(const std::vector<const Parts*>& kids, implicit::FieldPtr solid) {
    if (kids.empty()) return std::nullopt;
    std::vector<Convex> minus;
    double scale = extent(*kids[0]);
    for (std::size_t i = 1; i < kids.size(); ++i) {
        for (const Part& p : kids[i]->parts) {
            if (!p.convex()) return std::nullopt;
            minus.push_back(convexOfPart(p));
            if (minus.back().empty()) minus.pop_back();
        }
        scale = std::max(scale, extent(*kids[i]));
    }
    if (minus.empty()) return *kids[0];
    const double eps = tolerance(scale);
    // The boundary of A - B lies in (the boundary of A outside B) and (the boundary of B inside A).
    std::vector<Convex> first;
    std::vector<Polygon> pieces;
    for (const Part& p : kids[0]->parts) {
        if (!p.convex()) return std::nullopt;
        first.push_back(convexOfPart(p));
        pieces.insert(pieces.end(), first.back().faces.begin(), first.back().faces.end());
    }
    for (const Convex& b : minus) {
        subtract(pieces, b, eps);
        if (pieces.size() > kMaxCoverPieces) return std::nullopt;
    }
    for (std::size_t k = 0; k < minus.size(); ++k)
        for (const Polygon& face : minus[k].faces)
            for (const Convex& a : first) {
                std::vector<Polygon> inside{clipTo(face, a, eps)};
                if (!hasArea(inside[0], eps)) continue;
                std::reverse(inside[0].begin(), inside[0].end());  // outward from A - B
                for (std::size_t m = 0; m < minus.size(); ++m)
                    if (m != k) subtract(inside, minus[m], eps);
                pieces.insert(pieces.end(), inside.begin(), inside.end());
                if (pieces.size() > kMaxCoverPieces) return std::nullopt;
            }
    Parts out;
    if (pieces.empty()) return out;  // nothing left
    out.parts.push_back({{}, std::move(pieces), std::move(solid), nullptr});
    return out;
}

std::optional<Parts> intersectionParts(const std::vector<const Parts*>& kids) {
    if (kids.empty()) return std::nullopt;
    for (const Parts* k : kids)
        for (const Part& p : k->parts)
            if (!p.convex()) return std::nullopt;
    Parts acc = *kids[0];
    for (std::size_t i = 1; i < kids.size(); ++i) {
        const double eps = tolerance(std::max(extent(acc), extent(*kids[i])));
        Parts next;
        for (const Part& pa : acc.parts)
            for (const Part& pb : kids[i]->parts) {
                // The vertices of A n B are on the faces of A inside B or on the faces of B inside A.
                const Convex a = convexOfPart(pa), b = convexOfPart(pb);
                std::vector<glm::dvec3> pts;
                for (const Polygon& f : a.faces)
                    for (const glm::dvec3& q : clipTo(f, b, eps, false)) pts.push_back(q);
                for (const Polygon& f : b.faces)
                    for (const glm::dvec3& q : clipTo(f, a, eps, false)) pts.push_back(q);
                addHull(next, pts);
            }
        acc = std::move(next);
    }
    return acc;
}

std::size_t& maxMinkowskiSums() {
    static std::size_t limit = 25'000'000;
    return limit;
}

mesh::ConvexHull hullOfParts(const Parts& p) {
    std::vector<glm::dvec3> all;
    for (const Part& part : p.parts) {
        all.insert(all.end(), part.points.begin(), part.points.end());
        for (const Polygon& poly : part.cover) all.insert(all.end(), poly.begin(), poly.end());
    }
    // Cover polygons share their corners (a difference's pieces overlap, each clip computing the corner
    // anew, a few ulps apart): each point once, on a grid of the parts' tolerance, sorted (a hull's input
    // order decides nothing but its time). Points a few ulps apart or off a plane cost CGAL its exact
    // predicates: 124,640 corners of a 97-gon frustum less a 96-gon cylinder are 18,868 distinct ones
    // and 9,488 on the grid (1.9 s -> 0.19 s).
    const double q = tolerance(extent(p));
    for (glm::dvec3& a : all) a = glm::round(a / q) * q;
    std::sort(all.begin(), all.end(), [](const glm::dvec3& a, const glm::dvec3& b) {
        return a.x != b.x ? a.x < b.x : a.y != b.y ? a.y < b.y : a.z < b.z;
    });
    all.erase(std::unique(all.begin(), all.end()), all.end());
    return mesh::convexHull(all);
}

Parts minkowskiParts(const Parts& a, const Parts& b, std::size_t maxHulls) {
    Parts out;
    std::size_t hulls = 0;
    for (const Part& pa : a.parts)
        for (const Part& pb : b.parts) {
            if (pa.convex() && pb.convex()) {
                ++hulls;
                addHull(out, sums(pa.points, pb.points));
                continue;
            }
            if (!pa.convex() && !pb.convex())
                throw std::invalid_argument(
                    "minkowski() of two objects that are both not convex (polyhedra, extrusions or "
                    "differences) is not supported");
            const Part& x = pa.convex() ? pb : pa;
            const Part& c = pa.convex() ? pa : pb;
            if (c.points.empty()) continue;
            hulls += x.cover.size();
            if (hulls > maxHulls)
                throw std::invalid_argument("minkowski() would take more than " + std::to_string(maxHulls) +
                                            " convex pieces (an object of many faces with another one)");
            Part moved = x;
            for (Polygon& poly : moved.cover)
                for (glm::dvec3& q : poly) q += c.points.front();
            moved.solid = implicit::makeTranslated(x.solid, glm::vec3(c.points.front()));
            out.parts.push_back(std::move(moved));
            for (const Polygon& poly : x.cover) addHull(out, sums(poly, c.points));
        }
    return out;
}

implicit::FieldPtr partsField(const Parts& p, const std::string& what) {
    std::vector<implicit::FieldPtr> fields;
    for (const Part& part : p.parts) {
        if (!part.convex()) {
            fields.push_back(part.solid);
            continue;
        }
        const auto h = hullOf(part);
        if (!h->empty()) fields.push_back(makeConvexPolytope(*h, what));
    }
    if (fields.empty()) return nullptr;
    return fields.size() == 1 ? fields[0] : makeUnion(std::move(fields));
}

}  // namespace isoforge::csg
