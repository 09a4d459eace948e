#include "csg/evaluator.h"

#include <algorithm>
#include <cmath>

#include <glm/mat4x4.hpp>

#include "core/error.h"
#include "csg/nodes.h"
#include "csg/shapes.h"
#include "implicit/primitives.h"

namespace isoforge::csg {

namespace {
enum class Dimension { Empty, Planar, Solid };
/// Empty, 2D (bounded in x and y, the same along z) or anything else.
Dimension dimensionOf(const FieldPtr& f) {
    const implicit::Box3 b = f->bounds();
    if (b.isEmpty()) return Dimension::Empty;
    const bool planar = std::isinf(b.min.z) && std::isinf(b.max.z) && std::isfinite(b.min.x) &&
                        std::isfinite(b.max.x) && std::isfinite(b.min.y) && std::isfinite(b.max.y);
    return planar ? Dimension::Planar : Dimension::Solid;
}
}  // namespace

bool Evaluator::planar(const FieldPtr& f) {
    return dimensionOf(f) == Dimension::Planar;
}

/// Fields of the statements in order (assignments first update the scope, as OpenSCAD does).
std::vector<FieldPtr> Evaluator::run(const std::vector<Statement>& list, Scope& scope, int depth, Want want) {
    for (const Statement& s : list)
        if (s.assignment) {
            try {
                scope.vars[s.name] = evaluate(*s.value, scope);
            } catch (const EvalError& e) {
                d_.error(e.line, e.col, e.message);
            }
        }
    std::vector<FieldPtr> out;
    std::vector<const Statement*> sites;
    for (const Statement& s : list) {
        if (s.assignment || s.modifier == '*' || s.modifier == '%') continue;
        try {
            FieldPtr f = call(s, scope, depth);
            if (!f) continue;
            if (s.modifier == '!' && !root_) root_ = f;
            out.push_back(f);
            sites.push_back(&s);
        } catch (const EvalError& e) {
            d_.error(e.line, e.col, e.message);
        } catch (const ParseError& e) {
            d_.error(s.line, s.col, e.what());
        } catch (const IoError& e) {
            d_.error(s.line, s.col, e.what());
        } catch (const std::invalid_argument& e) {
            d_.error(s.line, s.col, e.what());
        }
    }
    // OpenSCAD's dimensions: an extrusion ignores 3D children, and 2D objects beside 3D ones are
    // ignored; both with a warning.
    if (want == Want::Any) return out;
    std::vector<Dimension> dims;
    for (const FieldPtr& f : out) dims.push_back(dimensionOf(f));
    const bool any3D = std::find(dims.begin(), dims.end(), Dimension::Solid) != dims.end();
    if (want == Want::Solids && !any3D) return out;
    std::vector<FieldPtr> kept;
    for (std::size_t i = 0; i < out.size(); ++i) {
        if (want == Want::Profiles && dims[i] == Dimension::Solid)
            d_.warn(sites[i]->line, sites[i]->col,
                    "ignoring the 3D object " + sites[i]->name + "() inside a 2D operation, as OpenSCAD does");
        else if (want == Want::Solids && dims[i] == Dimension::Planar)
            d_.warn(sites[i]->line, sites[i]->col,
                    "ignoring the 2D object " + sites[i]->name +
                        "() beside 3D objects (mixing 2D and 3D is not supported, as in OpenSCAD)");
        else
            kept.push_back(out[i]);
    }
    return kept;
}

void Evaluator::note(int depth, const std::string& what, const Statement& s) {
    outline +=
        std::string(static_cast<std::size_t>(2 * depth), ' ') + what + "  (line " + std::to_string(s.line) + ")\n";
}
int Evaluator::fragments(const Scope& scope, const Statement& s, double r) {
    auto number = [&](const char* name) {
        const Value* v = scope.find(name);
        return v && v->kind == Value::Number ? v->n : 0.0;
    };
    const double fn = number("$fn");
    // OpenSCAD (Calc::get_fragments_from_r): any $fn > 0 asks for that many fragments, at least 3.
    if (fn > 0 && std::isfinite(fn)) {
        if (fn > 10000) throw EvalError{s.line, s.col, "$fn = " + std::to_string(fn) + " is more than 10,000 sides"};
        return std::max(3, static_cast<int>(fn));
    }
    if (fn > 0) {  // inf: OpenSCAD's integer conversion ends at its minimum of 3 fragments
        d_.warn(s.line, s.col, "$fn = inf gives 3 sides, as in OpenSCAD");
        return 3;
    }
    // $fn = 0 with $fa and $fs given (every OpenSCAD export carries them): OpenSCAD's own faceting,
    // ceil(max(min(360 / $fa, 2 pi r / $fs), 5)), so that the solid is the one OpenSCAD makes. Without
    // them (our own scenes), 0: the exact smooth shape.
    const Value* fa = scope.find("$fa");
    const Value* fs = scope.find("$fs");
    if (!fa || !fs || fa->kind != Value::Number || fs->kind != Value::Number) return 0;
    if (!(r >= 0.00000095367431640625)) return 3;                       // OpenSCAD's GRID_FINE
    const double a = std::max(fa->n, 0.01), f = std::max(fs->n, 0.01);  // its minimum for both
    const double n = std::ceil(std::max(std::min(360.0 / a, r * 2.0 * M_PI / f), 5.0));
    return static_cast<int>(std::min(n, 10000.0));
}
std::vector<FieldPtr> Evaluator::children(const Statement& s, const Scope& scope, int depth, Want want) {
    Scope inner{{}, &scope};
    return run(s.children, inner, depth + 1, want);
}
FieldPtr Evaluator::group(const Statement& s, const Scope& scope, int depth) {
    auto kids = children(s, scope, depth);
    if (kids.empty()) return nullptr;
    if (kids.size() == 1) return kids[0];
    return carried(makeUnion(kids), kids);
}
FieldPtr Evaluator::transformed(const Statement& s, const Scope& scope, int depth, const glm::dmat4& m) {
    FieldPtr g = group(s, scope, depth);
    if (!g) return nullptr;
    return carried(implicit::makeTransformed(g, glm::mat4(m)), {g}, &m);
}
FieldPtr Evaluator::carried(FieldPtr f, const std::vector<FieldPtr>& kids, const glm::dmat4* m) {
    if (kids.size() == 1 && f == kids[0]) return f;  // a union of one child is the child: it has its own
    if (std::optional<Profile> p = combinedProfile(kids, ProfileOp::Union))
        withProfile(f, m ? transformProfile(std::move(*p), *m) : std::move(*p));
    if (hasParts(kids)) {
        const std::optional<glm::dmat4> move = m ? std::optional(*m) : std::nullopt;
        withParts(f, [this, kids, move]() -> std::optional<Parts> {
            std::optional<Parts> p = combinedParts(kids);
            if (p && move) return transformParts(std::move(*p), *move);
            return p;
        });
    }
    return f;
}
void Evaluator::carryParts(const FieldPtr& f, const std::vector<FieldPtr>& kids, bool difference) {
    // An intersection or difference of one child is the child: it has its own parts, and making them from
    // themselves would recurse without end (fuzz_scene found it).
    for (const FieldPtr& k : kids)
        if (k == f) return;
    if (!hasParts(kids)) return;
    withParts(f, [this, f, kids, difference]() -> std::optional<Parts> {
        std::vector<const Parts*> ps;
        for (const FieldPtr& k : kids) {
            const Parts* p = partsOf(k);
            if (!p) return std::nullopt;
            ps.push_back(p);
        }
        return difference ? differenceParts(ps, f) : intersectionParts(ps);
    });
}
FieldPtr Evaluator::withParts(FieldPtr f, PartsMaker make) {
    parts_[f.get()] = {f, std::move(make), false, std::nullopt};
    return f;
}
const Parts* Evaluator::partsOf(const FieldPtr& f) {
    auto it = parts_.find(f.get());
    if (it == parts_.end()) return nullptr;
    LazyParts& l = it->second;
    if (!l.made) {
        l.parts = l.make();
        l.made = true;
    }
    return l.parts ? &*l.parts : nullptr;
}
bool Evaluator::hasParts(const std::vector<FieldPtr>& kids) const {
    for (const FieldPtr& k : kids)
        if (!parts_.count(k.get())) return false;
    return true;
}
std::optional<Parts> Evaluator::combinedParts(const std::vector<FieldPtr>& kids) {
    std::vector<const Parts*> ps;
    for (const FieldPtr& k : kids) {
        const Parts* p = partsOf(k);
        if (!p) return std::nullopt;
        ps.push_back(p);
    }
    return uniteParts(ps);
}
FieldPtr Evaluator::withProfile(FieldPtr f, Profile p) {
    profiles_[f.get()] = {f, std::move(p)};
    return f;
}
const Profile* Evaluator::profileOf(const FieldPtr& f) const {
    auto it = profiles_.find(f.get());
    return it == profiles_.end() ? nullptr : &it->second.second;
}
std::optional<Profile> Evaluator::combinedProfile(const std::vector<FieldPtr>& kids, ProfileOp op) const {
    std::vector<const Profile*> ps;
    for (const FieldPtr& k : kids) {
        const Profile* p = profileOf(k);
        if (!p) return std::nullopt;
        ps.push_back(p);
    }
    return combineProfiles(ps, op);
}
std::string Evaluator::path(const std::string& p) const {
    const std::filesystem::path q(p);
    const std::string full = q.is_absolute() ? p : (dir_ / q).string();
    std::error_code ec;
    if (std::filesystem::exists(full, ec) && !std::filesystem::is_regular_file(full, ec))
        throw IoError(full + ": not a regular file");  // a directory, /dev/zero, a FIFO
    if (std::find(scene_.files.begin(), scene_.files.end(), full) == scene_.files.end()) scene_.files.push_back(full);
    return full;
}

FieldPtr Evaluator::dropped(const Call& site, const std::string& why) {
    d_.warn(site.s.line, site.s.col, why + ": it is empty and ignored, as OpenSCAD does");
    note(site.depth, site.s.name + " (empty, ignored)", site.s);
    // An empty solid, not nothing: as the first child of a difference it empties the difference,
    // and in an intersection the intersection, as in OpenSCAD. As a 2D object, an empty polygon.
    return withParts(withProfile(makeEmpty(), Profile{}), [] { return Parts{}; });
}

FieldPtr Evaluator::leafOf(const Call& c, FieldPtr f, const std::string& what) {
    if (!c.s.children.empty()) d_.warn(c.s.line, c.s.col, c.s.name + "() takes no children; they are ignored");
    primitive();
    note(c.depth, what, c.s);
    return f;
}

FieldPtr Evaluator::meshLeafOf(const Call& c, mesh::TriMesh m, const std::string& what, bool generated) {
    bool closed = false;
    std::vector<glm::uvec3> tris(m.triangles.begin(), m.triangles.end());
    FieldPtr f = makeTriangleMeshField(std::move(m.positions), std::move(tris), c.s.name, &closed, generated);
    if (!closed)
        d_.warn(c.s.line, c.s.col,
                what +
                    " is not closed: inside and outside come from the generalized winding number, "
                    "which bridges small holes");
    return leafOf(c, f, c.s.name);
}

FieldPtr Evaluator::call(const Statement& s, const Scope& outer, int depth) {
    // Special variables given as arguments ($fn = 0, ...) apply to this call.
    Scope scope{{}, &outer};
    for (const Arg& a : s.args)
        if (!a.name.empty() && a.name[0] == '$') scope.vars[a.name] = evaluate(*a.value, outer);
    const std::string& n = s.name;
    const Call c{s, scope, depth};
    if (auto f = primitive3D(c)) return *f;
    if (auto f = shape2D(c)) return *f;
    if (auto f = operation(c)) return *f;
    if (auto f = convexOperation(c)) return *f;
    if (auto f = extensionShape(c)) return *f;
    if (auto f = sceneStatement(c)) return *f;
    if (n == "echo" || n == "assert") return nullptr;
    static const char* unsupported[] = {"projection", "roof", "children", "let", "for", "intersection_for", "if"};
    for (const char* u : unsupported)
        if (n == u)
            throw EvalError{
                s.line, s.col,
                "'" + n + "' is not supported (isoforge reads the CSG subset of OpenSCAD; see docs/scene-language.md)"};
    throw EvalError{s.line, s.col, "unknown module '" + n + "'"};
}

std::optional<FieldPtr> Evaluator::sceneStatement(const Call& site) {
    const Statement& s = site.s;
    const Scope& scope = site.scope;
    const std::string& n = s.name;
    auto args = [&](std::vector<std::string> order) { return Args(s, scope, order); };
    // --- scene statements
    if (n == "camera") {
        Args a = args({"eye", "target", "up", "fov", "orthographic"});
        scene_.camera.given = true;
        scene_.camera.eye = glm::vec3(a.vec3("eye", glm::dvec3(scene_.camera.eye), false));
        scene_.camera.target = glm::vec3(a.vec3("target", glm::dvec3(scene_.camera.target), false));
        scene_.camera.up = glm::vec3(a.vec3("up", glm::dvec3(scene_.camera.up), false));
        scene_.camera.fov = float(a.number("fov", scene_.camera.fov));
        scene_.camera.orthographic = a.boolean("orthographic", false);
        if (scene_.camera.fov <= 0 || scene_.camera.fov >= 180)
            throw a.error("fov", "fov must be between 0 and 180 degrees");
        return nullptr;
    }
    if (n == "light") {
        Args a = args({"direction", "color", "intensity"});
        Light l;
        if (a.has("position")) {
            l.point = true;
            l.vector = glm::vec3(a.vec3("position", std::nullopt, false));
        } else {
            l.vector = glm::vec3(a.vec3("direction", glm::dvec3(l.vector), false));
        }
        l.color = glm::vec3(a.vec3("color", glm::dvec3(1.0)));
        l.intensity = float(a.number("intensity", 1.0));
        scene_.lights.push_back(l);
        return nullptr;
    }
    if (n == "background") {
        Args a = args({"color"});
        if (a.has("color")) scene_.backgroundTop = scene_.backgroundBottom = glm::vec3(a.vec3("color"));
        if (a.has("top")) scene_.backgroundTop = glm::vec3(a.vec3("top"));
        if (a.has("bottom")) scene_.backgroundBottom = glm::vec3(a.vec3("bottom"));
        return nullptr;
    }
    return std::nullopt;
}

}  // namespace isoforge::csg
