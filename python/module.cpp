// The isoforge._isoforge extension module: exceptions, shared helpers, and the bindings of each file.
#include <cmath>

#include "core/error.h"
#include "python/common.h"
#include "volume/sample.h"

namespace isoforge::python {

py::object progressCallback(const py::object& progress) {
    if (progress.is_none() || (py::isinstance<py::bool_>(progress) && !progress.cast<bool>())) return py::none();
    if (py::isinstance<py::bool_>(progress)) return py::module_::import("isoforge._progress").attr("bar")();
    if (!PyCallable_Check(progress.ptr()))
        throw py::type_error("progress must be None, True or a callable taking (stage, done, total)");
    return progress;
}

glm::vec3 toVec3(const py::handle& v, const char* what) {
    if (py::isinstance<py::float_>(v) || py::isinstance<py::int_>(v)) return glm::vec3(v.cast<float>());
    const auto s = v.cast<std::vector<float>>();
    if (s.size() != 3) throw py::value_error(std::string(what) + ": expected a number or three numbers");
    return {s[0], s[1], s[2]};
}

implicit::Box3 toBox(const py::object& box) {
    if (box.is_none()) return implicit::Box3::everything();
    const auto pair = box.cast<std::vector<py::object>>();
    if (pair.size() != 2) throw py::value_error("box: expected ((x0, y0, z0), (x1, y1, z1))");
    implicit::Box3 b{toVec3(pair[0], "box"), toVec3(pair[1], "box")};
    if (b.isEmpty()) throw py::value_error("box: each minimum must be at most its maximum");
    return b;
}

py::tuple fromBox(const implicit::Box3& b) {
    return py::make_tuple(py::make_tuple(b.min.x, b.min.y, b.min.z), py::make_tuple(b.max.x, b.max.y, b.max.z));
}

float voxelFor(const PyField& f, const py::object& voxel, const py::object& resolution) {
    if (!voxel.is_none()) {
        const float v = voxel.cast<float>();
        if (!(v > 0.f) || !std::isfinite(v)) throw py::value_error("voxel must be a positive number");
        return v;
    }
    const implicit::Box3 domain = volume::sampleDomain(*f.field, f.clip);
    if (!domain.isBounded())
        throw py::value_error(f.field->describe() + " is unbounded: give box=((x0, y0, z0), (x1, y1, z1))");
    const int n = resolution.is_none() ? 256 : resolution.cast<int>();
    if (n < 1) throw py::value_error("resolution must be at least 1");
    return volume::voxelSizeForResolution(domain, n);
}

}  // namespace isoforge::python

PYBIND11_MODULE(_isoforge, m) {
    namespace py = pybind11;
    using namespace isoforge::python;
    m.doc() = "isoforge: implicit surfaces, CSG scenes and volumes to closed, oriented meshes (C++ core)";
    // The command line's exit-1 errors, as exceptions carrying the same messages (file:line:column).
    static py::exception<isoforge::IoError> ioError(m, "IoError", PyExc_OSError);
    static py::exception<isoforge::ParseError> parseError(m, "ParseError", PyExc_ValueError);
    static py::exception<isoforge::ResourceError> resourceError(m, "ResourceError", PyExc_MemoryError);
    py::register_exception_translator([](std::exception_ptr p) {
        try {
            if (p) std::rethrow_exception(p);
        } catch (const isoforge::ParseError& e) {  // before IoError, its base
            parseError(e.what());
        } catch (const isoforge::IoError& e) {
            ioError(e.what());
        } catch (const isoforge::ResourceError& e) {
            resourceError(e.what());
        } catch (const Interrupted&) {
            PyErr_SetString(PyExc_KeyboardInterrupt, "interrupted");
        }
    });
    bindFields(m);
    bindMeshes(m);
    bindGrids(m);
    bindVolumes(m);
    bindScenes(m);
}
