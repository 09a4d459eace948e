#pragma once
/// @file What the binding files share: numpy conversions, the Python handles of fields, and long
/// calls run with the GIL released, progress reported and Ctrl-C honoured.

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <openvdb/openvdb.h>

#include "core/progress.h"
#include "implicit/field.h"
#include "mesh/trimesh.h"

namespace isoforge::python {

namespace py = pybind11;

void bindFields(py::module_& m);
void bindMeshes(py::module_& m);
void bindGrids(py::module_& m);
void bindVolumes(py::module_& m);
void bindScenes(py::module_& m);

/// A field as Python holds it: the C++ field and the box it is clipped to (everything, or [-1, 1]^3
/// for a .vm model, as the command line does).
struct PyField {
    implicit::FieldPtr field;
    implicit::Box3 clip = implicit::Box3::everything();
};

/// A sparse grid as Python holds it, with the field it was sampled from (null for grids read from files
/// and volumes): meshing it with sharp=True then takes Hermite data from the field, as the command line does.
struct PyGrid {
    openvdb::FloatGrid::Ptr grid;
    implicit::FieldPtr field;
};

/// Samples the field into a grid (the command line's `volume::sample` call: narrow band of
/// `halfWidth` voxels, clipped to the field's clip box).
PyGrid sampleField(const PyField& f, float voxel, float halfWidth, const py::object& progress);

/// The mesh of a grid: iso-surface, then sharp features, simplification and scene colours as asked
/// (volume::meshSurface, the command line's pipeline); with normals and sharp features, a vertex on a crease
/// once per side (mesh/crease_normals.h, faces more than creaseAngle degrees apart), as `isoforge mesh` writes it.
mesh::TriMesh meshGrid(const PyGrid& g, float iso, const std::string& inside, bool normals, bool sharp, double maxError,
                       const py::object& progress, double creaseAngle = 30.0);

/// Thrown from Progress calls on worker threads once the user pressed Ctrl-C (or the callback raised).
struct Interrupted : std::exception {
    const char* what() const noexcept override { return "interrupted"; }
};

/// Progress that long C++ calls update from their worker threads; the Python thread reads it.
class PollProgress final : public Progress {
public:
    void begin(const std::string& stage) override {
        {
            std::lock_guard lock(mutex_);
            stage_ = stage;
        }
        done_ = 0;
        total_ = 0;
        check();
    }
    void update(std::size_t done, std::size_t total) override {
        done_ = done;
        total_ = total;
        check();
    }
    void end() override { done_ = total_.load(); }  // never throws (core/progress.h)
    void cancel() { cancelled_ = true; }
    /// (stage, done, total) as last reported.
    std::tuple<std::string, std::size_t, std::size_t> snapshot() const {
        std::lock_guard lock(mutex_);
        return {stage_, done_.load(), total_.load()};
    }

private:
    void check() const {
        if (cancelled_) throw Interrupted();
    }
    mutable std::mutex mutex_;
    std::string stage_;
    std::atomic<std::size_t> done_{0}, total_{0};
    std::atomic<bool> cancelled_{false};
};

/// The callable `progress=` names: None or False for none, True for a bar on stderr when it is a
/// terminal (isoforge._progress.bar), or a callable taking (stage, done, total).
py::object progressCallback(const py::object& progress);

/// Runs `work(Progress*)` on a worker thread with the GIL released. The calling thread wakes ten times a
/// second to check for Ctrl-C (PyErr_CheckSignals: KeyboardInterrupt cancels the work at its next
/// progress report and is raised here) and to call the progress callback. C++ errors are rethrown here
/// (pybind11 turns them into Python exceptions).
template <class Work>
auto runLong(const py::object& progress, Work&& work) {
    using Result = decltype(work(static_cast<Progress*>(nullptr)));
    const py::object callback = progressCallback(progress);
    PollProgress poll;
    std::optional<Result> result;
    std::exception_ptr error;
    PyObject *type = nullptr, *value = nullptr, *trace = nullptr;  // a Python error raised while polling
    {
        py::gil_scoped_release release;
        std::mutex mutex;
        std::condition_variable cv;
        bool finished = false;
        std::thread worker([&] {
            try {
                result.emplace(work(&poll));
            } catch (...) {
                error = std::current_exception();
            }
            std::lock_guard lock(mutex);
            finished = true;
            cv.notify_all();
        });
        std::unique_lock lock(mutex);
        while (!finished) {
            cv.wait_for(lock, std::chrono::milliseconds(100));
            if (finished || type) continue;
            lock.unlock();
            {
                py::gil_scoped_acquire gil;
                if (PyErr_CheckSignals() != 0) {
                    PyErr_Fetch(&type, &value, &trace);
                } else if (!callback.is_none()) {
                    const auto [stage, done, total] = poll.snapshot();
                    if (PyObject* r = PyObject_CallFunction(callback.ptr(), "snn", stage.c_str(), Py_ssize_t(done),
                                                            Py_ssize_t(total)))
                        Py_DECREF(r);
                    else
                        PyErr_Fetch(&type, &value, &trace);
                }
            }
            if (type) poll.cancel();
            lock.lock();
        }
        worker.join();
    }
    if (type) {
        PyErr_Restore(type, value, trace);
        throw py::error_already_set();
    }
    if (!callback.is_none()) {
        const auto [stage, done, total] = poll.snapshot();
        callback(stage, total, total);
        callback(py::none(), 0, 0);  // the end: a bar clears its line
    }
    if (error) std::rethrow_exception(error);
    return std::move(*result);
}

/// A 3-vector from a number (all three components) or a sequence of three.
glm::vec3 toVec3(const py::handle& v, const char* what);

/// A box from ((x0, y0, z0), (x1, y1, z1)) or None (everything).
implicit::Box3 toBox(const py::object& box);
py::tuple fromBox(const implicit::Box3& box);

/// The voxel size for `field`: `voxel` if given, else `resolution` (default 256) voxels along the longest
/// side of its sampled domain (the command line's rule). @throw ValueError when the domain is unbounded.
float voxelFor(const PyField& f, const py::object& voxel, const py::object& resolution);

}  // namespace isoforge::python
