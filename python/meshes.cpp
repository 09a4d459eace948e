// iso.Mesh: a TriMesh whose arrays numpy sees in place (no copies), with files, checks and simplification.
#include <cstring>

#include "mesh/check.h"
#include "mesh/io.h"
#include "mesh/simplify.h"
#include "python/common.h"

namespace isoforge::python {

namespace {

/// A (rows, 3) numpy view of `data` kept alive by `owner`.
template <class T, class Element>
py::array_t<T> view(std::vector<Element>& v, const py::object& owner) {
    static_assert(sizeof(Element) == 3 * sizeof(T));
    return py::array_t<T>({py::ssize_t(v.size()), py::ssize_t(3)}, reinterpret_cast<T*>(v.data()), owner);
}

/// Rows of three from an (N, 3) array (converted once if its dtype or layout differ).
template <class Element, class T>
std::vector<Element> rows(const py::array_t<T, py::array::c_style | py::array::forcecast>& a, const char* what) {
    if (a.ndim() != 2 || (a.shape(1) != 3 && a.shape(0) != 0))
        throw py::value_error(std::string(what) + ": expected an array of shape (N, 3)");
    std::vector<Element> out(std::size_t(a.shape(0)));
    if (!out.empty()) std::memcpy(out.data(), a.data(), out.size() * sizeof(Element));
    return out;
}

py::dict reportDict(const mesh::MeshReport& r) {
    py::dict d;
    d["vertices"] = r.vertices;
    d["triangles"] = r.triangles;
    d["edges"] = r.edges;
    d["watertight"] = r.isWatertight();
    d["edge_manifold"] = r.isEdgeManifold();
    d["vertex_manifold"] = r.isVertexManifold();
    d["oriented"] = r.isOriented();
    d["degenerate"] = r.hasDegenerates();
    d["valid_closed_surface"] = r.isValidClosedSurface();
    d["boundary_edges"] = r.boundaryEdges;
    d["non_manifold_edges"] = r.nonManifoldEdges;
    d["non_manifold_vertices"] = r.nonManifoldVertices;
    d["misoriented_edges"] = r.misorientedEdges;
    d["components"] = r.components;
    d["euler_characteristic"] = r.eulerCharacteristic;
    const auto g = r.genus();
    d["genus"] = g ? py::object(py::int_(*g)) : py::object(py::none());
    d["area"] = r.area;
    d["volume"] = r.volume;
    if (r.selfIntersectionsChecked) d["self_intersecting_pairs"] = r.selfIntersections.pairs;
    d["welded_vertices"] = r.weldedVertices;
    return d;
}

}  // namespace

void bindMeshes(py::module_& m) {
    py::class_<mesh::TriMesh>(m, "Mesh",
                              "An indexed triangle mesh. vertices (N, 3) float32, triangles (M, 3) int32 (counter-\n"
                              "clockwise seen from outside), normals and colors (N, 3) float32 or None: views of the\n"
                              "mesh's own memory, not copies.")
        .def(py::init([](const py::array_t<float, py::array::c_style | py::array::forcecast>& vertices,
                         const py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>& triangles,
                         const py::object& normals, const py::object& colors) {
                 mesh::TriMesh t;
                 t.positions = rows<glm::vec3>(vertices, "vertices");
                 if (triangles.ndim() != 2 || (triangles.shape(1) != 3 && triangles.shape(0) != 0))
                     throw py::value_error("triangles: expected an array of shape (M, 3)");
                 const std::int64_t* idx = triangles.data();
                 t.triangles.resize(std::size_t(triangles.shape(0)));
                 for (std::size_t i = 0; i < t.triangles.size(); ++i)
                     for (int k = 0; k < 3; ++k) {
                         const std::int64_t v = idx[3 * i + k];
                         if (v < 0 || std::uint64_t(v) >= t.positions.size())
                             throw py::index_error("triangle " + std::to_string(i) + " names vertex " +
                                                   std::to_string(v) + " of " + std::to_string(t.positions.size()));
                         t.triangles[i][k] = std::uint32_t(v);
                     }
                 auto perVertex = [&](const py::object& a, const char* what) {
                     if (a.is_none()) return std::vector<glm::vec3>{};
                     auto v =
                         rows<glm::vec3>(a.cast<py::array_t<float, py::array::c_style | py::array::forcecast>>(), what);
                     if (v.size() != t.positions.size())
                         throw py::value_error(std::string(what) + ": one row per vertex expected");
                     return v;
                 };
                 t.normals = perVertex(normals, "normals");
                 t.colors = perVertex(colors, "colors");
                 return t;
             }),
             py::arg("vertices"), py::arg("triangles"), py::arg("normals") = py::none(), py::arg("colors") = py::none())
        .def_property_readonly("vertices",
                               [](py::object self) { return view<float>(self.cast<mesh::TriMesh&>().positions, self); })
        .def_property_readonly(
            "triangles",
            [](py::object self) { return view<std::int32_t>(self.cast<mesh::TriMesh&>().triangles, self); })
        .def_property_readonly("normals",
                               [](py::object self) -> py::object {
                                   auto& t = self.cast<mesh::TriMesh&>();
                                   if (t.normals.empty()) return py::none();
                                   return view<float>(t.normals, self);
                               })
        .def_property_readonly("colors",
                               [](py::object self) -> py::object {
                                   auto& t = self.cast<mesh::TriMesh&>();
                                   if (t.colors.empty()) return py::none();
                                   return view<float>(t.colors, self);
                               })
        .def_static(
            "load", [](const std::string& path) { return mesh::readMesh(path); }, py::arg("path"),
            py::call_guard<py::gil_scoped_release>(), "Reads .ply, .obj, .stl or .off (any tool's)")
        .def(
            "save",
            [](const mesh::TriMesh& t, const std::string& path, bool ascii) {
                if (!mesh::isMeshPath(path))
                    throw py::value_error(path + ": expected a .ply, .obj, .stl or .glb file name");
                mesh::writeMesh(path, t, {ascii});
            },
            py::arg("path"), py::kw_only(), py::arg("ascii") = false, py::call_guard<py::gil_scoped_release>(),
            "Writes .ply (binary; ascii=True for text), .obj, .stl or .glb, atomically")
        .def(
            "check",
            [](const mesh::TriMesh& t, bool selfIntersections) {
                mesh::MeshReport r;
                {
                    py::gil_scoped_release release;
                    // With normals, copies of a vertex split at a crease count as one (as `isoforge check`).
                    r = mesh::check(t, {.selfIntersections = selfIntersections, .weldByPosition = !t.normals.empty()});
                }
                return reportDict(r);
            },
            py::kw_only(), py::arg("self_intersections") = false,
            "Watertight, manifold, oriented, degenerate, genus, components, area, volume ... as a dict\n"
            "(`isoforge check`); self_intersections=True also counts intersecting triangle pairs")
        .def(
            "simplify",
            [](const mesh::TriMesh& t, double maxError) {
                if (!(maxError > 0)) throw py::value_error("max_error must be positive");
                py::gil_scoped_release release;
                mesh::TriMesh out = t;
                mesh::simplify(out, maxError);
                return out;
            },
            py::arg("max_error"),
            "A simplified copy: every vertex within max_error of the result, still closed, manifold,\n"
            "oriented and free of self-intersections (`isoforge mesh --max-error`)")
        .def_property_readonly("area", [](const mesh::TriMesh& t) { return mesh::area(t); })
        .def_property_readonly("volume", [](const mesh::TriMesh& t) { return mesh::signedVolume(t); })
        .def("__len__", [](const mesh::TriMesh& t) { return t.triangleCount(); })
        .def("__repr__", [](const mesh::TriMesh& t) {
            return "<isoforge.Mesh " + std::to_string(t.vertexCount()) + " vertices, " +
                   std::to_string(t.triangleCount()) + " triangles>";
        });
}

}  // namespace isoforge::python
