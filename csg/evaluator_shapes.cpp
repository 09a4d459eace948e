#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>

#include "core/error.h"
#include "core/number_text.h"
#include "csg/evaluator.h"
#include "csg/nodes.h"
#include "csg/shapes.h"
#include "csg/surface.h"
#include "csg/text.h"
#include "implicit/blobby.h"
#include "implicit/primitives.h"
#include "implicit/quadric.h"
#include "implicit/tape.h"
#include "mesh/io.h"
#include "mesh/parametric.h"
#include "mesh/subdivide.h"
#include "mesh/triangulate.h"
#include "volume/grid_field.h"

namespace isoforge::csg {

using implicit::Box3;

int Evaluator::resolutionArg(const Args& a, int def) {
    const double r = a.number("resolution", def);
    if (!(r >= 1 && r <= 1024)) throw a.error("resolution", "resolution must be from 1 to 1024");
    return static_cast<int>(r);
}

/// nurbs(points = [[p, ...], ...] rows along v of points along u, each [x, y, z] or [x, y, z, w],
/// knots_u, knots_v (default: clamped uniform), degree = p or [pu, pv] (default 3, at most the
/// count - 1), weights = [[w, ...], ...]).
mesh::NurbsSurface Evaluator::nurbsSurface(const Args& a) {
    int line = 0, col = 0;
    const Value* pts = a.raw("points", &line, &col);
    if (!pts || pts->kind != Value::Vector || pts->v.empty())
        throw a.error("points", "nurbs() needs points: rows of [x, y, z] or [x, y, z, w]");
    mesh::NurbsSurface ns;
    ns.countV = static_cast<int>(pts->v.size());
    ns.countU = static_cast<int>(pts->v[0].v.size());
    if (ns.countV > 4096 || ns.countU > 4096) throw a.error("points", "nurbs() takes at most 4096 x 4096 points");
    bool rational = false;
    std::vector<double> w;
    for (const Value& row : pts->v) {
        if (row.kind != Value::Vector || static_cast<int>(row.v.size()) != ns.countU)
            throw a.error("points", "nurbs() points must be rows of the same length (" + std::to_string(ns.countU) +
                                        " points each)");
        for (const Value& p : row.v) {
            if (p.kind != Value::Vector || p.v.size() < 3 || p.v.size() > 4)
                throw a.error("points", "each nurbs() point must be [x, y, z] or [x, y, z, w]");
            for (const Value& c : p.v)
                if (c.kind != Value::Number) throw a.error("points", "nurbs() point coordinates must be numbers");
            ns.points.emplace_back(p.v[0].n, p.v[1].n, p.v[2].n);
            w.push_back(p.v.size() == 4 ? p.v[3].n : 1.0);
            rational = rational || p.v.size() == 4;
        }
    }
    if (const Value* wv = a.raw("weights"); wv && wv->kind != Value::Undef) {
        std::vector<double> given;
        if (wv->kind == Value::Vector)
            for (const Value& row : wv->v) {
                if (row.kind == Value::Number) given.push_back(row.n);
                for (const Value& x : row.v)
                    if (x.kind == Value::Number) given.push_back(x.n);
            }
        if (given.size() != w.size())
            throw a.error("weights", "nurbs() needs one weight per point (" + std::to_string(w.size()) + ")");
        w = std::move(given);
        rational = true;
    }
    if (rational) ns.weights = std::move(w);
    ns.degreeU = ns.degreeV = 3;
    if (a.has("degree")) {
        const glm::dvec3 d = a.vec3("degree");
        // Checked before the conversion to int (and before knots are made for a degree of 10^9).
        if (!(d.x >= 1 && d.x <= 20 && d.y >= 1 && d.y <= 20))
            throw a.error("degree", "nurbs() degrees must be from 1 to 20");
        ns.degreeU = static_cast<int>(d.x);
        ns.degreeV = static_cast<int>(d.y);
    } else {
        ns.degreeU = std::min(3, ns.countU - 1);
        ns.degreeV = std::min(3, ns.countV - 1);
    }
    auto knots = [&](const char* k, int count, int degree) {
        const Value* kv = a.raw(k);
        if (!kv || kv->kind == Value::Undef) return mesh::clampedUniformKnots(count, degree);
        std::vector<double> out;
        if (kv->kind == Value::Vector)
            for (const Value& x : kv->v) {
                if (x.kind != Value::Number) throw a.error(k, std::string(k) + " must be a list of numbers");
                out.push_back(x.n);
            }
        else
            throw a.error(k, std::string(k) + " must be a list of numbers");
        return out;
    };
    if (ns.degreeU < 1 || ns.degreeV < 1) throw a.error("degree", "nurbs() degrees must be at least 1");
    ns.knotsU = knots("knots_u", ns.countU, ns.degreeU);
    ns.knotsV = knots("knots_v", ns.countV, ns.degreeV);
    try {
        ns.validate();
    } catch (const std::invalid_argument& e) {
        throw EvalError{line, col, std::string("nurbs(): ") + e.what()};
    }
    return ns;
}

std::optional<FieldPtr> Evaluator::primitive3D(const Call& site) {
    const Statement& s = site.s;
    const Scope& scope = site.scope;
    const std::string& n = s.name;
    auto args = [&](std::vector<std::string> order) { return Args(s, scope, order); };
    auto leaf = [&](FieldPtr f, const std::string& what) { return leafOf(site, std::move(f), what); };
    // --- OpenSCAD 3D primitives
    if (n == "cube") {
        Args a = args({"size", "center"});
        const glm::dvec3 size = a.vec3("size", glm::dvec3(1.0));
        if (!(size.x > 0 && size.y > 0 && size.z > 0) || !std::isfinite(size.x + size.y + size.z))
            return dropped(site, "cube() with a zero, negative or non-finite size");
        FieldPtr f = implicit::makeBox(glm::vec3(size));
        if (!a.boolean("center", false)) f = implicit::makeTranslated(f, glm::vec3(0.5 * size));
        return withParts(leaf(f, "cube"),
                         [size, center = a.boolean("center", false)] { return cubeParts(size, center); });
    }
    if (n == "sphere") {
        Args a = args({"r"});
        const double r = a.has("d") ? 0.5 * a.number("d") : a.number("r", 1.0);
        if (!(r > 0) || !std::isfinite(r)) return dropped(site, "sphere() with a zero, negative or non-finite radius");
        const int fn = fragments(scope, s, r);
        return withParts(
            leaf(fn ? makeFacetedSphere(static_cast<float>(r), fn) : implicit::makeSphere(static_cast<float>(r)),
                 fn ? "sphere ($fn=" + std::to_string(fn) + ")" : "sphere"),
            [r, fn] { return sphereParts(r, fn ? fn : kSmoothFragments); });
    }
    if (n == "cylinder") {
        Args a = args({"h", "r1", "r2", "center"});
        const double h = a.number("h", 1.0);
        double r1 = a.has("r") ? a.number("r") : (a.has("d") ? 0.5 * a.number("d") : 1.0);
        double r2 = r1;
        if (a.has("r1")) r1 = a.number("r1");
        if (a.has("r2")) r2 = a.number("r2");
        if (a.has("d1")) r1 = 0.5 * a.number("d1");
        if (a.has("d2")) r2 = 0.5 * a.number("d2");
        const bool center = a.boolean("center", false);
        if (!(h > 0) || !std::isfinite(h))
            return dropped(site, "cylinder() with a zero, negative or non-finite height");
        if (!(r1 >= 0 && r2 >= 0) || r1 + r2 <= 0 || !std::isfinite(r1 + r2))
            return dropped(site, "cylinder() with negative, non-finite or two zero radii");
        const int fn = fragments(scope, s, std::max(r1, r2));
        auto parts = [=] { return cylinderParts(r1, r2, h, center, fn ? fn : kSmoothFragments); };
        if (fn)
            return withParts(leaf(makeFacetedCylinder(float(r1), float(r2), float(h), center, fn),
                                  "cylinder ($fn=" + std::to_string(fn) + ")"),
                             parts);
        FieldPtr f =
            r1 == r2 ? implicit::makeCylinder(float(r1), float(h)) : implicit::makeCone(float(r1), float(r2), float(h));
        if (!center) f = implicit::makeTranslated(f, glm::vec3(0, 0, 0.5f * float(h)));
        return withParts(leaf(f, "cylinder"), parts);
    }
    if (n == "polyhedron") {
        Args a = args({"points", "faces", "convexity"});
        int pl = s.line, pc = s.col;
        const Value* pts = a.raw("points", &pl, &pc);
        const Value* faces = a.has("faces") ? a.raw("faces") : a.raw("triangles");
        if (!pts || !faces || pts->kind != Value::Vector || faces->kind != Value::Vector)
            return dropped(site, "polyhedron() without lists of points and faces");
        std::vector<glm::vec3> p;
        for (const auto& q : pts->v) {
            if (q.kind != Value::Vector || q.v.size() != 3 || q.v[0].kind != Value::Number ||
                q.v[1].kind != Value::Number || q.v[2].kind != Value::Number ||
                !std::isfinite(q.v[0].n + q.v[1].n + q.v[2].n))
                return dropped(
                    site, "polyhedron() point " + std::to_string(p.size()) + " is not [x, y, z] of finite numbers");
            p.emplace_back(q.v[0].n, q.v[1].n, q.v[2].n);
        }
        std::vector<std::vector<int>> f;
        for (const auto& q : faces->v) {
            f.emplace_back();
            if (q.kind != Value::Vector)
                return dropped(site,
                               "polyhedron() face " + std::to_string(f.size() - 1) + " is not a list of point indices");
            for (const auto& i : q.v) {
                if (i.kind != Value::Number || !(i.n >= 0 && i.n < double(p.size())))
                    return dropped(site, "polyhedron() face " + std::to_string(f.size() - 1) +
                                             " names a point that does not exist");
                f.back().push_back(static_cast<int>(i.n));
            }
        }
        // OpenSCAD writes a polyhedron that stands alone as it is given, but converts it to a CGAL
        // polyhedron inside a boolean operation, which fails (with an error; the object is skipped)
        // unless its faces pair up edge to edge.
        if (booleans_ > 0 && f.size() >= 4 && !facesPairUp(p, f))
            return dropped(site,
                           "polyhedron() is not closed or its faces are not oriented consistently, so OpenSCAD "
                           "cannot use it in a boolean operation (\"The given mesh is not closed!\")");
        std::vector<glm::dvec3> exact;
        for (const auto& q : pts->v) exact.emplace_back(q.v[0].n, q.v[1].n, q.v[2].n);
        std::vector<glm::uvec3> tris;
        for (const auto& face : f)
            for (const glm::uvec3& t : mesh::triangulateFace(p, face)) tris.push_back(t);
        FieldPtr poly;
        try {
            poly = makePolyhedron(std::move(p), f);
        } catch (const std::invalid_argument& e) {
            // hull() still takes the points
            return withParts(dropped(site, e.what()), [exact = std::move(exact)] { return pointParts(exact); });
        }
        return withParts(leaf(poly, "polyhedron"),
                         [exact = std::move(exact), tris, poly] { return meshParts(exact, tris, poly); });
    }
    if (n == "import" || n == "surface") return fileShape(site);
    return std::nullopt;
}

/// OpenSCAD's import() of a 3D mesh file and surface() of a .dat height map. A file that cannot be
/// opened is skipped with a warning, as OpenSCAD skips it.
FieldPtr Evaluator::fileShape(const Call& site) {
    const Statement& s = site.s;
    const bool import = s.name == "import";
    Args a = import ? Args(s, site.scope, {"file", "layer", "convexity", "origin", "scale"})
                    : Args(s, site.scope, {"file", "center", "invert", "convexity"});
    const std::string name = a.string("file", std::string());
    std::string ext = std::filesystem::path(name).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    const std::string file = name.empty() ? name : path(name);
    std::error_code ec;
    if (name.empty() || !std::filesystem::is_regular_file(file, ec))
        return dropped(site, s.name + "() cannot open '" + name + "'");
    if (import && ext != ".stl" && ext != ".off" && ext != ".obj" && ext != ".ply")
        throw a.error("file", "import() reads 3D meshes (STL, OFF, OBJ, PLY); '" + ext +
                                  "' files (DXF and SVG drawings, AMF, 3MF) are not supported");
    if (!import && ext != ".dat")
        throw a.error("file", "surface() reads .dat height maps; PNG images are not supported");
    mesh::TriMesh m;
    if (import) {
        m = mesh::readMesh(file);
        const double scale = a.number("scale", 1.0);
        if (!(scale > 0) || !std::isfinite(scale)) throw a.error("scale", "import() scale must be positive");
        for (glm::vec3& p : m.positions) p *= float(scale);
    } else {
        std::vector<std::string> warnings;
        m = surfaceMesh(readHeightMap(file, warnings), a.boolean("center", false));
        for (const std::string& w : warnings) d_.warn(s.line, s.col, w);
        if (a.boolean("invert", false)) d_.warn(s.line, s.col, "surface(invert = true) applies to PNG images only");
        if (m.triangles.empty()) return dropped(site, "surface() of a height map of fewer than 2 rows or columns");
    }
    std::vector<glm::dvec3> points(m.positions.begin(), m.positions.end());
    std::vector<glm::uvec3> tris = m.triangles;
    FieldPtr f = meshLeafOf(site, std::move(m), s.name + "(\"" + name + "\")", !import);
    return withParts(f, [points = std::move(points), tris = std::move(tris), f] { return meshParts(points, tris, f); });
}

std::optional<FieldPtr> Evaluator::shape2D(const Call& site) {
    const Statement& s = site.s;
    const Scope& scope = site.scope;
    const std::string& n = s.name;
    auto args = [&](std::vector<std::string> order) { return Args(s, scope, order); };
    auto leaf = [&](FieldPtr f, const std::string& what) { return leafOf(site, std::move(f), what); };
    // --- 2D primitives and extrusions
    if (n == "circle") {
        Args a = args({"r"});
        const double r = a.has("d") ? 0.5 * a.number("d") : a.number("r", 1.0);
        if (!(r > 0) || !std::isfinite(r)) return dropped(site, "circle() with a zero, negative or non-finite radius");
        const int fn = fragments(scope, s, r);
        if (!fn) return leaf(makeCircle2D(float(r)), "circle");
        return leaf(withProfile(makeRegularPolygon2D(float(r), fn), circleProfile(r, fn)), "circle");
    }
    if (n == "square") {
        Args a = args({"size", "center"});
        const glm::dvec3 size = a.vec3("size", glm::dvec3(1.0));
        if (!(size.x > 0 && size.y > 0) || !std::isfinite(size.x + size.y))
            return dropped(site, "square() with a zero, negative or non-finite size");
        const glm::vec2 sz(static_cast<float>(size.x), static_cast<float>(size.y));
        const glm::vec2 lo = a.boolean("center", false) ? -0.5f * sz : glm::vec2(0.f);
        return leaf(withProfile(makeRectangle2D(lo, lo + sz),
                                squareProfile(glm::dvec2(size.x, size.y), a.boolean("center", false))),
                    "square");
    }
    if (n == "text") {
        Args a = args({"text", "size", "font", "halign", "valign", "spacing", "direction", "language", "script"});
        TextParams t;
        t.text = a.string("text", std::string());
        t.size = a.number("size", 10.0);
        t.font = a.string("font", std::string());
        t.halign = a.string("halign", std::string("left"));
        t.valign = a.string("valign", std::string("baseline"));
        t.spacing = a.number("spacing", 1.0);
        t.direction = a.string("direction", std::string());
        t.language = a.string("language", std::string("en"));
        t.script = a.string("script", std::string());
        if (!std::isfinite(t.size) || !std::isfinite(t.spacing) || std::abs(t.size) > 1e6)
            throw a.error("size", "text() size and spacing must be finite numbers");
        if (t.text.size() > 100000) throw a.error("text", "text() of more than 100,000 bytes");
        // OpenSCAD: max(floor(fragments(size) / 8) + 1, 2) points per curve; its default $fa = 12 and
        // $fs = 2 where our own scenes set neither.
        int frags = fragments(scope, s, t.size);
        if (!frags) frags = int(std::ceil(std::max(std::min(360.0 / 12, t.size * 2 * M_PI / 2), 5.0)));
        t.segments = std::max(frags / 8 + 1, 2);
        Profile p;
        try {
            p = textProfile(t);
        } catch (const std::runtime_error& e) {
            throw EvalError{s.line, s.col, e.what()};
        }
        if (p.outlines.empty()) return dropped(site, "text() with nothing to draw");
        FieldPtr f = profileField(p);
        return leaf(withProfile(f, std::move(p)), "text");
    }
    if (n == "polygon") {
        Args a = args({"points", "paths", "convexity", "subdivide", "levels"});
        const Value* pts = a.raw("points");
        if (!pts) throw EvalError{s.line, s.col, "polygon() needs points"};
        std::vector<glm::vec2> p;
        std::vector<glm::dvec2> exact;  // OpenSCAD's points, in double precision
        if (pts->kind != Value::Vector) return dropped(site, "polygon() without a list of points");
        for (const auto& q : pts->v) {
            if (q.kind != Value::Vector || q.v.size() != 2 || q.v[0].kind != Value::Number ||
                q.v[1].kind != Value::Number || !std::isfinite(q.v[0].n + q.v[1].n))
                return dropped(site,
                               "polygon() point " + std::to_string(p.size()) + " is not [x, y] of finite numbers");
            p.emplace_back(q.v[0].n, q.v[1].n);
            exact.emplace_back(q.v[0].n, q.v[1].n);
        }
        std::vector<std::vector<int>> paths;
        if (const Value* pv = a.raw("paths"); pv && pv->kind == Value::Vector)
            for (const auto& q : pv->v) {
                paths.emplace_back();
                for (const auto& i : q.v) {
                    // Checked before the conversion to int: 3e58 is out of range, not undefined behaviour.
                    if (!(i.n > -1.0 && i.n < double(p.size())))
                        return dropped(site, "polygon: a path names point " + numberText(i.n) + ", but there are " +
                                                 std::to_string(p.size()));
                    paths.back().push_back(static_cast<int>(i.n));
                }
            }
        // isoforge's extension: smooth the outline(s) by curve subdivision before use.
        if (a.has("subdivide")) {
            const std::string scheme = a.string("subdivide");
            if (scheme != "chaikin" && scheme != "4point")
                throw a.error("subdivide", "subdivide must be \"chaikin\" or \"4point\"");
            const double levels = a.number("levels", 3.0);
            if (!(levels >= 0 && levels <= 10)) throw a.error("levels", "levels must be from 0 to 10");
            if (p.size() * (std::size_t(1) << static_cast<int>(levels)) > 10000000)
                throw a.error("levels", "subdividing " + std::to_string(p.size()) + " points " +
                                            std::to_string(static_cast<int>(levels)) + " times is too many");
            auto smooth = [&](std::vector<glm::vec2> ring) {
                return scheme == "chaikin" ? mesh::chaikin(std::move(ring), static_cast<int>(levels))
                                           : mesh::fourPoint(std::move(ring), static_cast<int>(levels));
            };
            exact.clear();
            if (paths.empty()) {
                p = smooth(std::move(p));
            } else {
                std::vector<glm::vec2> all;
                std::vector<std::vector<int>> newPaths;
                for (const auto& path : paths) {
                    std::vector<glm::vec2> ring;
                    for (int i : path) {
                        if (i < 0 || std::size_t(i) >= p.size())
                            throw a.error("paths", "path index " + std::to_string(i) + " is out of range");
                        ring.push_back(p[std::size_t(i)]);
                    }
                    newPaths.emplace_back();
                    for (const glm::vec2& q : smooth(std::move(ring))) {
                        newPaths.back().push_back(static_cast<int>(all.size()));
                        all.push_back(q);
                    }
                }
                p = std::move(all);
                paths = std::move(newPaths);
            }
        }
        if (exact.empty())
            for (const glm::vec2& q : p) exact.emplace_back(q);
        Profile profile = polygonProfile(exact, paths);
        FieldPtr poly;
        try {
            poly = makePolygon2D(std::move(p), std::move(paths));
        } catch (const std::invalid_argument& e) {
            return dropped(site, e.what());
        }
        return leaf(withProfile(poly, std::move(profile)), "polygon");
    }
    return std::nullopt;
}

std::optional<FieldPtr> Evaluator::extensionShape(const Call& site) {
    const Statement& s = site.s;
    const Scope& scope = site.scope;
    const int depth = site.depth;
    const std::string& n = s.name;
    auto args = [&](std::vector<std::string> order) { return Args(s, scope, order); };
    auto leaf = [&](FieldPtr f, const std::string& what) { return leafOf(site, std::move(f), what); };
    // --- our extensions
    if (n == "torus") {
        Args a = args({"R", "r"});
        return leaf(implicit::makeTorus(float(a.number("R", 1.0)), float(a.number("r", 0.25))), "torus");
    }
    if (n == "cone") {
        Args a = args({"r1", "r2", "h", "center"});
        FieldPtr f =
            implicit::makeCone(float(a.number("r1", 1.0)), float(a.number("r2", 0.0)), float(a.number("h", 1.0)));
        if (!a.boolean("center", true))
            f = implicit::makeTranslated(f, glm::vec3(0, 0, 0.5f * float(a.number("h", 1.0))));
        return leaf(f, "cone");
    }
    if (n == "box") {
        Args a = args({"size", "r", "center"});
        const glm::dvec3 size = a.vec3("size", glm::dvec3(1.0));
        FieldPtr f = implicit::makeBox(glm::vec3(size), float(a.number("r", 0.0)));
        if (!a.boolean("center", true)) f = implicit::makeTranslated(f, glm::vec3(0.5 * size));
        return leaf(f, "box");
    }
    if (n == "plane") {
        Args a = args({"n", "d"});
        return leaf(implicit::makePlane(glm::vec3(a.vec3("n", glm::dvec3(0, 0, 1), false)), float(a.number("d", 0.0))),
                    "plane");
    }
    if (n == "ellipsoid") {
        Args a = args({"r"});
        return leaf(implicit::makeEllipsoid(glm::vec3(a.vec3("r", glm::dvec3(1.0, 0.6, 0.4)))), "ellipsoid");
    }
    if (n == "capsule") {
        Args a = args({"r", "h"});
        return leaf(implicit::makeCapsule(float(a.number("r", 0.25)), float(a.number("h", 1.0))), "capsule");
    }
    if (n == "tetrahedron") {
        Args a = args({"size"});
        return leaf(implicit::makeTetrahedron(float(a.number("size", 1.0))), "tetrahedron");
    }
    if (n == "quadric") {
        Args a = args({"type", "a", "b", "c"});
        if (a.has("coefficients")) {
            const Value* c = a.raw("coefficients");
            if (c->kind != Value::Vector || c->v.size() != 10)
                throw a.error("coefficients", "quadric coefficients must be 10 numbers A..J");
            std::array<float, 10> k{};
            for (std::size_t i = 0; i < 10; ++i) k[i] = static_cast<float>(c->v[i].n);
            return leaf(implicit::makeQuadric(k), "quadric");
        }
        return leaf(implicit::makeNamedQuadric(a.string("type"), float(a.number("a", 1.0)), float(a.number("b", 1.0)),
                                               float(a.number("c", 1.0))),
                    "quadric " + a.string("type"));
    }
    if (n == "implicit") {
        Args a = args({"expr"});
        const std::string e = a.string("expr");
        return leaf(implicit::makeTapeField(implicit::parseExpression(e), Box3::everything(), e), "implicit");
    }
    if (n == "vm") {
        Args a = args({"file"});
        const std::string file = path(a.string("file"));
        return leaf(implicit::makeTapeField(implicit::readVmFile(file), Box3::everything(), a.string("file")), "vm");
    }
    if (n == "volume") {
        Args a = args({"file", "iso", "grid"});
        const std::string file = path(a.string("file"));
        std::optional<std::string> grid;
        if (a.has("grid")) grid = a.string("grid");
        return leaf(volume::makeGridField(file, float(a.number("iso", 0.0)), grid), "volume");
    }
    if (n == "mesh") {
        Args a = args({"file"});
        const std::string file = path(a.string("file"));
        return meshLeafOf(site, mesh::readMesh(file), "mesh(\"" + a.string("file") + "\")", false);
    }
    if (n == "bezier_patches") {
        Args a = args({"file", "resolution"});
        const std::string file = path(a.string("file"));
        const int res = resolutionArg(a, 16);
        const auto patches = mesh::readBezierPatches(file);
        return meshLeafOf(site, mesh::tessellate(patches, res), "bezier_patches(\"" + a.string("file") + "\")", true);
    }
    if (n == "nurbs") {
        Args a = args({"points", "knots_u", "knots_v", "degree", "weights", "resolution"});
        return meshLeafOf(site, mesh::tessellate(nurbsSurface(a), resolutionArg(a, 32)), "nurbs()", true);
    }
    if (n == "blobby") {
        Args a = args({"threshold", "kernel"});
        const std::string k = a.string("kernel", std::string("metaball"));
        implicit::BlobKernel kernel = implicit::BlobKernel::Metaball;
        if (k == "blinn")
            kernel = implicit::BlobKernel::Blinn;
        else if (k == "wyvill")
            kernel = implicit::BlobKernel::Wyvill;
        else if (k != "metaball")
            throw a.error("kernel", "kernel must be blinn, wyvill or metaball");
        std::vector<implicit::Ball> balls;
        for (const Statement& c : s.children) {
            if (c.assignment) continue;
            if (c.name != "ball")
                throw EvalError{c.line, c.col, "blobby() holds ball(center, r, strength) children only"};
            Args b(c, scope, {"center", "r", "strength"});
            balls.push_back({glm::vec3(b.vec3("center", glm::dvec3(0.0), false)), float(b.number("r", 1.0)),
                             float(b.number("strength", 1.0))});
        }
        if (balls.empty()) throw EvalError{s.line, s.col, "blobby() needs at least one ball"};
        primitive();
        note(depth, "blobby (" + std::to_string(balls.size()) + " balls)", s);
        return implicit::makeBlobby(std::move(balls), float(a.number("threshold", 0.5)), kernel);
    }
    return std::nullopt;
}

}  // namespace isoforge::csg
