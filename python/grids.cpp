// iso.Grid: sparse OpenVDB float grids from fields, files and arrays; meshed with the command line's pipeline.
#include <openvdb/tools/Dense.h>

#include "core/error.h"
#include "mesh/crease_normals.h"
#include "python/common.h"
#include "volume/dense_grid.h"
#include "volume/sample.h"
#include "volume/surface.h"
#include "volume/vdb_io.h"

namespace isoforge::python {

namespace {

volume::InsideSide insideSide(const std::string& inside) {
    if (inside == "auto") return volume::InsideSide::Auto;
    if (inside == "below") return volume::InsideSide::Below;
    if (inside == "above") return volume::InsideSide::Above;
    throw py::value_error("inside must be 'auto', 'below' or 'above', not '" + inside + "'");
}

py::tuple coords(const openvdb::Coord& c) {
    return py::make_tuple(c.x(), c.y(), c.z());
}

}  // namespace

mesh::TriMesh meshGrid(const PyGrid& g, float iso, const std::string& inside, bool normals, bool sharp, double maxError,
                       const py::object& progress, double creaseAngle) {
    if (!(creaseAngle >= 0 && creaseAngle <= 180)) throw py::value_error("crease_angle must be in [0, 180]");
    volume::SurfaceOptions o;
    o.isovalue = iso;
    o.inside = insideSide(inside);
    o.normals = normals;
    o.sharp = sharp;
    if (maxError < 0) throw py::value_error("max_error must be >= 0");
    o.maxError = maxError;
    return runLong(progress, [&](Progress* p) {
        o.progress = p;
        mesh::TriMesh m = volume::meshSurface(*g.grid, g.field, o);
        if (sharp && normals) mesh::splitNormalsAtCreases(m, creaseAngle);
        return m;
    });
}

void bindGrids(py::module_& m) {
    py::class_<PyGrid>(m, "Grid", "A sparse OpenVDB float grid (a narrow-band level set, or a scalar/fog volume)")
        .def_static(
            "load",
            [](const std::string& path, const py::object& name) {
                py::gil_scoped_release release;
                return PyGrid{volume::readFloatGrid(
                                  path, name.is_none() ? std::nullopt : std::optional(name.cast<std::string>())),
                              nullptr};
            },
            py::arg("path"), py::arg("grid") = py::none(),
            "Reads a float grid from a .vdb file: the one named `grid`, else the first (a level set if any)")
        .def_static(
            "from_numpy",
            [](const py::array_t<float, py::array::f_style | py::array::forcecast>& a, float voxel,
               const py::object& origin, const py::object& affine, const py::object& background) {
                if (a.ndim() != 3) throw py::value_error("expected a 3D array");
                // Fortran order: i fastest, the layout the grid reads in place (C-ordered input is converted once).
                volume::VolumeView v{a.data(), {a.shape(0), a.shape(1), a.shape(2)}, glm::dmat4(1.0), "numpy"};
                if (!affine.is_none()) {
                    const auto mat = affine.cast<py::array_t<double, py::array::c_style | py::array::forcecast>>();
                    if (mat.ndim() != 2 || mat.shape(0) != 4 || mat.shape(1) != 4)
                        throw py::value_error("affine: a 4x4 matrix from (i, j, k, 1) to world coordinates");
                    for (int r = 0; r < 4; ++r)
                        for (int c = 0; c < 4; ++c) v.indexToWorld[c][r] = mat.at(r, c);
                } else {
                    if (!(voxel > 0.f)) throw py::value_error("voxel must be positive");
                    const glm::vec3 o = toVec3(origin, "origin");
                    v.indexToWorld = glm::dmat4(double(voxel));
                    v.indexToWorld[3] = glm::dvec4(o.x, o.y, o.z, 1.0);
                }
                volume::ToGridOptions opt;
                if (!background.is_none()) opt.background = background.cast<float>();
                py::gil_scoped_release release;
                return PyGrid{volume::toGrid(v, opt), nullptr};
            },
            py::arg("array"), py::kw_only(), py::arg("voxel") = 1.f, py::arg("origin") = py::make_tuple(0, 0, 0),
            py::arg("affine") = py::none(), py::arg("background") = py::none(),
            "A sparse grid of array[i, j, k] at origin + voxel * (i, j, k), or at affine @ (i, j, k, 1) (as\n"
            "read_volume returns it); values equal to the background (default: the minimum) are left out;\n"
            "meshed with values above the iso-value inside (densities, CT)")
        .def(
            "save",
            [](const PyGrid& g, const std::string& path) {
                py::gil_scoped_release release;
                volume::writeVdb(path, {g.grid});
            },
            py::arg("path"), "Writes a .vdb file atomically")
        .def(
            "mesh",
            [](const PyGrid& g, float iso, const std::string& inside, bool normals, bool sharp, double maxError,
               const py::object& progress, double creaseAngle) {
                return meshGrid(g, iso, inside, normals, sharp, maxError, progress, creaseAngle);
            },
            py::kw_only(), py::arg("iso") = 0.f, py::arg("inside") = "auto", py::arg("normals") = false,
            py::arg("sharp") = false, py::arg("max_error") = 0.0, py::arg("progress") = py::none(),
            py::arg("crease_angle") = 30.0,
            "The iso-surface (iso.Mesh), closed and oriented outward: inside 'below' the iso-value (level sets),\n"
            "'above' (fog, density, CT) or 'auto' (by the grid's class)")
        .def(
            "to_numpy",
            [](const PyGrid& g, const py::object& box) {
                openvdb::CoordBBox ib = g.grid->evalActiveVoxelBoundingBox();
                if (!box.is_none()) {  // the voxels whose centres lie in the world box
                    const implicit::Box3 wb = toBox(box);
                    const openvdb::Vec3d lo =
                        g.grid->transform().worldToIndex(openvdb::Vec3d(wb.min.x, wb.min.y, wb.min.z));
                    const openvdb::Vec3d hi =
                        g.grid->transform().worldToIndex(openvdb::Vec3d(wb.max.x, wb.max.y, wb.max.z));
                    ib = openvdb::CoordBBox(openvdb::Coord::ceil(openvdb::math::minComponent(lo, hi)),
                                            openvdb::Coord::floor(openvdb::math::maxComponent(lo, hi)));
                }
                if (ib.empty())
                    throw py::value_error("no voxels there (an empty grid, or a box between voxel centres)");
                const openvdb::Coord d = ib.dim();
                if (double(d.x()) * d.y() * d.z() * 4 > 0.5 * double(volume::physicalMemory()))
                    throw isoforge::ResourceError("a dense array of " + std::to_string(d.x()) + " x " +
                                                  std::to_string(d.y()) + " x " + std::to_string(d.z()) +
                                                  " voxels would need more than half of this machine's memory");
                auto* values = new std::vector<float>(std::size_t(d.x()) * std::size_t(d.y()) * std::size_t(d.z()));
                py::capsule owner(values, [](void* p) { delete static_cast<std::vector<float>*>(p); });
                {
                    py::gil_scoped_release release;
                    openvdb::tools::Dense<float, openvdb::tools::LayoutXYZ> dense(ib, values->data());
                    openvdb::tools::copyToDense(*g.grid, dense);
                }
                const py::ssize_t f = sizeof(float);
                return py::array_t<float>({py::ssize_t(d.x()), py::ssize_t(d.y()), py::ssize_t(d.z())},
                                          {f, f * d.x(), f * d.x() * d.y()}, values->data(), owner);
            },
            py::arg("box") = py::none(),
            "The dense array [i, j, k] (Fortran order: i fastest, no copy) of the active voxels' bounding box,\n"
            "or of the voxels whose centres lie in a world box ((x0, y0, z0), (x1, y1, z1))")
        .def_property_readonly("name", [](const PyGrid& g) { return g.grid->getName(); })
        .def_property_readonly("voxel_size", [](const PyGrid& g) { return g.grid->voxelSize().x(); })
        .def_property_readonly("active_voxels", [](const PyGrid& g) { return g.grid->activeVoxelCount(); })
        .def_property_readonly(
            "grid_class", [](const PyGrid& g) { return openvdb::GridBase::gridClassToString(g.grid->getGridClass()); })
        .def_property_readonly(
            "index_bounds",
            [](const PyGrid& g) {
                const openvdb::CoordBBox b = g.grid->evalActiveVoxelBoundingBox();
                return py::make_tuple(coords(b.min()), coords(b.max()));
            },
            "The active voxels' index box ((i0, j0, k0), (i1, j1, k1)), inclusive")
        .def("__repr__", [](const PyGrid& g) {
            return "<isoforge.Grid '" + g.grid->getName() + "' " +
                   openvdb::GridBase::gridClassToString(g.grid->getGridClass()) + ", voxel " +
                   std::to_string(g.grid->voxelSize().x()) + ", " + std::to_string(g.grid->activeVoxelCount()) +
                   " active voxels>";
        });
}

}  // namespace isoforge::python
