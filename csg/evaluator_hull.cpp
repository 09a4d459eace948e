// hull() and minkowski(): OpenSCAD computes both on its children's polygons and polyhedra, not on
// fields, so the evaluator keeps that geometry beside the fields that have it (csg/parts.h for
// solids, csg/profile.h for 2D objects) and builds the result from it: a convex polytope for a
// hull, a union of polytopes (and moved meshes) for a Minkowski sum.
#include <algorithm>
#include <stdexcept>

#include "csg/evaluator.h"
#include "csg/nodes.h"
#include "csg/polytope.h"
#include "csg/shapes.h"

namespace isoforge::csg {

FieldPtr Evaluator::profileField(const Profile& p) {
    std::vector<glm::vec2> points;
    std::vector<std::vector<int>> paths;
    for (const Outline2& o : p.outlines) {
        paths.emplace_back();
        for (const glm::dvec2& q : o.points) {
            paths.back().push_back(static_cast<int>(points.size()));
            points.emplace_back(q);
        }
    }
    return makePolygon2D(std::move(points), std::move(paths));
}

std::optional<FieldPtr> Evaluator::convexOperation(const Call& site) {
    const Statement& s = site.s;
    const std::string& n = s.name;
    if (n != "hull" && n != "minkowski") return std::nullopt;
    const bool hull = n == "hull";
    Args(s, site.scope, {"convexity"});  // checks the arguments
    note(site.depth, n, s);
    // OpenSCAD takes a hull's points from its children as they are, but converts a Minkowski sum's
    // children to CGAL polyhedra, as it does for booleans.
    auto kids = hull ? children(s, site.scope, site.depth)
                     : combining(s.children, [&] { return children(s, site.scope, site.depth); });
    if (kids.empty()) return nullptr;
    if (!hull && kids.size() == 1) return kids[0];  // OpenSCAD copies a lone child
    if (planar(kids[0])) {
        std::vector<const Profile*> ps;
        for (const FieldPtr& k : kids) {
            const Profile* p = profileOf(k);
            if (!p)
                throw EvalError{s.line, s.col,
                                n + "() of 2D objects needs their outlines (circle, square, polygon, their "
                                    "transforms, colours and booleans); offset() and resize() of 2D objects have none"};
            ps.push_back(p);
        }
        Profile p = hull ? hullProfile(ps) : minkowskiProfile(ps);
        if (p.outlines.empty()) return dropped(site, n + "() of 2D objects without an area");
        FieldPtr f = profileField(p);
        return withProfile(f, std::move(p));
    }
    std::vector<const Parts*> ps;
    static const Parts none;
    for (const FieldPtr& k : kids) {
        if (k->bounds().isEmpty()) {  // an object that makes nothing (an extrusion of a missing file)
            ps.push_back(&none);
            continue;
        }
        const Parts* p = partsOf(k);
        if (!p)
            throw EvalError{
                s.line, s.col,
                n + "() needs its children as polyhedra: primitives, polyhedron(), linear_extrude(), "
                    "their transforms, colours and unions, hull() and minkowski(); a "
                    "rotate_extrude(), or a difference() or intersection() of objects that are not all convex, "
                    "inside it is not supported (it would take exact polyhedral booleans)"};
        ps.push_back(p);
    }
    if (hull) {
        auto h = std::make_shared<const mesh::ConvexHull>(hullOfParts(uniteParts(ps)));
        if (h->empty()) return dropped(site, "hull() of points that do not span a solid");
        return withParts(makeConvexPolytope(*h, "hull"), [h] {
            Parts p;
            p.parts.push_back({h->points, {}, nullptr, h});
            return p;
        });
    }
    // OpenSCAD leaves out children that make nothing.
    ps.erase(std::remove_if(ps.begin(), ps.end(), [](const Parts* p) { return p->parts.empty(); }), ps.end());
    if (ps.empty()) return dropped(site, "minkowski() of objects that make nothing");
    Parts sum = *ps[0];
    try {
        for (std::size_t i = 1; i < ps.size(); ++i) sum = minkowskiParts(sum, *ps[i]);
        FieldPtr f = partsField(sum, "minkowski");
        if (!f) return dropped(site, "minkowski() of objects without a volume");
        return withParts(f, [sum = std::move(sum)] { return sum; });
    } catch (const std::invalid_argument& e) {
        throw EvalError{s.line, s.col, e.what()};
    }
}

}  // namespace isoforge::csg
