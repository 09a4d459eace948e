/// @file OpenSCAD 2021.01's linear_extrude as a mesh (its GeometryEvaluator's extrudePolygon and
/// add_slice): the solid OpenSCAD makes for a twisted or unevenly scaled extrusion is a polyhedron
/// whose walls are straight between slices, which a continuous twist only approximates (a square
/// turned 45 degrees over one slice: 1.5% of its volume).

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>
#include <string>
#include <tuple>

#include "csg/profile.h"
#include "mesh/triangulate.h"

namespace isoforge::csg {

namespace {

/// OpenSCAD's sgn_vdiff: -1, 0 or 1 as |a| is shorter, about equal (10 ppm) or longer than |b|.
int lengthOrder(const glm::dvec2& a, const glm::dvec2& b) {
    const double l1 = glm::length(a), l2 = glm::length(b);
    return 2 * std::fabs(l1 - l2) * 1e5 > l1 + l2 ? (l1 < l2 ? -1 : 1) : 0;
}

double signedArea(const std::vector<glm::dvec2>& p) {
    double a = 0;
    for (std::size_t i = 0; i < p.size(); ++i) {
        const glm::dvec2 &u = p[i], &v = p[(i + 1) % p.size()];
        a += u.x * v.y - u.y * v.x;
    }
    return a / 2;
}

bool inside(const std::vector<glm::dvec2>& poly, const glm::dvec2& q) {
    bool in = false;
    for (std::size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
        const glm::dvec2 &a = poly[i], &b = poly[j];
        if ((a.y > q.y) != (b.y > q.y) && q.x < (b.x - a.x) * (q.y - a.y) / (b.y - a.y) + a.x) in = !in;
    }
    return in;
}

double archimedesLength(double a, double theta) {
    return 0.5 * a * (theta * std::sqrt(1 + theta * theta) + std::asinh(theta));
}

constexpr double kGridFine = 0.00000095367431640625;

}  // namespace

int openscadSlices(const Profile& p, const ExtrudeParams& e) {
    // In double, and clamped before the conversion: a hostile twist or $fn would overflow an int.
    auto count = [](double n) { return !(n >= 1.0) ? 1 : n >= kMaxSlices ? kMaxSlices : static_cast<int>(n); };
    const double fn = e.fn, fa = std::max(e.fa, 0.01), fs = std::max(e.fs, 0.01);
    if (e.twistDeg != 0) {
        double r2 = 0;
        for (const Outline2& o : p.outlines)
            for (const glm::dvec2& v : o.points) r2 = std::max(r2, glm::dot(v, v));
        const double twist = std::fabs(e.twistDeg);
        const double least = std::max(std::ceil(twist / 120.0), 1.0);
        const double r = std::sqrt(r2);
        if (r < kGridFine || std::isinf(fn) || std::isnan(fn)) return count(least);
        if (fn > 0) return count(std::max(std::ceil(twist / 360.0 * fn), least));
        const double byAngle = std::ceil(twist / fa);
        double length;
        if ((e.scale.x == 1.0 && e.scale.y == 1.0) || e.scale.x != e.scale.y) {
            // Calc::get_helix_slices: a helix of radius r.
            const double t = twist * M_PI / 180.0, c = e.height / t;
            length = t * std::sqrt(r2 + c * c);
        } else {
            // Calc::get_conical_helix_slices: an Archimedes spiral turned into a cone.
            const double s = e.scale.x, rads = twist * M_PI / 180.0;
            const double end = s > 1 ? rads * s / (s - 1) : rads / (1 - s), start = end - rads;
            const double a = r / end;
            const double spiral = archimedesLength(a, end) - archimedesLength(a, start);
            length = std::sqrt(spiral * spiral + e.height * e.height);
        }
        const double byLength = std::ceil(length / fs);
        return count(std::max(std::min(byAngle, byLength), least));
    }
    if (e.scale.x != e.scale.y) {  // Calc::get_diagonal_slices
        double d2 = 0;
        for (const Outline2& o : p.outlines)
            for (const glm::dvec2& v : o.points) {
                const glm::dvec2 d = v - v * e.scale;
                d2 = std::max(d2, glm::dot(d, d));
            }
        if (std::sqrt(d2) < kGridFine || std::isinf(fn) || std::isnan(fn)) return 1;
        if (fn > 0) return count(fn);
        return count(std::ceil(std::sqrt(d2 + e.height * e.height) / fs));
    }
    return 1;
}

double& maxExtrusionTriangles() {
    static double limit = 4e6;
    return limit;
}

mesh::TriMesh extrudeProfile(const Profile& p, const ExtrudeParams& e) {
    mesh::TriMesh m;
    if (!(e.height > 0) || p.outlines.empty()) return m;
    const int slices = e.slices > 0 ? e.slices : openscadSlices(p, e);
    std::size_t points = 0;
    for (const Outline2& o : p.outlines) points += o.points.size();
    if (double(slices) * double(points) * 2 > maxExtrusionTriangles())
        throw std::length_error(std::to_string(slices) + " slices of " + std::to_string(points) + " points make " +
                                std::to_string(std::size_t(2 * double(slices) * double(points))) +
                                " wall triangles; OpenSCAD's sliced mesh is built up to " +
                                std::to_string(std::size_t(maxExtrusionTriangles())));
    const double h1 = e.center ? -e.height / 2 : 0.0, h2 = e.center ? e.height / 2 : e.height;
    std::vector<std::size_t> offset;  // first vertex of each outline within a ring
    std::size_t ring = 0;
    for (const Outline2& o : p.outlines) {
        offset.push_back(ring);
        ring += o.points.size();
    }
    // Rings 0..slices: ring j turned by -twist * j / slices and scaled by lerp(1, scale, j / slices).
    std::vector<std::vector<glm::dvec2>> at(std::size_t(slices) + 1);
    std::vector<glm::dvec2> scales(std::size_t(slices) + 1);
    std::vector<double> rots(std::size_t(slices) + 1);
    for (int j = 0; j <= slices; ++j) {
        const double rot = e.twistDeg * j / slices;
        const glm::dvec2 s(1 - (1 - e.scale.x) * j / slices, 1 - (1 - e.scale.y) * j / slices);
        const double c = cosDegrees(-rot), sn = sinDegrees(-rot);
        const double z = h1 + (h2 - h1) * j / slices;
        rots[std::size_t(j)] = rot;
        scales[std::size_t(j)] = s;
        for (const Outline2& o : p.outlines)
            for (const glm::dvec2& v : o.points) {
                const glm::dvec2 q(s.x * (c * v.x - sn * v.y), s.y * (sn * v.x + c * v.y));
                at[std::size_t(j)].push_back(q);
                m.positions.emplace_back(float(q.x), float(q.y), float(z));
            }
    }
    auto id = [&](int j, std::size_t o, std::size_t i) { return unsigned(std::size_t(j) * ring + offset[o] + i); };
    auto tri = [&](unsigned a, unsigned b, unsigned c) { m.triangles.emplace_back(a, b, c); };

    // Walls (add_slice): OpenSCAD lists them clockwise seen from outside; ours run the other way.
    for (int j = 0; j < slices; ++j) {
        const glm::dvec2 s2 = scales[std::size_t(j) + 1];
        const bool anyZero = s2.x == 0 || s2.y == 0, anyNonZero = s2.x != 0 || s2.y != 0;
        const bool backTwist = rots[std::size_t(j) + 1] <= rots[std::size_t(j)];
        for (std::size_t o = 0; o < p.outlines.size(); ++o) {
            const std::size_t n = p.outlines[o].points.size();
            const bool flip = !p.outlines[o].positive != backTwist;
            for (std::size_t i = 1; i <= n; ++i) {
                const std::size_t a = i - 1, b = i % n;
                const unsigned prev1 = id(j, o, a), curr1 = id(j, o, b), prev2 = id(j + 1, o, a),
                               curr2 = id(j + 1, o, b);
                const glm::dvec2 &P1 = at[std::size_t(j)][offset[o] + a], &C1 = at[std::size_t(j)][offset[o] + b];
                const glm::dvec2 &P2 = at[std::size_t(j) + 1][offset[o] + a],
                                 &C2 = at[std::size_t(j) + 1][offset[o] + b];
                const int order = lengthOrder(P1 - C2, C1 - P2);
                const bool splitFirst = order == -1 || (order == 0 && !flip);
                const bool second = !anyZero || (anyNonZero && P2 != C2);
                if (splitFirst != anyZero) {
                    tri(prev1, curr1, curr2);
                    if (second) tri(curr2, prev2, prev1);
                } else {
                    tri(prev1, curr1, prev2);
                    if (second) tri(prev2, curr1, curr2);
                }
            }
        }
    }

    // Caps: each positive outline with the holes inside it, triangulated once on ring 0 (a turn and a
    // positive scale keep a triangulation valid) and reused on the top ring.
    std::vector<double> area(p.outlines.size());
    for (std::size_t o = 0; o < p.outlines.size(); ++o) area[o] = std::fabs(signedArea(p.outlines[o].points));
    std::vector<std::vector<std::vector<int>>> holes(p.outlines.size());
    for (std::size_t h = 0; h < p.outlines.size(); ++h) {
        if (p.outlines[h].positive || p.outlines[h].points.empty()) continue;
        std::size_t best = p.outlines.size();
        for (std::size_t o = 0; o < p.outlines.size(); ++o)
            if (p.outlines[o].positive && inside(p.outlines[o].points, p.outlines[h].points[0]) &&
                (best == p.outlines.size() || area[o] < area[best]))
                best = o;
        if (best == p.outlines.size()) continue;
        std::vector<int> loop;
        for (std::size_t i = 0; i < p.outlines[h].points.size(); ++i) loop.push_back(int(id(0, h, i)));
        holes[best].push_back(std::move(loop));
    }
    std::vector<glm::uvec3> cap;
    for (std::size_t o = 0; o < p.outlines.size(); ++o) {
        if (!p.outlines[o].positive) continue;
        std::vector<int> outer;
        for (std::size_t i = 0; i < p.outlines[o].points.size(); ++i) outer.push_back(int(id(0, o, i)));
        for (const glm::uvec3& t : mesh::triangulateRegionXY(m.positions, outer, holes[o])) cap.push_back(t);
    }
    const bool top = e.scale.x > 0 && e.scale.y > 0;
    const unsigned up = unsigned(std::size_t(slices) * ring);
    for (const glm::uvec3& t : cap) {
        tri(t.x, t.z, t.y);  // the bottom faces down
        if (top) tri(t.x + up, t.y + up, t.z + up);
    }
    // Points at one place (a scale of 0 pinches the top ring to a line or a point) become one
    // vertex, as OpenSCAD's conversion merges them; triangles left naming one vertex twice go.
    std::map<std::tuple<float, float, float>, unsigned> seen;
    std::vector<unsigned> remap(m.positions.size());
    std::vector<glm::vec3> unique;
    for (std::size_t i = 0; i < m.positions.size(); ++i) {
        const glm::vec3& q = m.positions[i];
        remap[i] = seen.try_emplace({q.x, q.y, q.z}, unsigned(unique.size())).first->second;
        if (remap[i] == unique.size()) unique.push_back(q);
    }
    std::vector<glm::uvec3> kept;
    for (const glm::uvec3& t : m.triangles) {
        const glm::uvec3 u(remap[t.x], remap[t.y], remap[t.z]);
        if (u.x != u.y && u.y != u.z && u.z != u.x) kept.push_back(u);
    }
    m.positions = std::move(unique);
    m.triangles = std::move(kept);
    return m;
}

}  // namespace isoforge::csg
