// Fields and CSG from Python: primitives, shape specifications, expressions, .vm models, booleans as
// operators (| & -), smooth booleans, transforms; evaluation on numpy points; sampling and meshing.
#include <cmath>
#include <filesystem>

#include <glm/gtc/matrix_transform.hpp>

#include "csg/nodes.h"
#include "csg/scene.h"
#include "implicit/primitives.h"
#include "implicit/shape_spec.h"
#include "implicit/tape.h"
#include "python/common.h"
#include "volume/sample.h"

namespace isoforge::python {

namespace {

PyField wrap(implicit::FieldPtr f) {
    return PyField{std::move(f), implicit::Box3::everything()};
}

PyField boolean(csg::BoolOp op, const std::vector<PyField>& fields, float k) {
    if (fields.empty()) throw py::value_error("a boolean needs at least one field");
    if (!(k >= 0.f) || !std::isfinite(k)) throw py::value_error("k (the blend radius) must be a number >= 0");
    std::vector<implicit::FieldPtr> children;
    implicit::Box3 clip = fields.front().clip;
    for (const auto& f : fields) {
        children.push_back(f.field);
        if (&f != &fields.front()) clip = op == csg::BoolOp::Union ? clip.unite(f.clip) : clip.intersect(f.clip);
    }
    if (op == csg::BoolOp::Difference) clip = fields.front().clip;  // the rest only cut it
    return PyField{csg::makeBoolean(op, std::move(children), k), clip};
}

PyField transformed(const PyField& f, const glm::mat4& m) {
    PyField r{implicit::makeTransformed(f.field, m), implicit::Box3::everything()};
    if (f.clip.isBounded()) {  // the clip box moves with the field: the box of its moved corners
        implicit::Box3 b;
        for (int i = 0; i < 8; ++i) {
            const glm::vec3 c((i & 1) ? f.clip.max.x : f.clip.min.x, (i & 2) ? f.clip.max.y : f.clip.min.y,
                              (i & 4) ? f.clip.max.z : f.clip.min.z);
            const glm::vec3 p = glm::vec3(m * glm::vec4(c, 1.f));
            b = b.unite({p, p});
        }
        r.clip = b;
    }
    return r;
}

float positive(float v, const char* what) {
    if (!(v > 0.f) || !std::isfinite(v)) throw py::value_error(std::string(what) + " must be a positive number");
    return v;
}

}  // namespace

PyGrid sampleField(const PyField& f, float voxel, float halfWidth, const py::object& progress) {
    if (!(halfWidth >= 1.f)) throw py::value_error("half_width must be at least 1 voxel");
    volume::SampleOptions so;
    so.voxelSize = voxel;
    so.halfWidth = halfWidth;
    so.clip = f.clip;
    openvdb::FloatGrid::Ptr grid = runLong(progress, [&](Progress* p) {
        so.progress = p;
        auto g = volume::sample(f.field, so);
        g->setName("field");
        return g;
    });
    return PyGrid{grid, f.field};
}

void bindFields(py::module_& m) {
    py::class_<PyField>(
        m, "Field",
        "An implicit field R^3 -> R, negative inside: primitives, CSG, expressions, .vm models, scenes.\n"
        "Combine with | (union), & (intersection) and - (difference).")
        .def("__or__",
             [](const PyField& a, const PyField& b) {
                 return boolean(csg::BoolOp::Union, {a, b}, 0.f);
             })
        .def("__and__",
             [](const PyField& a, const PyField& b) {
                 return boolean(csg::BoolOp::Intersection, {a, b}, 0.f);
             })
        .def("__sub__",
             [](const PyField& a, const PyField& b) {
                 return boolean(csg::BoolOp::Difference, {a, b}, 0.f);
             })
        .def(
            "translate",
            [](const PyField& f, const py::object& t) {
                return transformed(f, glm::translate(glm::mat4(1.f), toVec3(t, "translate")));
            },
            py::arg("offset"), "Moved by offset (x, y, z)")
        .def(
            "rotate",
            [](const PyField& f, float degrees, const py::object& axis) {
                const glm::vec3 a = toVec3(axis, "axis");
                if (!(glm::length(a) > 0.f)) throw py::value_error("rotate: a zero axis");
                return transformed(f, glm::rotate(glm::mat4(1.f), glm::radians(degrees), glm::normalize(a)));
            },
            py::arg("degrees"), py::arg("axis") = py::make_tuple(0, 0, 1),
            "Rotated by an angle in degrees (OpenSCAD's unit) about an axis through the origin (default z)")
        .def(
            "scale",
            [](const PyField& f, const py::object& s) {
                const glm::vec3 v = toVec3(s, "scale");
                if (!(v.x != 0.f && v.y != 0.f && v.z != 0.f)) throw py::value_error("scale: a zero factor");
                return transformed(f, glm::scale(glm::mat4(1.f), v));
            },
            py::arg("factor"), "Scaled by a number or (sx, sy, sz); distances stay conservative")
        .def(
            "offset",
            [](const PyField& f, float r) {
                return PyField{implicit::makeOffset(f.field, r), f.clip};
            },
            py::arg("r"), "Grown (r > 0) or shrunk (r < 0) by r")
        .def(
            "shell",
            [](const PyField& f, float t) {
                return PyField{implicit::makeShell(f.field, positive(t, "thickness")), f.clip};
            },
            py::arg("thickness"), "A hollow shell of this thickness centred on the surface")
        .def(
            "color",
            [](const PyField& f, const py::object& c) {
                glm::vec4 rgba(1.f);
                if (py::isinstance<py::str>(c)) {
                    bool ok = false;
                    rgba = csg::parseColor(c.cast<std::string>(), ok);
                    if (!ok) throw py::value_error("unknown colour '" + c.cast<std::string>() + "'");
                } else {
                    const auto v = c.cast<std::vector<float>>();
                    if (v.size() != 3 && v.size() != 4)
                        throw py::value_error("color: a name, (r, g, b) or (r, g, b, a)");
                    rgba = glm::vec4(v[0], v[1], v[2], v.size() == 4 ? v[3] : 1.f);
                }
                return PyField{csg::makeColored(f.field, rgba), f.clip};
            },
            py::arg("color"), "Coloured: an SVG name ('steelblue'), '#rrggbb', or (r, g, b[, a]) in [0, 1]")
        .def(
            "clip",
            [](const PyField& f, const py::object& box) {
                return PyField{f.field, f.clip.intersect(toBox(box))};
            },
            py::arg("box"), "Sampled and meshed only within ((x0, y0, z0), (x1, y1, z1)) (needed for unbounded fields)")
        .def(
            "__call__",
            [](const PyField& f, const py::array_t<float, py::array::c_style | py::array::forcecast>& points) {
                if (points.ndim() != 2 || points.shape(1) != 3)
                    throw py::value_error("expected points of shape (N, 3)");
                const std::size_t n = std::size_t(points.shape(0));
                py::array_t<float> out(static_cast<py::ssize_t>(n));
                const auto* p = reinterpret_cast<const glm::vec3*>(points.data());
                float* o = out.mutable_data();
                {
                    py::gil_scoped_release release;
                    f.field->values({p, n}, {o, n});
                }
                return out;
            },
            py::arg("points"), "Values at points (N, 3) -> (N,) float32, negative inside")
        .def_property_readonly(
            "bounds", [](const PyField& f) { return fromBox(volume::sampleDomain(*f.field, f.clip)); },
            "Where the surface can be: ((x0, y0, z0), (x1, y1, z1)) (infinite for unbounded fields)")
        .def_property_readonly(
            "is_distance", [](const PyField& f) { return f.field->isDistance(); },
            "True when the values are conservative distances")
        .def(
            "sample",
            [](const PyField& f, const py::object& voxel, const py::object& resolution, float halfWidth,
               const py::object& progress) {
                return sampleField(f, voxelFor(f, voxel, resolution), halfWidth, progress);
            },
            py::kw_only(), py::arg("voxel") = py::none(), py::arg("resolution") = py::none(),
            py::arg("half_width") = 3.f, py::arg("progress") = py::none(),
            "A sparse grid (iso.Grid): a narrow-band level set for distance fields. voxel (world units) or\n"
            "resolution (voxels along the longest side; default 256)")
        .def(
            "mesh",
            [](const PyField& f, const py::object& voxel, const py::object& resolution, bool sharp, double maxError,
               bool normals, float halfWidth, const py::object& progress, double creaseAngle) {
                const PyGrid g = sampleField(f, voxelFor(f, voxel, resolution), halfWidth, progress);
                return meshGrid(g, 0.f, "auto", normals, sharp, maxError, progress, creaseAngle);
            },
            py::kw_only(), py::arg("voxel") = py::none(), py::arg("resolution") = py::none(), py::arg("sharp") = false,
            py::arg("max_error") = 0.0, py::arg("normals") = false, py::arg("half_width") = 3.f,
            py::arg("progress") = py::none(), py::arg("crease_angle") = 30.0,
            "The closed, oriented mesh of the surface (iso.Mesh), as `isoforge mesh` makes it: sharp=True for\n"
            "feature vertices on edges and corners, max_error > 0 to simplify within that distance")
        .def("__repr__", [](const PyField& f) { return "<isoforge.Field " + f.field->describe() + ">"; });

    m.def(
        "union", [](const std::vector<PyField>& fs, float k) { return boolean(csg::BoolOp::Union, fs, k); },
        py::arg("fields"), py::kw_only(), py::arg("k") = 0.f, "Union of fields (smooth with blend radius k > 0)");
    m.def(
        "intersection",
        [](const std::vector<PyField>& fs, float k) { return boolean(csg::BoolOp::Intersection, fs, k); },
        py::arg("fields"), py::kw_only(), py::arg("k") = 0.f, "Intersection (smooth with k > 0)");
    m.def(
        "difference", [](const std::vector<PyField>& fs, float k) { return boolean(csg::BoolOp::Difference, fs, k); },
        py::arg("fields"), py::kw_only(), py::arg("k") = 0.f, "The first field minus the others (smooth with k > 0)");
    m.def(
        "smooth_union",
        [](const PyField& a, const PyField& b, float k) {
            return boolean(csg::BoolOp::Union, {a, b}, k);
        },
        py::arg("a"), py::arg("b"), py::kw_only(), py::arg("k"), "Union blended over radius k (Quilez's smooth min)");
    m.def(
        "smooth_intersection",
        [](const PyField& a, const PyField& b, float k) {
            return boolean(csg::BoolOp::Intersection, {a, b}, k);
        },
        py::arg("a"), py::arg("b"), py::kw_only(), py::arg("k"), "Intersection blended over radius k");
    m.def(
        "smooth_difference",
        [](const PyField& a, const PyField& b, float k) {
            return boolean(csg::BoolOp::Difference, {a, b}, k);
        },
        py::arg("a"), py::arg("b"), py::kw_only(), py::arg("k"), "a minus b blended over radius k");

    m.def(
        "sphere", [](float r) { return wrap(implicit::makeSphere(positive(r, "r"))); }, py::arg("r") = 1.f,
        "Sphere of radius r at the origin");
    m.def(
        "box",
        [](const py::object& size, float rounding) {
            const glm::vec3 s = toVec3(size, "size");
            positive(std::min({s.x, s.y, s.z}), "size");
            return wrap(implicit::makeBox(s, rounding));
        },
        py::arg("size") = 1.f, py::kw_only(), py::arg("rounding") = 0.f,
        "Box centred at the origin: full edge lengths (a number or (x, y, z)), edges rounded by `rounding`");
    m.def(
        "cylinder", [](float r, float h) { return wrap(implicit::makeCylinder(positive(r, "r"), positive(h, "h"))); },
        py::arg("r") = 1.f, py::arg("h") = 2.f, "Capped cylinder along z, centred");
    m.def(
        "cone",
        [](float r1, float r2, float h) {
            if (!(r1 >= 0.f && r2 >= 0.f && r1 + r2 > 0.f)) throw py::value_error("cone: radii >= 0, not both 0");
            return wrap(implicit::makeCone(r1, r2, positive(h, "h")));
        },
        py::arg("r1") = 1.f, py::arg("r2") = 0.f, py::arg("h") = 2.f,
        "Capped cone (frustum) along z, centred: bottom radius r1, top radius r2");
    m.def(
        "torus", [](float R, float r) { return wrap(implicit::makeTorus(positive(R, "R"), positive(r, "r"))); },
        py::arg("R") = 1.f, py::arg("r") = 0.25f, "Torus in the xy plane: major radius R, minor radius r");
    m.def(
        "capsule", [](float r, float h) { return wrap(implicit::makeCapsule(positive(r, "r"), h)); },
        py::arg("r") = 0.5f, py::arg("h") = 1.f, "Capsule along z: radius r around a segment of length h");
    m.def(
        "ellipsoid",
        [](const py::object& radii) {
            const glm::vec3 r = toVec3(radii, "radii");
            positive(std::min({r.x, r.y, r.z}), "radii");
            return wrap(implicit::makeEllipsoid(r));
        },
        py::arg("radii"), "Ellipsoid with semi-axes (a, b, c)");
    m.def(
        "plane",
        [](const py::object& normal, float offset) {
            const glm::vec3 n = toVec3(normal, "normal");
            if (!(glm::length(n) > 0.f)) throw py::value_error("plane: a zero normal");
            return wrap(implicit::makePlane(n, offset));
        },
        py::arg("normal") = py::make_tuple(0, 0, 1), py::arg("offset") = 0.f,
        "Half-space dot(normal, p) <= offset (unbounded: clip() it before sampling)");
    m.def(
        "shape", [](const std::string& spec) { return wrap(implicit::parseShape(spec)); }, py::arg("spec"),
        "A shape as `isoforge mesh --shape` takes it, e.g. \"torus(R=1, r=0.3)\" (see `isoforge shapes`)");
    m.def(
        "expr",
        [](const std::string& text, const py::object& box) {
            PyField f =
                wrap(implicit::makeTapeField(implicit::parseExpression(text), implicit::Box3::everything(), text));
            f.clip = toBox(box);
            return f;
        },
        py::arg("text"), py::kw_only(), py::arg("box") = py::none(),
        "An algebraic surface f(x, y, z) = 0, negative inside, as `--expr` takes it; give box for sampling");
    m.def(
        "vm",
        [](const std::string& path) {
            PyField f = wrap(implicit::makeTapeField(implicit::readVmFile(path), implicit::Box3::everything(),
                                                     std::filesystem::path(path).filename().string()));
            f.clip = {glm::vec3(-1.f), glm::vec3(1.f)};  // the command line's domain for .vm models
            return f;
        },
        py::arg("path"), "A .vm model (fidget's SSA format), sampled over [-1, 1]^3");
}

}  // namespace isoforge::python
