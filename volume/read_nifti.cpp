// NIfTI-1 and NIfTI-2 through niftilib's nifti2 API (which reads both), and a NIfTI-1 writer.
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <mutex>

#include <unistd.h>
#include <zlib.h>

#include <nifti/nifti2_io.h>

#include "core/big_buffer.h"
#include "core/error.h"
#include "volume/readers.h"

namespace isoforge::volume::detail {

namespace {

std::mutex& niftiMutex() {  // niftilib keeps global options; calls are serialized
    static std::mutex m;
    return m;
}

struct NiftiFree {
    void operator()(nifti_image* n) const { nifti_image_free(n); }
};
using NiftiPtr = std::unique_ptr<nifti_image, NiftiFree>;

std::string niftiTypeName(int dt) {
    switch (dt) {
        case DT_UINT8:
            return "uint8";
        case DT_INT8:
            return "int8";
        case DT_UINT16:
            return "uint16";
        case DT_INT16:
            return "int16";
        case DT_UINT32:
            return "uint32";
        case DT_INT32:
            return "int32";
        case DT_UINT64:
            return "uint64";
        case DT_INT64:
            return "int64";
        case DT_FLOAT32:
            return "float32";
        case DT_FLOAT64:
            return "float64";
        default:
            return {};
    }
}

/// Bytes of voxel data the file really holds after `offset` (decompressing .gz to count them), so that a
/// short file gets a precise message instead of niftilib's stderr.
std::uint64_t availableBytes(const std::filesystem::path& path, std::uint64_t offset, std::uint64_t wanted,
                             bool* streamError) {
    *streamError = false;
    gzFile f = gzopen(path.c_str(), "rb");  // reads plain files too
    if (!f) return 0;
    std::vector<char> buf(1 << 20);
    std::uint64_t total = 0;
    const std::uint64_t limit = offset + wanted;
    for (;;) {
        const int n = gzread(f, buf.data(), static_cast<unsigned>(buf.size()));
        if (n < 0) {
            *streamError = true;
            break;
        }
        if (n == 0) break;
        total += std::uint64_t(n);
        if (total >= limit) break;
    }
    int err = Z_OK;
    gzerror(f, &err);
    if (err != Z_OK && err != Z_STREAM_END) *streamError = true;
    gzclose(f);
    return total > offset ? total - offset : 0;
}

/// The version from the first field, sizeof_hdr: 348 for NIfTI-1, 540 for NIfTI-2 (either byte order).
int niftiVersion(const std::filesystem::path& path) {
    gzFile f = gzopen(path.c_str(), "rb");
    if (!f) return 0;
    unsigned char b[4] = {0, 0, 0, 0};
    const int n = gzread(f, b, 4);
    gzclose(f);
    if (n != 4) return 0;
    const std::uint32_t le = b[0] | (b[1] << 8) | (b[2] << 16) | (std::uint32_t(b[3]) << 24),
                        be = b[3] | (b[2] << 8) | (b[1] << 16) | (std::uint32_t(b[0]) << 24);
    return le == 540 || be == 540 ? 2 : 1;
}

bool scaled(const nifti_image& h) {
    return h.scl_slope != 0.0 && std::isfinite(h.scl_slope) && (h.scl_slope != 1.0 || h.scl_inter != 0.0);
}

}  // namespace

namespace {

/// The header of a NIfTI file (niftilib's, voxels not read) and what it says: `v` gets everything but the
/// values (the scaling only as a note).
NiftiPtr readHeader(const std::filesystem::path& path, DenseVolume& v) {
    nifti_set_debug_level(0);
    NiftiPtr header(nifti_image_read(path.c_str(), 0));
    if (!header)
        throw IoError(path.string() +
                      ": not a readable NIfTI file (the 348- or 540-byte header is missing, truncated or has a wrong "
                      "sizeof_hdr)");
    nifti_image& h = *header;
    if (h.nifti_type == NIFTI_FTYPE_ANALYZE) throw IoError(path.string() + ": an ANALYZE 7.5 file, not NIfTI");
    const std::string type = niftiTypeName(h.datatype);
    if (type.empty())
        throw IoError(path.string() + ": voxel datatype " + std::to_string(h.datatype) +
                      " is not a scalar type (expected uint8, int16, float32, ...)");
    for (int d = 4; d <= 7; ++d)
        if (h.dim[0] >= d && h.dim[d] > 1)
            throw IoError(path.string() + ": a " + std::to_string(h.dim[0]) + "D image (dim[" + std::to_string(d) +
                          "] = " + std::to_string(h.dim[d]) + "); only 3D volumes are supported");
    v.dims = {h.nx, std::max<std::int64_t>(h.ny, 1), std::max<std::int64_t>(h.nz, 1)};
    checkVolumeDims(path, v.dims);
    if (scaled(h))
        v.notes.push_back("scaled by scl_slope " + std::to_string(h.scl_slope) + ", scl_inter " +
                          std::to_string(h.scl_inter));
    // sform if set, else qform, else pixdim scaling; RAS -> LPS.
    nifti_dmat44 m{};
    if (h.sform_code > 0) {
        m = h.sto_xyz;
        v.notes.push_back("orientation from the sform (code " + std::to_string(h.sform_code) + ")");
    } else if (h.qform_code > 0) {
        m = h.qto_xyz;
        v.notes.push_back("orientation from the qform (code " + std::to_string(h.qform_code) + ")");
    } else {
        m.m[0][0] = h.dx > 0 ? h.dx : 1.0;
        m.m[1][1] = h.dy > 0 ? h.dy : 1.0;
        m.m[2][2] = h.dz > 0 ? h.dz : 1.0;
        m.m[3][3] = 1.0;
        v.notes.push_back("no sform or qform: axes from the voxel sizes alone");
    }
    for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 3; ++r) v.indexToWorld[c][r] = (r < 2 ? -1.0 : 1.0) * m.m[r][c];
    v.indexToWorld[3][3] = 1.0;
    v.format = niftiVersion(path) == 2 ? "NIfTI-2" : "NIfTI-1";
    v.storedType = type;
    if (h.descrip[0]) v.notes.push_back(std::string("description: ") + std::string(h.descrip, strnlen(h.descrip, 80)));
    return header;
}

}  // namespace

DenseVolume readNifti(const std::filesystem::path& path) {
    std::lock_guard<std::mutex> lock(niftiMutex());
    DenseVolume v;
    NiftiPtr header = readHeader(path, v);
    nifti_image& h = *header;
    checkVolumeSize(path, v.dims);
    const std::string& type = v.storedType;
    // Counted before loading (decompressing .gz twice): niftilib accepts a gzip stream that ends early and
    // leaves the rest of the voxels as they were (EveryCutOfEveryFormatIsAnErrorNotACrash shows it).
    const std::uint64_t need = std::uint64_t(h.nvox) * std::uint64_t(h.nbyper);
    bool streamError = false;
    const std::uint64_t have =
        availableBytes(h.iname ? h.iname : path.c_str(), std::uint64_t(h.iname_offset), need, &streamError);
    if (have < need)
        throw IoError(path.string() + ": the header promises " + std::to_string(v.dims[0]) + " x " +
                      std::to_string(v.dims[1]) + " x " + std::to_string(v.dims[2]) + " " + type + " voxels (" +
                      std::to_string(need) + " bytes from offset " + std::to_string(h.iname_offset) +
                      ") but the file holds " + std::to_string(have) +
                      (streamError ? " before its gzip stream breaks off (truncated or corrupt .gz)" : ""));
    if (nifti_image_load(header.get()) != 0 || !h.data)
        throw IoError(path.string() + ": niftilib could not read the voxel data");

    resizeLarge(v.values, std::size_t(v.voxelCount()));
    // nifti_image_load leaves the data in native byte order.
    convertVoxels(h.data, type, std::endian::native == std::endian::big, v.voxelCount(), v.values.data());
    if (scaled(h)) {
        const auto slope = float(h.scl_slope), inter = float(std::isfinite(h.scl_inter) ? h.scl_inter : 0.0);
        for (float& x : v.values) x = x * slope + inter;
    }
    return v;
}

VoxelSource niftiSource(const std::filesystem::path& path) {
    std::lock_guard<std::mutex> lock(niftiMutex());
    VoxelSource s;
    NiftiPtr header = readHeader(path, s.header);
    const nifti_image& h = *header;
    VoxelSource::Part p;
    p.file = h.iname ? std::filesystem::path(h.iname) : path;
    p.bytes = std::uint64_t(h.nvox) * std::uint64_t(h.nbyper);
    // A gzip file (.nii.gz, or a .img.gz pair) is one stream: the voxels start iname_offset bytes into it.
    unsigned char magic[2] = {0, 0};
    if (std::FILE* f = std::fopen(p.file.c_str(), "rb")) {
        if (std::fread(magic, 1, 2, f) != 2) magic[0] = 0;
        std::fclose(f);
    }
    p.compressed = magic[0] == 0x1f && magic[1] == 0x8b;
    (p.compressed ? p.skip : p.offset) = std::uint64_t(h.iname_offset);
    s.parts.push_back(p);
    // niftilib reports the file's byte order as byteorder; its swapsize says whether it differs from ours.
    s.bigEndian = h.byteorder == 2;  // MSB_FIRST (niftilib keeps its name to itself)
    if (scaled(h)) {
        s.slope = float(h.scl_slope);
        s.intercept = float(std::isfinite(h.scl_inter) ? h.scl_inter : 0.0);
    }
    return s;
}

}  // namespace isoforge::volume::detail

namespace isoforge::volume {

using detail::niftiMutex;
using detail::NiftiPtr;

void writeNifti(const std::filesystem::path& path, const DenseVolume& v) {
    std::string name = path.filename().string();
    const bool gz = name.size() > 7 && name.compare(name.size() - 7, 7, ".nii.gz") == 0;
    if (!gz && !(name.size() > 4 && name.compare(name.size() - 4, 4, ".nii") == 0))
        throw IoError(path.string() + ": a NIfTI file name ends in .nii or .nii.gz");
    const std::filesystem::path temp =
        path.parent_path() / (".isoforge-" + std::to_string(::getpid()) + "-" + name);  // same extension
    {
        std::lock_guard<std::mutex> lock(niftiMutex());
        nifti_set_debug_level(0);
        const int64_t dims[8] = {3, v.dims[0], v.dims[1], v.dims[2], 1, 1, 1, 1};
        NiftiPtr nim(nifti_make_new_nim(dims, DT_FLOAT32, 0));
        if (!nim) throw IoError(path.string() + ": niftilib could not make an image");
        nim->nifti_type = NIFTI_FTYPE_NIFTI1_1;
        nim->data = const_cast<float*>(v.values.data());  // not owned: released before free below
        nifti_dmat44 m{};
        for (int c = 0; c < 4; ++c)
            for (int r = 0; r < 3; ++r) m.m[r][c] = (r < 2 ? -1.0 : 1.0) * v.indexToWorld[c][r];  // LPS -> RAS
        m.m[3][3] = 1.0;
        nim->sform_code = NIFTI_XFORM_SCANNER_ANAT;
        nim->sto_xyz = m;
        nim->qform_code = NIFTI_XFORM_SCANNER_ANAT;
        nim->qto_xyz = m;
        nifti_dmat44_to_quatern(m, &nim->quatern_b, &nim->quatern_c, &nim->quatern_d, &nim->qoffset_x, &nim->qoffset_y,
                                &nim->qoffset_z, &nim->dx, &nim->dy, &nim->dz, &nim->qfac);
        nim->pixdim[1] = nim->dx;
        nim->pixdim[2] = nim->dy;
        nim->pixdim[3] = nim->dz;
        nim->xyz_units = NIFTI_UNITS_MM;
        std::snprintf(nim->descrip, sizeof nim->descrip, "isoforge %s", v.units.c_str());
        if (nifti_set_filenames(nim.get(), temp.c_str(), 0, 1) != 0) {
            nim->data = nullptr;
            throw IoError(path.string() + ": niftilib refused the file name");
        }
        nifti_image_write(nim.get());
        nim->data = nullptr;
    }
    std::error_code ec;
    if (!std::filesystem::exists(temp, ec) ||
        std::filesystem::file_size(temp, ec) < 352 + (gz ? 0 : v.voxelCount() * 4)) {
        std::filesystem::remove(temp, ec);
        throw IoError(path.string() + ": writing failed (disk full or not writable?)");
    }
    std::filesystem::rename(temp, path, ec);
    if (ec) {
        std::filesystem::remove(temp, ec);
        throw IoError(path.string() + ": cannot rename the finished file into place: " + ec.message());
    }
}

}  // namespace isoforge::volume
