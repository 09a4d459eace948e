// Scenes and images from Python: Scene.load (our language, OpenSCAD's .csg, .scad through openscad) and
// render() of scenes, fields, grids and meshes to uint8 arrays, with the command line's camera and lights.
#include <algorithm>
#include <cmath>

#include "csg/scene.h"
#include "python/common.h"
#include "render/embree_renderer.h"
#include "render/grid_march.h"
#include "render/ray_march.h"
#include "render/scene.h"
#include "volume/marching_cubes.h"
#include "volume/sample.h"
#include "volume/surface_box.h"

namespace isoforge::python {

namespace {

struct PyScene {
    csg::Scene scene;
    PyField field() const { return PyField{scene.root, implicit::Box3::everything()}; }
};

/// The frame as the command line writes it to a PNG: sRGB-encoded, 8 bits, alpha dropped.
py::array_t<std::uint8_t> toArray(const render::Frame& frame) {
    const render::Image img = render::toDisplayImage(frame);
    py::array_t<std::uint8_t> out({py::ssize_t(img.height), py::ssize_t(img.width), py::ssize_t(3)});
    std::uint8_t* o = out.mutable_data();
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
            const float* p = img.at(x, y);
            for (int c = 0; c < 3; ++c) {
                const float v = std::clamp(p[c], 0.f, 1.f);
                const float e = v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.f / 2.4f) - 0.055f;
                *o++ = std::uint8_t(std::clamp(e, 0.f, 1.f) * 255.f + 0.5f);
            }
        }
    return out;
}

implicit::Box3 meshBounds(const std::vector<mesh::TriMesh>& meshes) {
    implicit::Box3 b;
    for (const auto& m : meshes)
        for (const auto& p : m.positions) b = b.unite(implicit::Box3{p, p});
    return b;
}

}  // namespace

void bindScenes(py::module_& m) {
    py::class_<PyScene>(m, "Scene", "A scene: a CSG tree with camera, lights and background")
        .def_static(
            "load",
            [](const std::string& path, const std::vector<std::string>& defines) {
                py::gil_scoped_release release;
                return PyScene{csg::readScene(path, defines)};
            },
            py::arg("path"), py::arg("defines") = std::vector<std::string>{},
            "Reads .isf (our language), .csg (OpenSCAD's export) or .scad (through openscad, with defines\n"
            "['NAME=VALUE', ...] as its -D); raises iso.ParseError with file:line:column")
        .def_static(
            "parse",
            [](const std::string& text, const std::string& name) { return PyScene{csg::parseScene(text, name)}; },
            py::arg("text"), py::arg("name") = "<string>", "Parses scene text")
        .def_property_readonly("field", &PyScene::field, "The scene's CSG tree as an iso.Field")
        .def_property_readonly(
            "warnings",
            [](const PyScene& s) {
                py::list l;
                for (const auto& w : s.scene.warnings) l.append(w.loc.toString() + ": " + w.message);
                return l;
            },
            "Warnings as 'file:line:column: message', OpenSCAD's first for .scad files")
        .def_property_readonly("tree", [](const PyScene& s) { return s.scene.tree; })
        .def_property_readonly("primitives", [](const PyScene& s) { return s.scene.primitives; })
        .def_property_readonly("camera",
                               [](const PyScene& s) -> py::object {
                                   const csg::Camera& c = s.scene.camera;
                                   if (!c.given) return py::none();
                                   py::dict d;
                                   d["eye"] = py::make_tuple(c.eye.x, c.eye.y, c.eye.z);
                                   d["target"] = py::make_tuple(c.target.x, c.target.y, c.target.z);
                                   d["up"] = py::make_tuple(c.up.x, c.up.y, c.up.z);
                                   d["fov"] = c.fov;
                                   d["orthographic"] = c.orthographic;
                                   return d;
                               })
        .def(
            "mesh",
            [](const PyScene& s, const py::object& voxel, const py::object& resolution, bool sharp, double maxError,
               bool normals, float halfWidth, const py::object& progress, double creaseAngle) {
                const PyField f = s.field();
                const PyGrid g = sampleField(f, voxelFor(f, voxel, resolution), halfWidth, progress);
                return meshGrid(g, 0.f, "auto", normals, sharp, maxError, progress, creaseAngle);
            },
            py::kw_only(), py::arg("voxel") = py::none(), py::arg("resolution") = py::none(), py::arg("sharp") = false,
            py::arg("max_error") = 0.0, py::arg("normals") = false, py::arg("half_width") = 3.f,
            py::arg("progress") = py::none(), py::arg("crease_angle") = 30.0,
            "The scene's mesh, as `isoforge mesh scene.csg` makes it")
        .def("__repr__", [](const PyScene& s) {
            return "<isoforge.Scene " + std::to_string(s.scene.primitives) + " primitives, " +
                   std::to_string(s.scene.warnings.size()) + " warnings>";
        });

    m.def(
        "render",
        [](const py::object& what, const std::pair<int, int>& size, const std::string& methodArg, int spp, bool shadows,
           const py::object& resolution, const py::object& progress) {
            const auto [width, height] = size;
            if (width <= 0 || height <= 0 || double(width) * height > 2.5e8)
                throw py::value_error("size must be (width, height), at most 250 megapixels");
            if (spp < 1) throw py::value_error("spp must be at least 1");
            if (methodArg != "auto" && methodArg != "mesh" && methodArg != "march")
                throw py::value_error("method must be 'auto', 'mesh' or 'march'");
            render::RenderOptions opt;
            opt.width = width;
            opt.height = height;
            opt.spp = spp;
            opt.shadows = shadows;
            render::Look look;
            bool haveCamera = false;
            PyField field;
            const mesh::TriMesh* meshIn = nullptr;
            const PyGrid* grid = nullptr;
            if (py::isinstance<PyScene>(what)) {
                const csg::Scene& s = what.cast<const PyScene&>().scene;
                field = PyField{s.root, implicit::Box3::everything()};
                look.camera.eye = s.camera.eye;
                look.camera.target = s.camera.target;
                look.camera.up = s.camera.up;
                look.camera.fov = s.camera.fov;
                look.camera.orthographic = s.camera.orthographic;
                haveCamera = s.camera.given;
                for (const auto& l : s.lights) look.lights.push_back({l.point, l.vector, l.color, l.intensity});
                look.backgroundTop = s.backgroundTop;
                look.backgroundBottom = s.backgroundBottom;
            } else if (py::isinstance<PyField>(what)) {
                field = what.cast<PyField>();
            } else if (py::isinstance<mesh::TriMesh>(what)) {
                meshIn = &what.cast<const mesh::TriMesh&>();
            } else if (py::isinstance<PyGrid>(what)) {
                grid = &what.cast<const PyGrid&>();
            } else {
                throw py::type_error("render takes an iso.Scene, iso.Field, iso.Grid or iso.Mesh");
            }
            std::string method = methodArg;
            if (method == "auto") method = grid ? "march" : "mesh";
            if (meshIn && method == "march") throw py::value_error("a mesh is rendered with method='mesh'");
            const float voxel =
                field.field ? voxelFor(field, py::none(), resolution.is_none() ? py::int_(512) : resolution) : 0.f;
            const render::Frame frame = runLong(progress, [&](Progress* p) {
                opt.progress = p;
                std::vector<mesh::TriMesh> meshes;
                std::vector<implicit::Material> materials;
                implicit::Box3 bounds;
                if (meshIn) {
                    meshes.push_back(*meshIn);
                    materials.emplace_back();
                } else if (field.field) {
                    bounds = volume::sampleDomain(*field.field, field.clip);
                    if (method == "mesh") {
                        volume::SampleOptions so;
                        so.voxelSize = voxel;
                        so.clip = field.clip;
                        so.progress = p;
                        volume::MeshingOptions mo;
                        mo.normals = true;
                        mo.progress = p;
                        const mesh::TriMesh mm = volume::extractIsosurface(*volume::sample(field.field, so), mo);
                        meshes = render::splitByMaterial(mm, *field.field, materials);
                    }
                } else {
                    const openvdb::CoordBBox ab = grid->grid->evalActiveVoxelBoundingBox();
                    if (!ab.empty()) {
                        const openvdb::BBoxd w = grid->grid->transform().indexToWorld(ab);
                        bounds = {glm::vec3(float(w.min().x()), float(w.min().y()), float(w.min().z())),
                                  glm::vec3(float(w.max().x()), float(w.max().y()), float(w.max().z()))};
                    }
                    if (method == "mesh") {
                        volume::MeshingOptions mo;
                        mo.normals = true;
                        mo.progress = p;
                        meshes.push_back(volume::extractIsosurface(*grid->grid, mo));
                        materials.emplace_back();
                    }
                }
                if (!meshes.empty()) bounds = meshBounds(meshes);
                if (!haveCamera) {
                    const float aspect = float(width) / float(height);
                    implicit::Box3 frameOf =
                        bounds.isEmpty() ? implicit::Box3{glm::vec3(-1.f), glm::vec3(1.f)} : bounds;
                    // As `isoforge render` frames a marched field: its surface's box, not its bounds.
                    if (field.field && meshes.empty()) frameOf = volume::framingBox(field.field, field.clip);
                    look.camera = render::frameBox(frameOf, aspect);
                }
                if (method == "mesh") {
                    std::vector<render::MeshObject> objs;
                    for (std::size_t i = 0; i < meshes.size(); ++i) objs.push_back({&meshes[i], materials[i], true});
                    return render::renderMeshes(objs, look, opt);
                }
                if (grid)
                    return render::marchGrid(*grid->grid, {render::IsoLayer{}},
                                             volume::insideIsBelow(*grid->grid, volume::InsideSide::Auto), look, opt);
                return render::marchField(field.field, bounds, look, opt);
            });
            return toArray(frame);
        },
        py::arg("what"), py::kw_only(), py::arg("size") = std::pair<int, int>(800, 600), py::arg("method") = "auto",
        py::arg("spp") = 1, py::arg("shadows") = true, py::arg("resolution") = py::none(),
        py::arg("progress") = py::none(),
        "Renders a Scene, Field, Grid or Mesh as `isoforge render` does -> uint8 array (height, width, 3),\n"
        "sRGB. method: 'mesh' (marching cubes at `resolution`, default 512, then Embree), 'march' (rays\n"
        "against the field or grid, no mesh), 'auto' (march for grids, mesh otherwise). The scene's camera,\n"
        "else a view framing what is drawn.");
}

}  // namespace isoforge::python
