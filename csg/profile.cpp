#include "csg/profile.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include <glm/geometric.hpp>
#include <polyclipping/clipper.hpp>

#include "mesh/triangulate.h"

// Why Clipper: OpenSCAD 2021.01 makes every 2D boolean with Clipper 6.4 (Debian's libpolyclipping is
// that version) on coordinates scaled by 2^16 and truncated to integers; using the same library the
// same way gives its outlines, vertex for vertex, and so the walls an extrusion builds on them.

namespace isoforge::csg {

namespace {

constexpr double kClipperScale = 65536.0;  // OpenSCAD's CLIPPER_SCALE (1 << 16)

/// OpenSCAD converts with IntPoint(cInt, cInt): truncation toward zero. A coordinate past Clipper's
/// range (2^62 - 1 after scaling), or NaN, becomes 2^62 with its sign, which Clipper's own range check
/// refuses as it refuses any coordinate past it (converting a larger one to an integer is undefined).
ClipperLib::cInt toClipper(double v) {
    constexpr double kPast = 4611686018427387904.0;  // 2^62
    const double scaled = v * kClipperScale;
    if (!(std::abs(scaled) < kPast)) return static_cast<ClipperLib::cInt>(scaled < 0 ? -kPast : kPast);
    return static_cast<ClipperLib::cInt>(scaled);
}

ClipperLib::Path toPath(const Outline2& o, bool keepOrientation) {
    ClipperLib::Path p;
    p.reserve(o.points.size());
    for (const glm::dvec2& v : o.points) p.emplace_back(toClipper(v.x), toClipper(v.y));
    if (!keepOrientation && !ClipperLib::Orientation(p)) std::reverse(p.begin(), p.end());
    return p;
}

ClipperLib::Paths toPaths(const Profile& p) {
    ClipperLib::Paths out;
    for (const Outline2& o : p.outlines) out.push_back(toPath(o, p.sanitized));
    return out;
}

/// OpenSCAD's ClipperUtils::toPolygon2d: each contour of the tree, its sign from its orientation,
/// cleaned (CleanPolygon), kept if 3 points are left.
Profile fromTree(const ClipperLib::PolyTree& tree) {
    Profile out;
    for (const ClipperLib::PolyNode* node = tree.GetFirst(); node; node = node->GetNext()) {
        ClipperLib::Path cleaned;
        ClipperLib::CleanPolygon(node->Contour, cleaned);
        if (cleaned.size() < 3) continue;
        Outline2 o;
        o.positive = ClipperLib::Orientation(node->Contour);
        for (const ClipperLib::IntPoint& q : cleaned)
            o.points.emplace_back(double(q.X) / kClipperScale, double(q.Y) / kClipperScale);
        out.outlines.push_back(std::move(o));
    }
    out.sanitized = true;
    return out;
}

/// OpenSCAD's ClipperUtils::sanitize: a union of the paths under the even-odd rule.
ClipperLib::PolyTree sanitizeTree(const ClipperLib::Paths& paths) {
    ClipperLib::PolyTree tree;
    ClipperLib::Clipper c;
    try {
        c.AddPaths(paths, ClipperLib::ptSubject, true);
    } catch (...) {
        // Clipper's range check (coordinates beyond 2^62 / 2^16): OpenSCAD skips the polygon too.
        return tree;
    }
    c.Execute(ClipperLib::ctUnion, tree, ClipperLib::pftEvenOdd);
    return tree;
}

/// The paths of a profile for a boolean: as they are if sanitized, else sanitized first.
ClipperLib::Paths clipperPaths(const Profile& p) {
    ClipperLib::Paths paths = toPaths(p);
    if (!p.sanitized) ClipperLib::PolyTreeToPaths(sanitizeTree(paths), paths);
    return paths;
}

Profile sanitize(const Profile& p) {
    return fromTree(sanitizeTree(toPaths(p)));
}

/// x reduced to [0, 360), NaN for huge angles (OpenSCAD's TRIG_HUGE_VAL).
double reduceDegrees(double x) {
    if (x < 360.0 && x >= 0.0) return x;
    constexpr double huge = double(1LL << 26) * 360.0 * double(1LL << 26);
    if (!(x < huge && x > -huge)) return std::numeric_limits<double>::quiet_NaN();
    return x - 360.0 * std::floor(x / 360.0);
}

constexpr double kDegToRad = M_PI / 180.0;
constexpr double kSqrt3_4 = 0.86602540378443859659;

}  // namespace

double sinDegrees(double x) {
    x = reduceDegrees(x);
    if (std::isnan(x)) return x;
    const bool oppose = x >= 180.0;
    if (oppose) x -= 180.0;
    if (x > 90.0) x = 180.0 - x;
    if (x < 45.0)
        x = x == 30.0 ? 0.5 : std::sin(x * kDegToRad);
    else if (x == 45.0)
        x = M_SQRT1_2;
    else if (x == 60.0)
        x = kSqrt3_4;
    else
        x = std::cos((90.0 - x) * kDegToRad);
    return oppose ? -x : x;
}

double cosDegrees(double x) {
    x = reduceDegrees(x);
    if (std::isnan(x)) return x;
    bool oppose = x >= 180.0;
    if (oppose) x -= 180.0;
    if (x > 90.0) {
        x = 180.0 - x;
        oppose = !oppose;
    }
    if (x > 45.0)
        x = x == 60.0 ? 0.5 : std::sin((90.0 - x) * kDegToRad);
    else if (x == 45.0)
        x = M_SQRT1_2;
    else if (x == 30.0)
        x = kSqrt3_4;
    else
        x = std::cos(x * kDegToRad);
    return oppose ? -x : x;
}

Profile circleProfile(double r, int n) {
    Profile p;
    if (!(r > 0) || std::isinf(r) || n < 3) return p;
    Outline2 o;
    o.points.resize(std::size_t(n));
    for (int i = 0; i < n; ++i) {
        const double phi = (360.0 * i) / n;
        o.points[std::size_t(i)] = glm::dvec2(r * cosDegrees(phi), r * sinDegrees(phi));
    }
    p.outlines.push_back(std::move(o));
    return p;
}

Profile squareProfile(glm::dvec2 size, bool center) {
    Profile p;
    if (!(size.x > 0 && size.y > 0) || std::isinf(size.x) || std::isinf(size.y)) return p;
    glm::dvec2 lo(0.0), hi = size;
    if (center) {
        lo -= size / 2.0;
        hi -= size / 2.0;
    }
    p.outlines.push_back({{lo, {hi.x, lo.y}, hi, {lo.x, hi.y}}, true});
    return p;
}

Profile polygonProfile(const std::vector<glm::dvec2>& points, const std::vector<std::vector<int>>& paths) {
    Profile raw;
    raw.sanitized = false;
    if (paths.empty()) {
        if (points.size() > 2) raw.outlines.push_back({points, true});
    } else {
        for (const auto& path : paths) {
            Outline2 o;
            for (int i : path)
                if (i >= 0 && std::size_t(i) < points.size()) o.points.push_back(points[std::size_t(i)]);
            raw.outlines.push_back(std::move(o));
        }
    }
    return sanitize(raw);
}

Profile transformProfile(Profile p, const glm::dmat4& m) {
    // OpenSCAD's Transform2d: rows (m00 m01 m03), (m10 m11 m13) of the 3D matrix.
    for (Outline2& o : p.outlines)
        for (glm::dvec2& v : o.points)
            v = glm::dvec2(m[0][0] * v.x + m[1][0] * v.y + m[3][0], m[0][1] * v.x + m[1][1] * v.y + m[3][1]);
    const double det = m[0][0] * m[1][1] - m[1][0] * m[0][1];
    if (p.sanitized && det <= 0) return sanitize(p);  // a mirror turns the outlines the wrong way
    return p;
}

Profile combineProfiles(const std::vector<const Profile*>& children, ProfileOp op) {
    if (children.empty()) return {};
    if (children.size() == 1) return *children[0];
    std::vector<ClipperLib::Paths> sets;
    for (const Profile* c : children) sets.push_back(clipperPaths(*c));
    ClipperLib::Clipper clipper;
    ClipperLib::PolyTree result;
    try {
        if (op == ProfileOp::Intersection) {
            // A sequence of binary intersections, as OpenSCAD does them.
            ClipperLib::Paths source = sets[0];
            for (std::size_t i = 1; i < sets.size(); ++i) {
                clipper.AddPaths(source, ClipperLib::ptSubject, true);
                clipper.AddPaths(sets[i], ClipperLib::ptClip, true);
                clipper.Execute(ClipperLib::ctIntersection, result, ClipperLib::pftNonZero, ClipperLib::pftNonZero);
                if (i + 1 != sets.size()) {
                    ClipperLib::PolyTreeToPaths(result, source);
                    clipper.Clear();
                }
            }
            return fromTree(result);
        }
        for (std::size_t i = 0; i < sets.size(); ++i)
            clipper.AddPaths(sets[i], i == 0 ? ClipperLib::ptSubject : ClipperLib::ptClip, true);
        clipper.Execute(op == ProfileOp::Union ? ClipperLib::ctUnion : ClipperLib::ctDifference, result,
                        ClipperLib::pftNonZero, ClipperLib::pftNonZero);
    } catch (...) {
        return {};  // Clipper's range check: nothing, as OpenSCAD gets
    }
    return fromTree(result);
}

Profile uniteProfiles(const std::vector<const Profile*>& children) {
    ClipperLib::Clipper clipper;
    ClipperLib::PolyTree result;
    try {
        for (std::size_t i = 0; i < children.size(); ++i)
            clipper.AddPaths(clipperPaths(*children[i]), i == 0 ? ClipperLib::ptSubject : ClipperLib::ptClip, true);
        clipper.Execute(ClipperLib::ctUnion, result, ClipperLib::pftNonZero, ClipperLib::pftNonZero);
    } catch (...) {
        return {};  // Clipper's range check
    }
    return fromTree(result);
}

Profile offsetProfile(const Profile& p, double delta, OffsetJoin join, double arcTolerance) {
    // OpenSCAD's ClipperUtils::applyOffset: ClipperOffset with a miter limit of 10^6 (no mitre
    // chamfers), its arc tolerance scaled to Clipper's integers, closed polygons.
    ClipperLib::ClipperOffset co(1000000.0, arcTolerance * kClipperScale);
    const ClipperLib::JoinType j = join == OffsetJoin::Round   ? ClipperLib::jtRound
                                   : join == OffsetJoin::Miter ? ClipperLib::jtMiter
                                                               : ClipperLib::jtSquare;
    ClipperLib::PolyTree result;
    try {
        co.AddPaths(toPaths(p), j, ClipperLib::etClosedPolygon);
        co.Execute(result, delta * kClipperScale);
    } catch (...) {
        return {};  // Clipper's range check
    }
    return fromTree(result);
}

Profile hullProfile(const std::vector<const Profile*>& children) {
    // OpenSCAD's applyHull2D: the hull of every vertex (CGAL's convex_hull_2; here Andrew's monotone
    // chain, which gives the same polygon), one counter-clockwise outline.
    std::vector<glm::dvec2> pts;
    for (const Profile* c : children)
        for (const Outline2& o : c->outlines) pts.insert(pts.end(), o.points.begin(), o.points.end());
    std::sort(pts.begin(), pts.end(),
              [](const glm::dvec2& a, const glm::dvec2& b) { return a.x < b.x || (a.x == b.x && a.y < b.y); });
    pts.erase(std::unique(pts.begin(), pts.end()), pts.end());
    Profile out;
    if (pts.size() < 3) return out;
    auto cross = [](const glm::dvec2& o, const glm::dvec2& a, const glm::dvec2& b) {
        return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
    };
    std::vector<glm::dvec2> h(2 * pts.size());
    std::size_t k = 0;
    for (std::size_t i = 0; i < pts.size(); ++i) {  // lower chain
        while (k >= 2 && cross(h[k - 2], h[k - 1], pts[i]) <= 0) --k;
        h[k++] = pts[i];
    }
    for (std::size_t i = pts.size() - 1, lower = k + 1; i-- > 0;) {  // upper chain
        while (k >= lower && cross(h[k - 2], h[k - 1], pts[i]) <= 0) --k;
        h[k++] = pts[i];
    }
    h.resize(k - 1);
    if (h.size() < 3) return out;
    out.outlines.push_back({std::move(h), true});
    return sanitize(out);
}

Profile minkowskiProfile(const std::vector<const Profile*>& children) {
    // OpenSCAD's ClipperUtils::applyMinkowski: for each pair of outlines the quads that sweep each
    // edge of one along each edge of the other, then each outline moved by a point of each positive
    // outline of the other (the insides), united under the non-zero rule, child after child.
    if (children.empty()) return {};
    if (children.size() == 1) return *children[0];
    auto insides = [](const ClipperLib::Paths& a, const ClipperLib::Paths& b, ClipperLib::Paths& target) {
        for (const ClipperLib::Path& bp : b) {
            if (bp.empty() || !ClipperLib::Orientation(bp)) continue;
            for (const ClipperLib::Path& ap : a) {
                target.push_back(ap);
                for (ClipperLib::IntPoint& q : target.back()) q.X += bp[0].X, q.Y += bp[0].Y;
            }
        }
    };
    ClipperLib::Clipper c;
    ClipperLib::Paths lhs = clipperPaths(*children[0]);
    try {
        for (std::size_t i = 1; i < children.size(); ++i) {
            const ClipperLib::Paths rhs = clipperPaths(*children[i]);
            ClipperLib::Paths terms;
            for (const ClipperLib::Path& path : lhs)
                for (const ClipperLib::Path& poly : rhs) {
                    if (path.empty() || poly.empty()) continue;
                    for (std::size_t a = 0; a < path.size(); ++a)
                        for (std::size_t b = 0; b < poly.size(); ++b) {
                            const ClipperLib::IntPoint &p0 = path[a], &p1 = path[(a + 1) % path.size()];
                            const ClipperLib::IntPoint &q0 = poly[b], &q1 = poly[(b + 1) % poly.size()];
                            ClipperLib::Path quad{{p0.X + q0.X, p0.Y + q0.Y},
                                                  {p1.X + q0.X, p1.Y + q0.Y},
                                                  {p1.X + q1.X, p1.Y + q1.Y},
                                                  {p0.X + q1.X, p0.Y + q1.Y}};
                            if (!ClipperLib::Orientation(quad)) std::reverse(quad.begin(), quad.end());
                            terms.push_back(std::move(quad));
                        }
                }
            insides(lhs, rhs, terms);
            insides(rhs, lhs, terms);
            c.Clear();
            c.AddPaths(terms, ClipperLib::ptSubject, true);
            if (i + 1 != children.size())
                c.Execute(ClipperLib::ctUnion, lhs, ClipperLib::pftNonZero, ClipperLib::pftNonZero);
        }
        ClipperLib::PolyTree tree;
        c.Execute(ClipperLib::ctUnion, tree, ClipperLib::pftNonZero, ClipperLib::pftNonZero);
        return fromTree(tree);
    } catch (...) {
        return {};  // Clipper's range check: nothing, as OpenSCAD gets
    }
}

}  // namespace isoforge::csg
