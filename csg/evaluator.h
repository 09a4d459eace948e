#pragma once
/// @file Internal to csg/: evaluation of a parsed scene into fields, module call by module call.
/// evaluator.cpp runs statement lists and dispatches calls (and holds the scene statements);
/// evaluator_shapes.cpp makes the leaf shapes, evaluator_operations.cpp the operations on children.

#include <algorithm>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <glm/mat4x4.hpp>

#include "csg/args.h"
#include "csg/diagnostics.h"
#include "csg/parts.h"
#include "csg/profile.h"
#include "csg/scene.h"
#include "csg/syntax.h"
#include "csg/value.h"
#include "mesh/parametric.h"
#include "mesh/trimesh.h"

namespace isoforge::csg {

using implicit::FieldPtr;

class Evaluator {
public:
    Evaluator(Diagnostics& d, Scene& scene, std::filesystem::path dir) : d_(d), scene_(scene), dir_(std::move(dir)) {}

    /// What a list of statements may hold: anything; solids (2D objects beside 3D ones are ignored);
    /// profiles of an extrusion (3D objects are ignored).
    enum class Want { Any, Solids, Profiles };
    /// Fields of the statements in order (assignments first update the scope, as OpenSCAD does).
    std::vector<FieldPtr> run(const std::vector<Statement>& list, Scope& scope, int depth, Want want = Want::Solids);
    /// The top level of a scene: several objects there are a union, as in OpenSCAD.
    std::vector<FieldPtr> runScene(const std::vector<Statement>& list, Scope& scope) {
        return combining(list, [&] { return run(list, scope, 0); });
    }
    FieldPtr rootOverride() const { return root_; }
    /// The 2D field of a sanitized profile (outlines and holes under the even-odd rule).
    static FieldPtr profileField(const Profile& p);
    /// Whether a field is a 2D object (bounded in x and y, the same along z).
    static bool planar(const FieldPtr& f);
    std::string outline;

private:
    /// One module call: the statement, its scope (with the special variables it sets), its depth.
    struct Call {
        const Statement& s;
        const Scope& scope;
        int depth;
    };

    /// Evaluates `body` (the statements `list`) counted as inside a boolean operation when the list
    /// holds two or more objects: OpenSCAD runs CGAL on those, and it refuses some polyhedra there.
    template <class Body>
    std::vector<FieldPtr> combining(const std::vector<Statement>& list, Body body) {
        const bool combines =
            std::count_if(list.begin(), list.end(), [](const Statement& st) { return !st.assignment; }) >= 2;
        booleans_ += combines;
        struct Restore {
            int& n;
            bool c;
            ~Restore() { n -= c; }
        } restore{booleans_, combines};
        return body();
    }
    void note(int depth, const std::string& what, const Statement& s);
    /// OpenSCAD's number of fragments of a circle of radius r; 0 for an exact smooth shape.
    int fragments(const Scope& scope, const Statement& s, double r);
    std::vector<FieldPtr> children(const Statement& s, const Scope& scope, int depth, Want want = Want::Solids);
    FieldPtr group(const Statement& s, const Scope& scope, int depth);
    FieldPtr transformed(const Statement& s, const Scope& scope, int depth, const glm::dmat4& m);
    std::string path(const std::string& p) const;
    void primitive() { ++scene_.primitives; }
    static int resolutionArg(const Args& a, int def);
    static mesh::NurbsSurface nurbsSurface(const Args& a);

    FieldPtr call(const Statement& s, const Scope& outer, int depth);
    /// Warns that the call makes nothing (a degenerate object OpenSCAD also skips): an empty field.
    FieldPtr dropped(const Call& site, const std::string& why);
    /// A leaf shape (it warns about children, counts the primitive and notes it in the outline).
    FieldPtr leafOf(const Call& c, FieldPtr f, const std::string& what);
    /// A triangle mesh as a solid: a file (any mesh, inside from the winding number) or one we
    /// tessellated (closed ones are trusted to be oriented, so the sign comes from pseudonormals).
    FieldPtr meshLeafOf(const Call& c, mesh::TriMesh m, const std::string& what, bool generated);
    // Each returns nothing when the call is not one of its modules (evaluator_shapes.cpp,
    // evaluator_operations.cpp, evaluator.cpp).
    std::optional<FieldPtr> primitive3D(const Call& site);
    FieldPtr fileShape(const Call& site);
    std::optional<FieldPtr> shape2D(const Call& site);
    std::optional<FieldPtr> extensionShape(const Call& site);
    std::optional<FieldPtr> operation(const Call& site);
    /// hull() and minkowski() (evaluator_hull.cpp).
    std::optional<FieldPtr> convexOperation(const Call& site);
    std::optional<FieldPtr> sceneStatement(const Call& site);

    /// OpenSCAD's polygons of the 2D objects made of circle, square, polygon, 2D transforms, colours
    /// and booleans (csg/profile.h), by field: what a twisted extrusion builds its walls on. Each
    /// entry holds its field, so that no other field takes its address.
    FieldPtr withProfile(FieldPtr f, Profile p);
    const Profile* profileOf(const FieldPtr& f) const;
    /// The boolean of the children's profiles, when each child has one.
    std::optional<Profile> combinedProfile(const std::vector<FieldPtr>& kids, ProfileOp op) const;
    /// OpenSCAD's linear_extrude mesh for a twist or an uneven scale (nothing for other extrusions, or
    /// a child without a profile).
    FieldPtr slicedExtrusion(const Call& site, const std::vector<FieldPtr>& kids, const ExtrudeParams& e);

    /// The polyhedral geometry of solids that have one (csg/parts.h), by field, as profiles_ for 2D:
    /// what hull() and minkowski() take from their children.
    /// Made when first asked for (most scenes never ask): `make` gives nothing where the object has
    /// no parts after all (a difference of non-convex objects).
    using PartsMaker = std::function<std::optional<Parts>()>;
    FieldPtr withParts(FieldPtr f, PartsMaker make);
    const Parts* partsOf(const FieldPtr& f);
    bool hasParts(const std::vector<FieldPtr>& kids) const;
    std::optional<Parts> combinedParts(const std::vector<FieldPtr>& kids);
    /// Both side maps of the children carried to `f` (a union, a colour, a transform by `m`).
    FieldPtr carried(FieldPtr f, const std::vector<FieldPtr>& kids, const glm::dmat4* m = nullptr);
    /// The parts of a difference or an intersection `f` of the children, where they have some.
    void carryParts(const FieldPtr& f, const std::vector<FieldPtr>& kids, bool difference);

    Diagnostics& d_;
    std::map<const implicit::Field*, std::pair<FieldPtr, Profile>> profiles_;
    struct LazyParts {
        FieldPtr field;
        PartsMaker make;
        bool made = false;
        std::optional<Parts> parts;
    };
    std::map<const implicit::Field*, LazyParts> parts_;
    Scene& scene_;
    std::filesystem::path dir_;
    FieldPtr root_;
    int booleans_ = 0;  ///< enclosing boolean operations of two or more objects
};

}  // namespace isoforge::csg
