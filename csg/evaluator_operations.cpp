#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/matrix.hpp>

#include "csg/evaluator.h"
#include "csg/nodes.h"
#include "csg/shapes.h"
#include "implicit/primitives.h"
#include "mesh/trimesh.h"

namespace isoforge::csg {

using implicit::Box3;

std::optional<FieldPtr> Evaluator::operation(const Call& site) {
    const Statement& s = site.s;
    const Scope& scope = site.scope;
    const int depth = site.depth;
    const std::string& n = s.name;
    auto args = [&](std::vector<std::string> order) { return Args(s, scope, order); };
    if (n == "linear_extrude") {
        Args a = args({"height", "center", "convexity", "twist", "slices", "scale"});
        if (a.has("file"))
            throw a.error("file",
                          "linear_extrude(file = ...) imports a DXF file, which is not supported (as import() is not)");
        const double twist = a.number("twist", 0.0), height = a.number("height", 100.0);
        glm::dvec3 sc = a.vec3("scale", glm::dvec3(1.0));
        note(depth, "linear_extrude", s);
        auto kids = children(s, scope, depth, Want::Profiles);
        if (kids.empty()) return nullptr;
        if (!(height > 0) || !std::isfinite(height))
            return dropped(site, "linear_extrude() with a zero, negative or non-finite height");
        if (!std::isfinite(twist)) throw a.error("twist", "linear_extrude twist must be finite");
        if (!std::isfinite(sc.x + sc.y)) {
            d_.warn(s.line, s.col, "linear_extrude() scale must be finite: 1 is used");
            sc = glm::dvec3(1.0);
        }
        sc = glm::max(sc, glm::dvec3(0.0));  // OpenSCAD takes a negative scale as 0
        // OpenSCAD builds a twisted or unevenly scaled extrusion from slices with straight,
        // triangulated walls: in its exports (slices, or $fa and $fs, given) we build the same mesh.
        // Elsewhere (our own scenes) the twist is continuous.
        const Value* fa = scope.find("$fa");
        const Value* fs = scope.find("$fs");
        const Value* fn = scope.find("$fn");
        const bool exported = a.has("slices") || (fa && fs && fa->kind == Value::Number && fs->kind == Value::Number);
        // (A scale of 0 goes the same way: OpenSCAD drops the pinched cone from boolean operations.)
        if (exported && (twist != 0 || sc.x != sc.y || sc.x == 0 || sc.y == 0)) {
            ExtrudeParams e;
            e.height = height;
            e.twistDeg = twist;
            e.scale = glm::dvec2(sc.x, sc.y);
            e.center = a.boolean("center", false);
            const double slices = a.number("slices", 0.0);
            e.slices = std::isfinite(slices) && slices > 0 ? static_cast<int>(std::min(slices, 1e6)) : 0;
            e.fn = fn && fn->kind == Value::Number ? fn->n : 0.0;
            if (fa && fa->kind == Value::Number) e.fa = fa->n;
            if (fs && fs->kind == Value::Number) e.fs = fs->n;
            if (FieldPtr f = slicedExtrusion(site, kids, e)) return f;
        }
        FieldPtr f = makeLinearExtrude(makeUnion(kids), float(height), a.boolean("center", false), float(twist),
                                       glm::vec2(float(sc.x), float(sc.y)));
        // A straight extrusion of outlines is a polyhedron with flat walls: what hull() and
        // minkowski() take from it.
        if (twist == 0 && sc.x == sc.y && sc.x > 0)
            if (std::optional<Profile> p = combinedProfile(kids, ProfileOp::Union); p && !p->outlines.empty()) {
                ExtrudeParams e;
                e.height = height;
                e.scale = glm::dvec2(sc.x, sc.y);
                e.center = a.boolean("center", false);
                e.slices = 1;
                withParts(f, [p = std::move(*p), e, f]() -> std::optional<Parts> {
                    try {
                        const mesh::TriMesh m = extrudeProfile(p, e);
                        return meshParts({m.positions.begin(), m.positions.end()}, m.triangles, f);
                    } catch (const std::length_error&) {
                        return std::nullopt;
                    }
                });
            }
        return f;
    }
    if (n == "rotate_extrude") {
        Args a = args({"angle", "convexity"});
        if (a.has("file"))
            throw a.error("file",
                          "rotate_extrude(file = ...) imports a DXF file, which is not supported (as import() is not)");
        double angle = a.number("angle", 360.0);
        note(depth, "rotate_extrude", s);
        auto kids = children(s, scope, depth, Want::Profiles);
        if (kids.empty()) return nullptr;
        if (angle == 0 || !std::isfinite(angle))
            return dropped(site, "rotate_extrude() with a zero or non-finite angle");
        angle = std::clamp(angle, -360.0, 360.0);  // OpenSCAD clamps to one turn
        FieldPtr g = makeUnion(std::move(kids));
        // OpenSCAD revolves a profile on either side of the axis (one on the -x side mirrored), but
        // refuses one that crosses it.
        const Box3 b = g->bounds();
        const float slack = 1e-3f * std::max(b.max.x - b.min.x, b.max.y - b.min.y);
        const bool negative = b.max.x <= slack && b.min.x < -slack;
        if (b.min.x < -slack && b.max.x > slack) {
            char range[96];
            std::snprintf(range, sizeof range, "(range is %.2f -> %.2f)", double(b.min.x), double(b.max.x));
            return dropped(site,
                           std::string("rotate_extrude(): all points must have the same X coordinate sign ") + range);
        }
        // Faceted as OpenSCAD does for $fn > 0: a full turn in $fn segments, a part of one in
        // max(floor($fn * |angle| / 360), 1).
        int segments = fragments(scope, s, std::max(std::abs(b.min.x), std::abs(b.max.x)));
        if (segments > 0 && std::abs(angle) < 360)
            segments = std::max(1, static_cast<int>(std::floor(segments * std::abs(angle) / 360.0)));
        return makeRotateExtrude(g, float(angle), segments, negative);
    }
    // --- transforms
    if (n == "translate") {
        Args a = args({"v"});
        note(depth, "translate", s);
        return transformed(s, scope, depth, glm::translate(glm::dmat4(1.0), a.vec3("v", glm::dvec3(0.0), false)));
    }
    if (n == "scale") {
        Args a = args({"v"});
        const glm::dvec3 v = a.vec3("v", glm::dvec3(1.0));
        if (v.x == 0 || v.y == 0 || v.z == 0) return dropped(site, "scale() by zero flattens its children");
        note(depth, "scale", s);
        return transformed(s, scope, depth, glm::scale(glm::dmat4(1.0), v));
    }
    if (n == "rotate") {
        Args a = args({"a", "v"});
        glm::dmat4 m(1.0);
        const Value* av = a.raw("a");
        if (av && av->kind == Value::Vector) {
            const glm::dvec3 r = a.vec3("a");
            m = glm::rotate(glm::dmat4(1.0), r.z * kDeg, glm::dvec3(0, 0, 1)) *
                glm::rotate(glm::dmat4(1.0), r.y * kDeg, glm::dvec3(0, 1, 0)) *
                glm::rotate(glm::dmat4(1.0), r.x * kDeg, glm::dvec3(1, 0, 0));
        } else {
            const glm::dvec3 axis = a.vec3("v", glm::dvec3(0, 0, 1), false);
            if (glm::length(axis) == 0) throw a.error("v", "the rotation axis must not be zero");
            m = glm::rotate(glm::dmat4(1.0), a.number("a", 0.0) * kDeg, glm::normalize(axis));
        }
        note(depth, "rotate", s);
        return transformed(s, scope, depth, m);
    }
    if (n == "mirror") {
        Args a = args({"v"});
        const glm::dvec3 v = a.vec3("v", glm::dvec3(1, 0, 0), false);
        if (glm::length(v) == 0) throw a.error("v", "the mirror normal must not be zero");
        const glm::dvec3 u = glm::normalize(v);
        glm::dmat4 m(1.0);
        for (int c = 0; c < 3; ++c)
            for (int r = 0; r < 3; ++r) m[c][r] -= 2.0 * u[r] * u[c];
        note(depth, "mirror", s);
        return transformed(s, scope, depth, m);
    }
    if (n == "multmatrix") {
        Args a = args({"m"});
        int ml = s.line, mc = s.col;
        const Value* mv = a.raw("m", &ml, &mc);
        const auto rows = mv ? matrixOf(*mv) : std::vector<std::vector<double>>{};
        if (rows.size() < 3 || rows.size() > 4) throw EvalError{ml, mc, "multmatrix needs a 3x4 or 4x4 matrix"};
        glm::dmat4 m(1.0);
        for (std::size_t r = 0; r < 3; ++r) {
            if (rows[r].size() < 3) throw EvalError{ml, mc, "multmatrix rows need 4 numbers"};
            for (std::size_t c = 0; c < std::min<std::size_t>(4, rows[r].size()); ++c)
                m[static_cast<int>(c)][static_cast<int>(r)] = rows[r][c];
        }
        note(depth, "multmatrix", s);
        const glm::dmat3 linear(m);
        if (!(std::abs(glm::determinant(linear)) > 1e-12)) {
            if (children(s, scope, depth).empty()) return nullptr;
            return dropped(site, "multmatrix() with a singular matrix flattens its children");
        }
        return transformed(s, scope, depth, m);
    }
    if (n == "resize") {
        Args a = args({"newsize", "auto"});
        const glm::dvec3 ns = a.vec3("newsize", std::nullopt, false);
        note(depth, "resize", s);
        FieldPtr g = group(s, scope, depth);
        if (!g) return nullptr;
        const Box3 b = g->bounds();
        if (!b.isBounded()) throw a.error("newsize", "resize() needs a bounded child");
        const glm::dvec3 size(b.size());
        // OpenSCAD: a positive new size scales its axis (about the origin); with auto, the axes left
        // at 0 take the scale factor of the largest new size (the first of equals), as OpenSCAD's resize.
        glm::bvec3 autos(false);
        if (const Value* av = a.raw("auto"); av && av->kind == Value::Vector) {
            for (std::size_t k = 0; k < std::min<std::size_t>(3, av->v.size()); ++k) autos[int(k)] = av->v[k].truthy();
        } else if (av) {
            autos = glm::bvec3(av->truthy());
        }
        glm::dvec3 f(1.0);
        int largest = 0;
        for (int k = 0; k < 3; ++k) {
            if (ns[k] > 0 && size[k] > 0) f[k] = ns[k] / size[k];
            if (ns[k] > ns[largest]) largest = k;
        }
        const double autoScale = f[largest];
        for (int k = 0; k < 3; ++k)
            if (!(ns[k] > 0) && autos[k]) f[k] = autoScale;
        const glm::dmat4 m = glm::scale(glm::dmat4(1.0), f);
        return carried(implicit::makeTransformed(g, glm::mat4(m)), {g}, &m);
    }
    // --- booleans and groups
    if (n == "union" || n == "group" || n == "render" || n == "intersection" || n == "difference" ||
        n == "smooth_union" || n == "smooth_intersection" || n == "smooth_difference") {
        const bool smooth = n.rfind("smooth_", 0) == 0;
        Args a = args(smooth ? std::vector<std::string>{"k"} : std::vector<std::string>{"convexity"});
        const float k = smooth ? float(a.number("k", 0.1)) : 0.f;
        if (smooth && !(k > 0)) throw a.error("k", "the blend radius k must be positive");
        note(depth, n, s);
        auto kids = combining(s.children, [&] { return children(s, scope, depth); });
        if (kids.empty()) return nullptr;
        const std::string base = smooth ? n.substr(7) : n;
        if (base == "union" || base == "group" || base == "render")
            return smooth ? makeUnion(std::move(kids), k) : carried(makeUnion(kids), kids);
        std::optional<Profile> profile;
        if (!smooth)
            profile = combinedProfile(kids, base == "intersection" ? ProfileOp::Intersection : ProfileOp::Difference);
        auto profiled = [&](FieldPtr f) { return profile ? withProfile(std::move(f), std::move(*profile)) : f; };
        if (base == "intersection") {
            // OpenSCAD: a child that makes nothing (an empty group or extrusion, a 2D object beside
            // 3D ones) empties the intersection.
            const auto objects = std::count_if(s.children.begin(), s.children.end(), [](const Statement& c) {
                return !c.assignment && c.modifier != '*' && c.modifier != '%' && c.name != "echo" &&
                       c.name != "assert";
            });
            if (static_cast<std::size_t>(objects) > kids.size())
                return dropped(site, "intersection() with a child that makes nothing");
            // A child whose bounds miss the others' (a shape outside its clipping box): nothing is left.
            Box3 common = Box3::everything();
            for (const auto& c : kids) common = common.intersect(c->bounds());
            if (kids.size() > 1 && common.isEmpty())
                d_.warn(s.line, s.col,
                        "this intersection is empty: a child lies outside the others (outside its clipping box?)");
            FieldPtr f = profiled(makeIntersection(kids, k));
            if (!smooth) carryParts(f, kids, false);
            return f;
        }
        if (kids.size() > 1) {
            const Box3 first = kids[0]->bounds();
            bool removes = false;
            for (std::size_t i = 1; i < kids.size(); ++i)
                removes = removes || !first.intersect(kids[i]->bounds()).isEmpty();
            if (!removes)
                d_.warn(s.line, s.col,
                        "this difference removes nothing: the subtracted children lie outside the first");
        }
        FieldPtr f = profiled(makeDifference(kids, k));
        if (!smooth) carryParts(f, kids, true);
        return f;
    }
    if (n == "color" || n == "material") {
        const bool mat = n == "material";
        Args a = mat ? args({"color", "diffuse", "specular", "shininess", "opacity"}) : args({"c", "alpha"});
        const std::string key = mat ? "color" : "c";
        glm::vec4 rgba(1.f);
        if (mat) rgba = glm::vec4(0.8f, 0.8f, 0.8f, 1.f);
        int cl = s.line, cc = s.col;
        const Value* c = a.raw(key, &cl, &cc);
        if (c && c->kind == Value::String) {
            bool ok = false;
            rgba = parseColor(c->s, ok);
            if (!ok)
                throw EvalError{cl, cc,
                                "unknown colour '" + c->s + "' (use a name such as red, \"#ff8000\" or [r, g, b])"};
        } else if (c && c->kind == Value::Vector && c->v.size() >= 3) {
            rgba = glm::vec4(c->v[0].n, c->v[1].n, c->v[2].n, c->v.size() > 3 ? c->v[3].n : 1.0);
        } else if (c && c->kind != Value::Undef) {
            throw EvalError{cl, cc, n + " needs a colour name or [r, g, b(, a)]"};
        }
        if (a.has("alpha")) rgba.a = static_cast<float>(a.number("alpha"));
        if (a.has("opacity")) rgba.a = static_cast<float>(a.number("opacity"));
        if (!(rgba.a >= 0.f && rgba.a <= 1.f)) throw a.error(mat ? "opacity" : "alpha", "opacity must be in [0, 1]");
        implicit::Material m;
        m.color = glm::vec4(glm::vec3(rgba), std::max(rgba.a, 1e-3f));
        if (mat) {
            m.diffuse = float(a.number("diffuse", m.diffuse));
            m.specular = float(a.number("specular", m.specular));
            m.shininess = float(a.number("shininess", m.shininess));
            if (m.diffuse < 0 || m.specular < 0 || m.shininess < 1)
                throw a.error("shininess", "diffuse and specular must be >= 0 and shininess >= 1");
        }
        note(depth, n, s);
        FieldPtr g = group(s, scope, depth);
        if (!g) return nullptr;
        return carried(makeMaterial(g, m), {g});
    }
    if (n == "offset") {
        Args a = args({"r", "delta", "chamfer"});
        note(depth, "offset", s);
        const bool round = a.has("r") || !a.has("delta");  // OpenSCAD: r wins; no argument is r = 1
        const double amount = round ? a.number("r", 1.0) : a.number("delta");
        if (!std::isfinite(amount)) throw a.error(round ? "r" : "delta", "offset() needs a finite distance");
        FieldPtr g = group(s, scope, depth);
        if (!g) return nullptr;
        // A 2D object with OpenSCAD's outlines: OpenSCAD's own offset by Clipper. Otherwise (a 3D
        // object, our extension; a 2D one without outlines) the offset of the field.
        if (const Profile* p = profileOf(g); p && planar(g)) {
            int frags = fragments(scope, s, std::abs(amount));
            if (!frags) frags = int(std::ceil(std::max(std::min(360.0 / 12, std::abs(amount) * 2 * M_PI / 2), 5.0)));
            const OffsetJoin join = round                         ? OffsetJoin::Round
                                    : a.boolean("chamfer", false) ? OffsetJoin::Square
                                                                  : OffsetJoin::Miter;
            Profile out = offsetProfile(*p, amount, join, std::abs(amount) * (1 - cosDegrees(180.0 / frags)));
            if (out.outlines.empty()) return dropped(site, "offset() leaves nothing of its 2D children");
            FieldPtr f = profileField(out);
            return withProfile(f, std::move(out));
        }
        return implicit::makeOffset(g, float(amount));
    }
    if (n == "shell") {
        Args a = args({"t"});
        note(depth, "shell", s);
        FieldPtr g = group(s, scope, depth);
        return g ? implicit::makeShell(g, float(a.number("t", 0.1))) : nullptr;
    }
    return std::nullopt;
}

FieldPtr Evaluator::slicedExtrusion(const Call& site, const std::vector<FieldPtr>& kids, const ExtrudeParams& e) {
    std::optional<Profile> p = combinedProfile(kids, ProfileOp::Union);
    if (!p || p->outlines.empty()) return nullptr;
    mesh::TriMesh m;
    try {
        m = extrudeProfile(*p, e);
    } catch (const std::length_error& err) {
        d_.warn(site.s.line, site.s.col, std::string(err.what()) + ": the twist is continuous here instead");
        return nullptr;
    }
    // OpenSCAD converts it to a CGAL polyhedron inside a boolean operation, which fails for a mesh
    // whose faces do not pair up or whose walls meet at one point (a scale of 0 pinching them
    // together): it skips it there.
    if (booleans_ > 0) {
        std::vector<std::vector<int>> faces;
        for (const glm::uvec3& t : m.triangles) faces.push_back({int(t.x), int(t.y), int(t.z)});
        if (!facesPairUp(m.positions, faces, true))
            return dropped(site,
                           "linear_extrude() makes a mesh that is not closed, so OpenSCAD cannot use it in a "
                           "boolean operation (\"The given mesh is not closed!\")");
    }
    std::vector<glm::dvec3> points(m.positions.begin(), m.positions.end());
    const std::vector<glm::uvec3> tris = m.triangles;
    try {
        FieldPtr f = makeTriangleMeshField(std::move(m.positions), std::move(m.triangles), site.s.name, nullptr, true);
        return withParts(f, [points = std::move(points), tris, f] { return meshParts(points, tris, f); });
    } catch (const std::invalid_argument&) {
        return nullptr;  // nothing of non-zero area: the continuous extrusion says the same
    }
}

}  // namespace isoforge::csg
