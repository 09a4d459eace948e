// Volumes from Python: scikit-image's marching_cubes signature with closed, oriented meshes, and
// read_volume for every reader (DICOM directories, NIfTI, NRRD, MetaImage, raw, .vdb) as array + affine.
#include <algorithm>
#include <cmath>
#include <limits>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include "python/common.h"
#include "volume/dense_grid.h"
#include "volume/dense_volume.h"
#include "volume/marching_cubes.h"

namespace isoforge::python {

namespace {

using FloatArray = py::array_t<float, py::array::forcecast>;

/// The array's voxels as a view with x fastest: an F-ordered array is [x, y, z] as it is; a C-ordered
/// one is [z, y, x] (axis 2 fastest). Anything else is copied once into C order.
struct Voxels {
    py::array_t<float> array;  ///< keeps the memory alive
    bool fortran = false;
    std::array<std::int64_t, 3> dims{};
};

Voxels voxelsOf(const py::object& input) {
    Voxels v;
    py::array a = py::array::ensure(input);
    if (!a) throw py::type_error("expected a 3D array (numpy, or anything numpy.asarray takes)");
    if (a.ndim() != 3) throw py::value_error("expected a 3D array, got " + std::to_string(a.ndim()) + " dimensions");
    const bool isFloat = a.dtype().is(py::dtype::of<float>());
    if (isFloat && (a.flags() & py::array::f_style) && !(a.flags() & py::array::c_style)) {
        v.array = py::array_t<float, py::array::f_style>::ensure(a);
        v.fortran = true;
    } else {
        v.array = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(a);
    }
    for (int i = 0; i < 3; ++i) {
        const auto n = std::int64_t(v.array.shape(i));
        if (n < 2) throw py::value_error("every axis of the volume needs at least 2 samples");
        v.dims[v.fortran ? i : 2 - i] = n;
    }
    return v;
}

/// A vector handed to numpy without a copy, as an (N,) array of `Scalar` or, for glm 3-vectors, an (N, 3)
/// one: numpy's array keeps the vector alive and frees it.
template <class Scalar, class T>
py::array_t<Scalar> adopt(std::vector<T>&& items) {
    constexpr auto columns = py::ssize_t(sizeof(T) / sizeof(Scalar));
    static_assert(sizeof(T) == columns * sizeof(Scalar), "packed components");
    auto* owner = new std::vector<T>(std::move(items));
    const py::capsule keep(owner, [](void* p) { delete static_cast<std::vector<T>*>(p); });
    const auto n = py::ssize_t(owner->size());
    const auto* data = reinterpret_cast<const Scalar*>(owner->data());
    if constexpr (columns == 1) return py::array_t<Scalar>(n, data, keep);
    return py::array_t<Scalar>({n, columns}, {py::ssize_t(sizeof(T)), py::ssize_t(sizeof(Scalar))}, data, keep);
}

}  // namespace

void bindVolumes(py::module_& m) {
    m.def(
        "marching_cubes",
        [](const py::object& input, const py::object& levelArg, const py::object& spacingArg,
           const std::string& gradientDirection, int stepSize, bool /*allowDegenerate*/, const std::string& method,
           const py::object& mask) {
            if (!mask.is_none())
                throw py::value_error(
                    "mask= is not supported: give the voxels outside the mask a value on the "
                    "outside of the level instead (the surface then closes there)");
            if (method != "lewiner" && method != "lorensen")
                throw py::value_error("method must be 'lewiner' or 'lorensen' (both give isoforge's marching cubes)");
            if (gradientDirection != "descent" && gradientDirection != "ascent")
                throw py::value_error("gradient_direction must be 'descent' or 'ascent'");
            if (stepSize < 1) throw py::value_error("step_size must be at least 1");
            py::object source = input;
            if (stepSize > 1) {
                const py::slice s{py::none(), py::none(), py::int_(stepSize)};
                source = py::array::ensure(input).attr("__getitem__")(py::make_tuple(s, s, s));
            }
            const Voxels vox = voxelsOf(source);
            const auto spacing = spacingArg.cast<std::vector<double>>();
            if (spacing.size() != 3 || std::any_of(spacing.begin(), spacing.end(), [](double s) { return !(s > 0); }))
                throw py::value_error("spacing must be three positive numbers, one per array axis");
            const float* data = vox.array.data();
            const std::size_t count = std::size_t(vox.array.size());
            using Range = std::pair<float, float>;
            auto rangeOf = [&] {  // only to choose the default level: toGridNearLevel finds it as it goes
                return tbb::parallel_reduce(
                    tbb::blocked_range<std::size_t>(0, count, 1 << 16),
                    Range(std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity()),
                    [&](const tbb::blocked_range<std::size_t>& r, Range acc) {
                        for (std::size_t i = r.begin(); i < r.end(); ++i) {
                            acc.first = std::min(acc.first, data[i]);
                            acc.second = std::max(acc.second, data[i]);
                        }
                        return acc;
                    },
                    [](const Range& a, const Range& b) {
                        return Range(std::min(a.first, b.first), std::max(a.second, b.second));
                    });
            };
            Range range;
            float level = 0.f;
            if (levelArg.is_none()) {
                range = rangeOf();
                level = 0.5f * (range.first + range.second);
            } else {
                level = levelArg.cast<float>();
            }
            // Index axis a of the view (x, y, z) is array axis a (Fortran) or 2 - a (C order).
            volume::VolumeView view{data, vox.dims, glm::dmat4(1.0), "numpy"};
            for (int a = 0; a < 3; ++a)
                view.indexToWorld[a][a] = stepSize * spacing[std::size_t(vox.fortran ? a : 2 - a)];
            // descent (skimage's default): values above the level are the object; ascent: below. The
            // background (outside the array) is on the outside side, so surfaces close at the borders.
            const bool above = gradientDirection == "descent";
            mesh::TriMesh t;
            std::vector<float> values;
            {
                py::gil_scoped_release release;
                // Only the blocks near the level are copied: the work grows with the surface.
                const openvdb::FloatGrid::Ptr grid = volume::toGridNearLevel(view, level, above, &range);
                if (!(level >= range.first && level <= range.second)) {
                    py::gil_scoped_acquire gil;
                    throw py::value_error("level " + std::to_string(level) + " is outside the volume's range [" +
                                          std::to_string(range.first) + ", " + std::to_string(range.second) + "]");
                }
                volume::MeshingOptions mo;
                mo.isovalue = level;
                mo.inside = above ? volume::InsideSide::Above : volume::InsideSide::Below;
                mo.normals = true;
                mo.edgeValues = &values;  // skimage's `values`: the larger datum at the ends of each vertex's edge
                t = volume::extractIsosurface(*grid, mo);
                if (t.vertexCount() > std::size_t(std::numeric_limits<std::int32_t>::max())) {
                    py::gil_scoped_acquire gil;
                    throw py::value_error("the surface has " + std::to_string(t.vertexCount()) +
                                          " vertices, more than int32 faces can index");
                }
                // For a C-ordered array, array axis a is view axis 2 - a: the positions and normals are
                // reversed in place, and the mesh so mirrored keeps counter-clockwise seen from outside by
                // swapping two corners of each triangle.
                if (!vox.fortran) {
                    tbb::parallel_for(std::size_t{0}, t.vertexCount(), [&](std::size_t v) {
                        std::swap(t.positions[v].x, t.positions[v].z);
                        std::swap(t.normals[v].x, t.normals[v].z);
                    });
                    tbb::parallel_for(std::size_t{0}, t.triangles.size(),
                                      [&](std::size_t i) { std::swap(t.triangles[i].y, t.triangles[i].z); });
                }
            }
            // The mesh's own arrays become numpy's (no copy): glm's vectors are three packed 32-bit values,
            // and the indices fit int32 (checked above).
            return py::make_tuple(adopt<float>(std::move(t.positions)), adopt<std::int32_t>(std::move(t.triangles)),
                                  adopt<float>(std::move(t.normals)), adopt<float>(std::move(values)));
        },
        py::arg("volume"), py::arg("level") = py::none(), py::kw_only(), py::arg("spacing") = py::make_tuple(1, 1, 1),
        py::arg("gradient_direction") = "descent", py::arg("step_size") = 1, py::arg("allow_degenerate") = true,
        py::arg("method") = "lewiner", py::arg("mask") = py::none(),
        "scikit-image's marching_cubes: verts (V, 3) float32 in array index order scaled by spacing, faces\n"
        "(F, 3) int32, normals (V, 3) float32 (outward), values (V,) float32. Unlike scikit-image's, the mesh is\n"
        "closed (surfaces close just outside the array's border), manifold, oriented outward, with no\n"
        "duplicate vertices and no degenerate triangles. level defaults to the middle of the range; values\n"
        "above it are the object (gradient_direction='descent'), or below ('ascent').");

    m.def(
        "read_volume",
        [](const std::string& path, const std::string& space, const py::object& dims, const std::string& dtype,
           const py::object& spacing, const std::string& endian, std::uint64_t offset, const std::string& series,
           const std::string& grid) {
            if (space != "LPS" && space != "RAS") throw py::value_error("space must be 'LPS' or 'RAS'");
            if (endian != "little" && endian != "big") throw py::value_error("endian must be 'little' or 'big'");
            volume::VolumeReadOptions o;
            if (!dims.is_none()) {
                const auto d = dims.cast<std::vector<std::int64_t>>();
                if (d.size() != 3) throw py::value_error("dims: three sizes (x, y, z)");
                o.rawDims = {d[0], d[1], d[2]};
            }
            o.rawType = dtype;
            if (!spacing.is_none()) {
                const glm::vec3 s = toVec3(spacing, "spacing");
                o.rawSpacing = glm::dvec3(s);
            }
            o.rawBigEndian = endian == "big";
            o.rawOffset = offset;
            o.dicomSeries = series;
            o.vdbGrid = grid;
            auto* v = new volume::DenseVolume;
            try {
                py::gil_scoped_release release;
                *v = volume::readVolume(path, o);
            } catch (...) {
                delete v;
                throw;
            }
            py::capsule owner(v, [](void* p) { delete static_cast<volume::DenseVolume*>(p); });
            const py::ssize_t f = sizeof(float);
            py::array_t<float> array({py::ssize_t(v->dims[0]), py::ssize_t(v->dims[1]), py::ssize_t(v->dims[2])},
                                     {f, f * v->dims[0], f * v->dims[0] * v->dims[1]}, v->values.data(), owner);
            py::array_t<double> affine({4, 4});
            for (int r = 0; r < 4; ++r)
                for (int c = 0; c < 4; ++c)
                    affine.mutable_at(r, c) = v->indexToWorld[c][r] * (space == "RAS" && r < 2 ? -1.0 : 1.0);
            return py::make_tuple(array, affine);
        },
        py::arg("path"), py::kw_only(), py::arg("space") = "LPS", py::arg("dims") = py::none(), py::arg("dtype") = "",
        py::arg("spacing") = py::none(), py::arg("endian") = "little", py::arg("offset") = 0, py::arg("series") = "",
        py::arg("grid") = "",
        "Reads a volume with isoforge's readers (a DICOM directory, .nii/.nii.gz, .nrrd/.nhdr, .mha/.mhd,\n"
        ".vdb; .raw with dims and dtype) -> (array, affine): array[i, j, k] float32 (Fortran order, no\n"
        "copy), affine (4, 4) float64 from (i, j, k, 1) to patient millimetres, LPS (DICOM's and ITK's\n"
        "convention; space='RAS' for NIfTI's and nibabel's).");
}

}  // namespace isoforge::python
