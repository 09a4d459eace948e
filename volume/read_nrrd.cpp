// NRRD through teem's nrrd library: attached and detached headers (.nrrd, .nhdr), multi-file data
// ("data file: quarter.%d 1 93 1"), raw, gzip and other encodings, space directions and origin.
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <mutex>
#include <optional>

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

namespace {

std::mutex& biffMutex() {  // biff's error stack is global
    static std::mutex m;
    return m;
}

struct IoStateNix {
    void operator()(NrrdIoState* n) const { nrrdIoStateNix(n); }
};

/// What a loaded (or header-only) nrrd says: `v` gets everything but the values.
void describe(const std::filesystem::path& path, const Nrrd& n, DenseVolume& v) {
    if (n.dim != 3 && n.dim != 2)
        throw IoError(path.string() + ": a " + std::to_string(n.dim) + "-dimensional NRRD; expected a 2D or 3D volume");
    const std::string type = typeName(n.type);
    if (type.empty()) throw IoError(path.string() + ": NRRD type 'block' is not a scalar type");
    v.format = "NRRD";
    v.storedType = type;
    v.dims = {std::int64_t(n.axis[0].size), std::int64_t(n.axis[1].size),
              n.dim == 3 ? std::int64_t(n.axis[2].size) : 1};
    checkVolumeDims(path, v.dims);

    // Geometry: space directions and origin when the file has a space, else spacings.
    glm::dmat4 m(1.0);
    if (n.spaceDim == 3) {
        // Flip the world axes of the file's space into LPS.
        glm::dvec3 toLps(1.0);
        switch (n.space) {
            case nrrdSpaceRightAnteriorSuperior:
                toLps = {-1, -1, 1};
                break;
            case nrrdSpaceLeftAnteriorSuperior:
                toLps = {1, -1, 1};
                break;
            default:
                break;  // LPS, scanner-xyz (= LPS), 3D-right/left-handed: taken as they are
        }
        for (unsigned a = 0; a < n.dim; ++a) {
            // An axis without a space direction ("spacings:" given instead) runs along its world axis.
            const bool given = std::isfinite(n.axis[a].spaceDirection[0]);
            const double s = std::isfinite(n.axis[a].spacing) && n.axis[a].spacing > 0 ? n.axis[a].spacing : 1.0;
            for (int c = 0; c < 3; ++c)
                m[int(a)][c] = given ? n.axis[a].spaceDirection[c] * toLps[c] : (int(a) == c ? s : 0.0);
        }
        for (int c = 0; c < 3; ++c) m[3][c] = std::isfinite(n.spaceOrigin[c]) ? n.spaceOrigin[c] * toLps[c] : 0.0;
        v.notes.push_back(std::string("space: ") + airEnumStr(nrrdSpace, n.space));
    } else {
        for (unsigned a = 0; a < n.dim; ++a) {
            const double s = n.axis[a].spacing;
            m[int(a)][int(a)] = std::isfinite(s) && s > 0 ? s : 1.0;
        }
        v.notes.push_back("no space directions: axes from the spacings alone");
    }
    v.indexToWorld = m;
}

/// The offset just past `lines` line ends from `from` in `file` (a NRRD header's blank line: `blank`).
std::uint64_t skipLines(const std::filesystem::path& file, std::uint64_t from, unsigned lines, bool blank) {
    std::ifstream in(file, std::ios::binary);
    if (!in) throw IoError(file.string() + ": cannot open the voxel data");
    in.seekg(std::streamoff(from));
    std::uint64_t at = from;
    bool lineEmpty = true;  // blank: the header ends at the first line holding nothing (or only "\r")
    char c;
    while (lines > 0 || blank) {
        if (!in.get(c)) throw IoError(file.string() + ": the file ends before its voxel data");
        ++at;
        if (c == '\n') {
            if (blank && lineEmpty) break;
            if (!blank) --lines;
            lineEmpty = true;
        } else if (c != '\r') {
            lineEmpty = false;
        }
    }
    return at;
}

/// teem's test for a "data file:" template (`_nrrdContainsPercentThisAndMore(info, 'd')`): the first '%' that
/// is not "%%" is followed by digits and then 'd'.
bool teemSeesTemplate(const std::string& value) {
    std::size_t at = 0;
    for (;;) {
        at = value.find('%', at);
        if (at == std::string::npos || at + 1 >= value.size()) return false;
        if (value[at + 1] != '%') break;
        at += 2;
    }
    std::size_t end = at + 1;
    while (end < value.size() && std::isdigit(static_cast<unsigned char>(value[end]))) ++end;
    return end < value.size() && value[end] == 'd';
}

/// teem hands a "data file:" template to sprintf as it stands ("slice.%03d.raw 1 93 1" -> slice.001.raw):
/// a file's "%s" or "%n" reads or writes through a stray argument, a wide field ("%999999999d") overruns the
/// name's buffer. So a template is taken only with one "%d" (an optional width up to 15, zero padding) and
/// "%%"s; anything else is this file's error, at its line and column. `value`: one teemSeesTemplate takes.
void checkDataFileTemplate(const std::filesystem::path& path, int number, std::size_t start, const std::string& value) {
    const std::string name = value.substr(0, value.find_first_of(" \t"));
    int conversions = 0;
    for (std::size_t i = 0; i < name.size(); ++i) {
        if (name[i] != '%') continue;
        if (i + 1 < name.size() && name[i + 1] == '%') {
            ++i;
            continue;
        }
        std::size_t end = i + 1;
        while (end < name.size() && std::isdigit(static_cast<unsigned char>(name[end]))) ++end;
        const bool fits = end - i - 1 <= 2 && (end == i + 1 || std::stoi(name.substr(i + 1, end - i - 1)) <= 15);
        if (end >= name.size() || name[end] != 'd' || !fits || ++conversions > 1)
            throw IoError(path.string() + ":" + std::to_string(number) + ":" + std::to_string(start + i + 1) +
                          ": the data file template '" + name +
                          "' may hold one %d (zero-padded to at most 15 digits, as in slice.%03d.raw) and %% "
                          "for a percent sign, nothing else");
        i = end;
    }
}

/// teem formats its messages into a fixed buffer of 1,025 bytes with vsprintf, and many of them quote the
/// line or value they could not parse ("failed to parse \"%s\" as field identifier") or the data file they
/// could not open (its directory, "/" and name): past that the stack is smashed (a fuzz finding, in
/// tests/data/fuzz/volume/). Key/value lines ("key:=value") and comments are stored, never quoted, so they may
/// be any length.
constexpr std::size_t kTeemLineLimit = 900;

/// Reads a NRRD header before teem does and refuses, at its line and column, what teem would mishandle.
void checkHeaderForTeem(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    char magic[4] = {};
    if (!in.read(magic, 4) || std::string(magic, 4) != "NRRD") return;  // teem refuses it itself
    in.seekg(0);
    std::string line;
    // Lines end as teem's do: "\n", "\r" or "\r\n".
    const auto next = [&in](std::string& l) {
        l.clear();
        for (int c; (c = in.get()) != EOF;) {
            if (c == '\n') return true;
            if (c == '\r') {
                if (in.peek() == '\n') in.get();
                return true;
            }
            l += char(c);
        }
        return !l.empty();
    };
    const std::size_t directory = path.parent_path().string().size() + 1;  // teem opens "dir/name"
    const auto tooLong = [&](int number, std::size_t column, std::size_t bytes, const std::string& what) {
        throw IoError(path.string() + ":" + std::to_string(number) + ":" + std::to_string(column) + ": " + what +
                      " of " + std::to_string(bytes) + " bytes; NRRD headers are read up to " +
                      std::to_string(kTeemLineLimit) + " (teem's messages overflow past that)");
    };
    bool list = false;  // after "data file: LIST" each line names a data file
    for (int number = 1; next(line); ++number) {
        if (line.empty()) return;  // the blank line that ends the header
        if (list) {
            if (directory + line.size() > kTeemLineLimit)
                tooLong(number, 1, directory + line.size(), "a data file path");
            continue;
        }
        if (line[0] == '#') continue;
        const std::size_t colon = line.find(':');
        const bool keyValue = colon != std::string::npos && line.compare(colon, 2, ":=") == 0;
        if (!keyValue && line.size() > kTeemLineLimit)
            tooLong(number, kTeemLineLimit + 1, line.size(), "a header line");
        if (colon == std::string::npos || keyValue) continue;
        std::string field;
        for (char c : line.substr(0, colon))
            if (c != ' ') field += char(std::tolower(static_cast<unsigned char>(c)));
        if (field != "datafile") continue;
        const std::size_t start = line.find_first_not_of(" \t", colon + 1);
        if (start == std::string::npos) continue;
        const std::string value = line.substr(start);
        if (value.rfind("LIST", 0) == 0) {
            list = true;
            continue;
        }
        const bool numbered = teemSeesTemplate(value);
        if (numbered) checkDataFileTemplate(path, number, start, value);
        // A numbered file's path: its template with up to ten digits for the number.
        const std::size_t name = numbered ? std::min(value.find_first_of(" \t"), value.size()) + 10 : value.size();
        if (directory + name > kTeemLineLimit) tooLong(number, start + 1, directory + name, "a data file path");
    }
}

}  // namespace

DenseVolume readNrrd(const std::filesystem::path& path) {
    checkHeaderForTeem(path);
    std::lock_guard<std::mutex> lock(biffMutex());
    std::unique_ptr<Nrrd, NrrdNuke> n(nrrdNew());
    if (nrrdLoad(n.get(), path.c_str(), nullptr))
        throw IoError(path.string() + ": cannot read NRRD:\n  " + biffMessage());
    DenseVolume v;
    describe(path, *n, v);
    checkVolumeSize(path, v.dims);
    resizeLarge(v.values, std::size_t(v.voxelCount()));
    // teem has decoded and byte-swapped the data to native order: convert without swapping.
    convertVoxels(n->data, v.storedType, std::endian::native == std::endian::big, v.voxelCount(), v.values.data());
    return v;
}

std::optional<VoxelSource> nrrdSource(const std::filesystem::path& path) {
    checkHeaderForTeem(path);
    std::lock_guard<std::mutex> lock(biffMutex());
    std::unique_ptr<Nrrd, NrrdNuke> n(nrrdNew());
    std::unique_ptr<NrrdIoState, IoStateNix> nio(nrrdIoStateNew());
    nrrdIoStateSet(nio.get(), nrrdIoStateSkipData, AIR_TRUE);
    if (nrrdLoad(n.get(), path.c_str(), nio.get()))
        throw IoError(path.string() + ": cannot read NRRD:\n  " + biffMessage());
    VoxelSource s;
    describe(path, *n, s.header);
    const std::string encoding = nio->encoding ? nio->encoding->name : "";
    if ((encoding != "raw" && encoding != "gzip") || nio->dataFSkip) return std::nullopt;
    const bool gzip = encoding == "gzip";
    s.bigEndian = nio->endian == airEndianBig;
    // The data files: a numbered series ("quarter.%d 1 93 1"), a list, one file, or this one (attached).
    std::vector<std::filesystem::path> files;
    const std::filesystem::path dir = path.parent_path();
    const auto relative = [&](const std::string& name) {
        const std::filesystem::path p(name);
        return p.is_absolute() ? p : dir / p;
    };
    if (nio->dataFNFormat) {
        if (nio->dataFNStep == 0) return std::nullopt;
        for (int i = nio->dataFNMin; nio->dataFNStep > 0 ? i <= nio->dataFNMax : i >= nio->dataFNMax;
             i += nio->dataFNStep) {
            char name[4096];
            std::snprintf(name, sizeof name, nio->dataFNFormat, i);
            files.push_back(relative(name));
        }
    } else if (nio->dataFNArr && nio->dataFNArr->len > 0) {
        for (unsigned i = 0; i < nio->dataFNArr->len; ++i) files.push_back(relative(nio->dataFN[i]));
    }
    const bool attached = files.empty();
    if (attached) files.push_back(path);
    const std::uint64_t total = std::uint64_t(s.header.voxelCount()) * std::uint64_t(typeSize(s.header.storedType));
    if (total % files.size()) return std::nullopt;
    for (const std::filesystem::path& f : files) {
        VoxelSource::Part p;
        p.file = f;
        p.bytes = total / files.size();
        p.compressed = gzip;
        std::uint64_t at = attached ? skipLines(f, 0, 0, true) : 0;
        at = skipLines(f, at, nio->lineSkip, false);
        if (nio->byteSkip == -1) {
            if (gzip) return std::nullopt;
            std::error_code ec;
            const std::uint64_t size = std::filesystem::file_size(f, ec);
            if (ec || size < p.bytes)
                throw IoError(f.string() + ": holds " + std::to_string(ec ? 0 : size) + " bytes, fewer than the " +
                              std::to_string(p.bytes) + " voxel bytes the header promises");
            at = size - p.bytes;  // "byte skip: -1": the voxels end the file
        } else if (gzip) {
            p.skip = std::uint64_t(nio->byteSkip);
        } else {
            at += std::uint64_t(nio->byteSkip);
        }
        p.offset = at;
        s.parts.push_back(p);
    }
    return s;
}

}  // namespace isoforge::volume::detail
