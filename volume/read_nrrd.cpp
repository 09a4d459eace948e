// NRRD through teem's nrrd library: attached and detached headers (.nrrd, .nhdr), multi-file data
// ("data file: quarter.%d 1 93 1"), raw, gzip and other encodings, space directions and origin.
#include <cmath>
#include <cstdlib>
#include <memory>
#include <mutex>

#include <teem/air.h>
#include <teem/biff.h>
#include <teem/nrrd.h>

#include "core/big_buffer.h"
#include "core/error.h"
#include "volume/readers.h"

namespace isoforge::volume::detail {

namespace {

struct NrrdNuke {
    void operator()(Nrrd* n) const { nrrdNuke(n); }
};

std::string typeName(int t) {
    switch (t) {
        case nrrdTypeChar:
            return "int8";
        case nrrdTypeUChar:
            return "uint8";
        case nrrdTypeShort:
            return "int16";
        case nrrdTypeUShort:
            return "uint16";
        case nrrdTypeInt:
            return "int32";
        case nrrdTypeUInt:
            return "uint32";
        case nrrdTypeLLong:
            return "int64";
        case nrrdTypeULLong:
            return "uint64";
        case nrrdTypeFloat:
            return "float32";
        case nrrdTypeDouble:
            return "float64";
        default:
            return {};
    }
}

std::string biffMessage() {
    char* e = biffGetDone(NRRD);
    std::string s = e ? e : "unknown error";
    std::free(e);
    while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
    // teem's messages are a stack "[nrrd] f: ...\n[nrrd] g: ..."; keep them, one per line, indented.
    std::string out;
    for (char c : s) out += c == '\n' ? std::string("\n  ") : std::string(1, c);
    return out;
}

}  // namespace

DenseVolume readNrrd(const std::filesystem::path& path) {
    static std::mutex biffMutex;  // biff's error stack is global
    std::lock_guard<std::mutex> lock(biffMutex);
    std::unique_ptr<Nrrd, NrrdNuke> n(nrrdNew());
    if (nrrdLoad(n.get(), path.c_str(), nullptr))
        throw IoError(path.string() + ": cannot read NRRD:\n  " + biffMessage());
    if (n->dim != 3 && n->dim != 2)
        throw IoError(path.string() + ": a " + std::to_string(n->dim) +
                      "-dimensional NRRD; expected a 2D or 3D volume");
    const std::string type = typeName(n->type);
    if (type.empty()) throw IoError(path.string() + ": NRRD type 'block' is not a scalar type");
    DenseVolume v;
    v.format = "NRRD";
    v.storedType = type;
    v.dims = {std::int64_t(n->axis[0].size), std::int64_t(n->axis[1].size),
              n->dim == 3 ? std::int64_t(n->axis[2].size) : 1};
    checkVolumeSize(path, v.dims);
    resizeLarge(v.values, std::size_t(v.voxelCount()));
    // teem has decoded and byte-swapped the data to native order: convert without swapping.
    convertVoxels(n->data, type, std::endian::native == std::endian::big, v.voxelCount(), v.values.data());

    // Geometry: space directions and origin when the file has a space, else spacings.
    glm::dmat4 m(1.0);
    if (n->spaceDim == 3) {
        // Flip the world axes of the file's space into LPS.
        glm::dvec3 toLps(1.0);
        switch (n->space) {
            case nrrdSpaceRightAnteriorSuperior:
                toLps = {-1, -1, 1};
                break;
            case nrrdSpaceLeftAnteriorSuperior:
                toLps = {1, -1, 1};
                break;
            default:
                break;  // LPS, scanner-xyz (= LPS), 3D-right/left-handed: taken as they are
        }
        for (unsigned a = 0; a < n->dim; ++a) {
            // An axis without a space direction ("spacings:" given instead) runs along its world axis.
            const bool given = std::isfinite(n->axis[a].spaceDirection[0]);
            const double s = std::isfinite(n->axis[a].spacing) && n->axis[a].spacing > 0 ? n->axis[a].spacing : 1.0;
            for (int c = 0; c < 3; ++c)
                m[int(a)][c] = given ? n->axis[a].spaceDirection[c] * toLps[c] : (int(a) == c ? s : 0.0);
        }
        for (int c = 0; c < 3; ++c) m[3][c] = std::isfinite(n->spaceOrigin[c]) ? n->spaceOrigin[c] * toLps[c] : 0.0;
        v.notes.push_back(std::string("space: ") + airEnumStr(nrrdSpace, n->space));
    } else {
        for (unsigned a = 0; a < n->dim; ++a) {
            const double s = n->axis[a].spacing;
            m[int(a)][int(a)] = std::isfinite(s) && s > 0 ? s : 1.0;
        }
        v.notes.push_back("no space directions: axes from the spacings alone");
    }
    v.indexToWorld = m;
    return v;
}

}  // namespace isoforge::volume::detail
