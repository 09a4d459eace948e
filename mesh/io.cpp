#include "mesh/io.h"

#include <algorithm>
#include <bit>
#include <cctype>
#include <charconv>
#include <cmath>
#include <concepts>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <limits>
#include <optional>
#include <span>
#include <sstream>
#include <string_view>
#include <vector>

#include <glm/geometric.hpp>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/number_text.h"
#include "mesh/gltf.h"
#include "mesh/records.h"
#include "mesh/text_cursor.h"

namespace isoforge::mesh {

namespace {

using detail::describe;
using detail::lowerExtension;
using detail::readWholeFile;
using detail::TextCursor;

void triangulateFace(TriMesh& mesh, const std::vector<std::uint32_t>& face) {
    for (std::size_t k = 1; k + 1 < face.size(); ++k) mesh.triangles.emplace_back(face[0], face[k], face[k + 1]);
}

// ---------------------------------------------------------------------------------------------
// PLY
enum class PlyType { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };

std::optional<PlyType> plyType(std::string_view s) {
    if (s == "char" || s == "int8") return PlyType::Int8;
    if (s == "uchar" || s == "uint8") return PlyType::UInt8;
    if (s == "short" || s == "int16") return PlyType::Int16;
    if (s == "ushort" || s == "uint16") return PlyType::UInt16;
    if (s == "int" || s == "int32") return PlyType::Int32;
    if (s == "uint" || s == "uint32") return PlyType::UInt32;
    if (s == "float" || s == "float32") return PlyType::Float32;
    if (s == "double" || s == "float64") return PlyType::Float64;
    return std::nullopt;
}
std::size_t plySize(PlyType t) {
    switch (t) {
        case PlyType::Int8:
        case PlyType::UInt8:
            return 1;
        case PlyType::Int16:
        case PlyType::UInt16:
            return 2;
        case PlyType::Int32:
        case PlyType::UInt32:
        case PlyType::Float32:
            return 4;
        case PlyType::Float64:
            return 8;
    }
    return 0;
}

struct PlyProperty {
    std::string name;
    PlyType type = PlyType::Float32;
    bool isList = false;
    PlyType countType = PlyType::UInt8;
};
struct PlyElement {
    std::string name;
    std::uint64_t count = 0;
    std::vector<PlyProperty> properties;
    std::size_t headerLine = 0;
};

class BinaryReader {
public:
    BinaryReader(std::string_view data, std::size_t pos, bool bigEndian, std::string file)
        : data_(data),
          pos_(pos),
          swap_(bigEndian != (std::endian::native == std::endian::big)),
          file_(std::move(file)) {}
    template <class What>
    double read(PlyType t, const What& what) {
        std::size_t n = plySize(t);
        if (pos_ + n > data_.size())
            throw IoError(file_ + ": byte " + std::to_string(pos_) + ": file ends while reading " + describe(what) +
                          " (truncated?)");
        unsigned char b[8];
        std::memcpy(b, data_.data() + pos_, n);
        if (swap_) std::reverse(b, b + n);
        pos_ += n;
        switch (t) {
            case PlyType::Int8: {
                std::int8_t v;
                std::memcpy(&v, b, 1);
                return v;
            }
            case PlyType::UInt8:
                return b[0];
            case PlyType::Int16: {
                std::int16_t v;
                std::memcpy(&v, b, 2);
                return v;
            }
            case PlyType::UInt16: {
                std::uint16_t v;
                std::memcpy(&v, b, 2);
                return v;
            }
            case PlyType::Int32: {
                std::int32_t v;
                std::memcpy(&v, b, 4);
                return v;
            }
            case PlyType::UInt32: {
                std::uint32_t v;
                std::memcpy(&v, b, 4);
                return v;
            }
            case PlyType::Float32: {
                float v;
                std::memcpy(&v, b, 4);
                return v;
            }
            case PlyType::Float64: {
                double v;
                std::memcpy(&v, b, 8);
                return v;
            }
        }
        return 0;
    }
    std::size_t position() const { return pos_; }
    std::size_t remaining() const { return data_.size() - pos_; }

private:
    std::string_view data_;
    std::size_t pos_;
    bool swap_;
    std::string file_;
};

TriMesh readPly(const std::filesystem::path& path, const std::string& data) {
    const std::string file = path.string();
    TextCursor cur(data, file);
    if (cur.word() != "ply") cur.fail("expected 'ply' magic at the start of the file");
    cur.nextLine();
    enum class Format { Ascii, BinaryLE, BinaryBE } format = Format::Ascii;
    bool haveFormat = false;
    std::vector<PlyElement> elements;
    for (;;) {
        if (cur.atEnd()) cur.fail("file ends inside the header: expected 'end_header'");
        std::string_view kw = cur.word();
        if (kw.empty()) {
            cur.nextLine();
            continue;
        }
        if (kw == "end_header") {
            // The body starts right after this line's newline.
            while (!cur.atEnd() && cur.peek() != '\n') cur.advance();
            if (!cur.atEnd()) cur.advance();
            break;
        }
        if (kw == "comment" || kw == "obj_info") {
            cur.nextLine();
            continue;
        }
        if (kw == "format") {
            std::string_view f = cur.word();
            if (f == "ascii")
                format = Format::Ascii;
            else if (f == "binary_little_endian")
                format = Format::BinaryLE;
            else if (f == "binary_big_endian")
                format = Format::BinaryBE;
            else
                cur.fail("expected ascii, binary_little_endian or binary_big_endian, found '" + std::string(f) + "'");
            haveFormat = true;
        } else if (kw == "element") {
            PlyElement e;
            e.headerLine = cur.line();
            e.name = std::string(cur.word());
            if (e.name.empty()) cur.fail("expected an element name");
            e.count = cur.number<std::uint64_t>("an element count");
            elements.push_back(std::move(e));
        } else if (kw == "property") {
            if (elements.empty()) cur.fail("'property' before any 'element'");
            PlyProperty p;
            std::string_view t = cur.word();
            if (t == "list") {
                p.isList = true;
                auto ct = plyType(cur.word());
                if (!ct || *ct == PlyType::Float32 || *ct == PlyType::Float64)
                    cur.fail("expected an integer list count type");
                p.countType = *ct;
                t = cur.word();
            }
            auto ty = plyType(t);
            if (!ty)
                cur.fail("expected a property type (char uchar short ushort int uint float double), found '" +
                         std::string(t) + "'");
            p.type = *ty;
            p.name = std::string(cur.word());
            if (p.name.empty()) cur.fail("expected a property name");
            elements.back().properties.push_back(std::move(p));
        } else {
            cur.fail("unexpected '" + std::string(kw) + "' in PLY header");
        }
        cur.nextLine();
    }
    if (!haveFormat) throw IoError(file + ": PLY header has no 'format' line");

    TriMesh mesh;
    const std::size_t bodyStart = cur.position();
    const std::size_t bodyBytes = data.size() - bodyStart;
    BinaryReader bin(data, bodyStart, format == Format::BinaryBE, file);
    TextCursor text(data, file, bodyStart, cur.line());
    std::vector<std::uint32_t> face;
    bool haveFaces = false;

    for (const PlyElement& e : elements) {
        // Hostile counts: every element needs at least one byte (binary) or two characters (ASCII).
        std::size_t minBytes = 0;
        for (const auto& p : e.properties) minBytes += p.isList ? plySize(p.countType) : plySize(p.type);
        if (format == Format::Ascii) minBytes = 2 * e.properties.size();
        if (minBytes > 0 && e.count > bodyBytes / minBytes)
            throw IoError(file + ":" + std::to_string(e.headerLine) + ": header declares " + std::to_string(e.count) +
                          " " + e.name + " elements, but the file holds only " + std::to_string(bodyBytes) +
                          " bytes of data");
        const bool isVertex = e.name == "vertex";
        const bool isFace = e.name == "face";
        int ix = -1, iy = -1, iz = -1, inx = -1, iny = -1, inz = -1, iface = -1, ir = -1, ig = -1, ib = -1;
        for (int k = 0; k < static_cast<int>(e.properties.size()); ++k) {
            const std::string& n = e.properties[k].name;
            if (isVertex && !e.properties[k].isList) {
                if (n == "x")
                    ix = k;
                else if (n == "y")
                    iy = k;
                else if (n == "z")
                    iz = k;
                else if (n == "nx")
                    inx = k;
                else if (n == "ny")
                    iny = k;
                else if (n == "nz")
                    inz = k;
                else if (n == "red")
                    ir = k;
                else if (n == "green")
                    ig = k;
                else if (n == "blue")
                    ib = k;
            }
            if (isFace && e.properties[k].isList && (n == "vertex_indices" || n == "vertex_index")) iface = k;
        }
        if (isVertex) {
            if (ix < 0 || iy < 0 || iz < 0)
                throw IoError(file + ":" + std::to_string(e.headerLine) + ": vertex element lacks x, y or z");
            mesh.positions.resize(e.count);
            if (inx >= 0 && iny >= 0 && inz >= 0) mesh.normals.resize(e.count);
            if (ir >= 0 && ig >= 0 && ib >= 0) mesh.colors.resize(e.count);
        }
        if (isFace) {
            if (iface < 0)
                throw IoError(file + ":" + std::to_string(e.headerLine) + ": face element lacks a vertex_indices list");
            haveFaces = true;
            mesh.triangles.reserve(e.count);
        }
        double values[64];
        for (std::uint64_t i = 0; i < e.count; ++i) {
            if (format == Format::Ascii) text.skipWhitespace();
            for (int k = 0; k < static_cast<int>(e.properties.size()); ++k) {
                const PlyProperty& p = e.properties[k];
                auto what = [&] { return e.name + " " + std::to_string(i) + " property '" + p.name + "'"; };
                auto readValue = [&](PlyType t) -> double {
                    if (format != Format::Ascii) return bin.read(t, what);
                    if (text.atEnd()) text.fail("file ends while reading " + what() + " (truncated?)");
                    return text.number<double>(what);  // one element per line
                };
                if (!p.isList) {
                    double v = readValue(p.type);
                    if (k < 64) values[k] = v;
                    continue;
                }
                double countValue = readValue(p.countType);
                if (countValue < 0) throw IoError(file + ": negative list length in " + what());
                // An ASCII count can be any number: past 2^32 (the largest a uint count holds) it is refused
                // before the conversion to an integer (undefined past 2^64).
                if (!(countValue <= 4294967295.0))
                    throw IoError(file + ": list length " + numberText(countValue) + " in " + what() +
                                  " is more than any PLY list holds");
                auto count = static_cast<std::uint64_t>(countValue);
                if (k == iface) face.clear();
                for (std::uint64_t j = 0; j < count; ++j) {
                    double v = readValue(p.type);
                    if (k != iface) continue;
                    if (v < 0 || v >= static_cast<double>(mesh.positions.size()) || v != std::floor(v)) {
                        const std::string where = format == Format::Ascii ? ":" + std::to_string(text.line())
                                                                          : ": byte " + std::to_string(bin.position());
                        throw IoError(file + where + ": " + e.name + " " + std::to_string(i) + " names vertex " +
                                      numberText(v) + ", but there are " + std::to_string(mesh.positions.size()) +
                                      " vertices");
                    }
                    face.push_back(static_cast<std::uint32_t>(v));
                }
            }
            if (format == Format::Ascii && !text.atLineEnd())
                text.fail("expected the end of " + e.name + " " + std::to_string(i) + "'s line, found more values");
            if (isVertex) {
                mesh.positions[i] = glm::vec3(values[ix], values[iy], values[iz]);
                if (!mesh.normals.empty()) mesh.normals[i] = glm::vec3(values[inx], values[iny], values[inz]);
                if (!mesh.colors.empty()) {
                    const bool bytes = e.properties[static_cast<std::size_t>(ir)].type == PlyType::UInt8;
                    mesh.colors[i] = glm::vec3(values[ir], values[ig], values[ib]) / (bytes ? 255.f : 1.f);
                }
            } else if (isFace) {
                triangulateFace(mesh, face);
            }
        }
    }
    if (!haveFaces) throw IoError(file + ": PLY file has no face element (point clouds are not meshes)");
    return mesh;
}

/// Whole-mesh writers: the records of mesh/records.h, a chunk at a time.
constexpr std::size_t kChunk = 1 << 16;

template <class T>
std::span<const T> chunkOf(const std::vector<T>& v, std::size_t begin) {
    return begin < v.size() ? std::span<const T>(v).subspan(begin, std::min(kChunk, v.size() - begin))
                            : std::span<const T>();
}

void writePly(const std::filesystem::path& path, const TriMesh& mesh, bool ascii) {
    AtomicFile out(path);
    const bool normals = mesh.normals.size() == mesh.positions.size() && !mesh.normals.empty();
    const bool colors = mesh.colors.size() == mesh.positions.size() && !mesh.colors.empty();
    out.write(records::plyHeader(mesh.positions.size(), mesh.triangles.size(), normals, colors, ascii));
    std::string buf;
    for (std::size_t b = 0; b < mesh.positions.size(); b += kChunk) {
        buf.clear();
        records::appendPlyVertices(buf, chunkOf(mesh.positions, b),
                                   normals ? chunkOf(mesh.normals, b) : std::span<const glm::vec3>(),
                                   colors ? chunkOf(mesh.colors, b) : std::span<const glm::vec3>(), ascii);
        out.write(buf);
    }
    for (std::size_t b = 0; b < mesh.triangles.size(); b += kChunk) {
        buf.clear();
        records::appendPlyFaces(buf, chunkOf(mesh.triangles, b), ascii);
        out.write(buf);
    }
    out.commit();
}

// ---------------------------------------------------------------------------------------------
// OBJ
TriMesh readObj(const std::filesystem::path& path, const std::string& data) {
    TextCursor cur(data, path.string());
    TriMesh mesh;
    std::vector<std::uint32_t> face;
    while (!cur.atEnd()) {
        cur.skipSpaces();
        std::string_view kw = cur.word();
        if (kw == "v") {
            float x = cur.number<float>("vertex x"), y = cur.number<float>("vertex y"),
                  z = cur.number<float>("vertex z");
            mesh.positions.emplace_back(x, y, z);
        } else if (kw == "f") {
            face.clear();
            while (!cur.atLineEnd()) {
                long long idx = cur.number<long long>("a vertex index");
                long long n = static_cast<long long>(mesh.positions.size());
                long long resolved = idx < 0 ? n + idx : idx - 1;
                if (idx == 0 || resolved < 0 || resolved >= n)
                    cur.fail("face names vertex " + std::to_string(idx) + ", but " + std::to_string(n) +
                             " vertices are defined so far");
                face.push_back(static_cast<std::uint32_t>(resolved));
                while (!cur.atEnd() && !std::isspace(static_cast<unsigned char>(cur.peek()))) cur.advance();  // /vt/vn
            }
            if (face.size() < 3) cur.fail("a face needs at least 3 vertices, found " + std::to_string(face.size()));
            triangulateFace(mesh, face);
        }
        cur.nextLine();  // other statements (vn vt g o s usemtl mtllib l p comments) carry no geometry we use
    }
    if (mesh.triangles.empty()) throw IoError(path.string() + ": OBJ file has no faces");
    return mesh;
}

void writeObj(const std::filesystem::path& path, const TriMesh& mesh) {
    AtomicFile out(path);
    const bool normals = mesh.normals.size() == mesh.positions.size() && !mesh.normals.empty();
    out.write(records::kObjHeader);
    std::string buf;
    for (std::size_t b = 0; b < mesh.positions.size(); b += kChunk) {
        buf.clear();
        records::appendObjPositions(buf, chunkOf(mesh.positions, b));
        out.write(buf);
    }
    if (normals)
        for (std::size_t b = 0; b < mesh.normals.size(); b += kChunk) {
            buf.clear();
            records::appendObjNormals(buf, chunkOf(mesh.normals, b));
            out.write(buf);
        }
    for (std::size_t b = 0; b < mesh.triangles.size(); b += kChunk) {
        buf.clear();
        records::appendObjFaces(buf, chunkOf(mesh.triangles, b), normals);
        out.write(buf);
    }
    out.commit();
}

// ---------------------------------------------------------------------------------------------
// OFF (Geomview): "OFF" or "COFF", counts, vertices (with RGB[A] for COFF), polygons "n i1 .. in".
TriMesh readOff(const std::filesystem::path& path, const std::string& data) {
    TextCursor cur(data, path.string());
    auto skip = [&] {  // whitespace and '#' comments
        for (;;) {
            cur.skipWhitespace();
            if (cur.peek() != '#') return;
            cur.nextLine();
        }
    };
    skip();
    const std::string_view magic = cur.word();
    if (magic != "OFF" && magic != "COFF") cur.fail("expected OFF or COFF, found '" + std::string(magic) + "'");
    const bool colours = magic == "COFF";
    skip();
    const long long nv = cur.number<long long>("the vertex count");
    skip();
    const long long nf = cur.number<long long>("the face count");
    skip();
    (void)cur.number<long long>("the edge count");
    // Every vertex takes at least 6 bytes ("0 0 0\n"), every face 8: refuse counts the file cannot hold.
    if (nv < 0 || nf < 0 || nv > static_cast<long long>(data.size()) / 6 ||
        nf > static_cast<long long>(data.size()) / 8)
        cur.fail("header declares " + std::to_string(nv) + " vertices and " + std::to_string(nf) +
                 " faces, more than a file of " + std::to_string(data.size()) + " bytes can hold");
    TriMesh mesh;
    mesh.positions.reserve(static_cast<std::size_t>(nv));
    bool bytes = false;
    for (long long i = 0; i < nv; ++i) {
        skip();
        if (cur.atEnd()) cur.fail("file ends after " + std::to_string(i) + " of " + std::to_string(nv) + " vertices");
        const float x = cur.number<float>("vertex x"), y = cur.number<float>("vertex y"),
                    z = cur.number<float>("vertex z");
        mesh.positions.emplace_back(x, y, z);
        if (colours) {
            glm::vec3 c;
            for (int k = 0; k < 3; ++k) c[k] = cur.number<float>("a colour component");
            if (!cur.atLineEnd()) (void)cur.number<float>("alpha");
            bytes = bytes || c.x > 1.f || c.y > 1.f || c.z > 1.f;
            mesh.colors.push_back(c);
        }
    }
    if (bytes)
        for (auto& c : mesh.colors) c /= 255.f;
    std::vector<std::uint32_t> face;
    for (long long f = 0; f < nf; ++f) {
        skip();
        if (cur.atEnd()) cur.fail("file ends after " + std::to_string(f) + " of " + std::to_string(nf) + " faces");
        const long long n = cur.number<long long>("the face's vertex count");
        if (n < 3 || n > nv)
            cur.fail("a face needs 3 to " + std::to_string(nv) + " vertices, found " + std::to_string(n));
        face.clear();
        for (long long k = 0; k < n; ++k) {
            const long long idx = cur.number<long long>("a vertex index");
            if (idx < 0 || idx >= nv)
                cur.fail("face names vertex " + std::to_string(idx) + ", but there are " + std::to_string(nv));
            face.push_back(static_cast<std::uint32_t>(idx));
        }
        triangulateFace(mesh, face);
        cur.nextLine();  // per-face colours, if any, are ignored
    }
    if (mesh.triangles.empty()) throw IoError(path.string() + ": OFF file has no faces");
    return mesh;
}

// ---------------------------------------------------------------------------------------------
// STL
TriMesh readStl(const std::filesystem::path& path, const std::string& data) {
    const std::string file = path.string();
    TriMesh mesh;
    bool binary = false;
    if (data.size() >= 84) {
        std::uint32_t n;
        std::memcpy(&n, data.data() + 80, 4);
        binary = data.size() == 84 + 50ull * n;
    }
    const bool looksAscii = data.compare(0, 5, "solid") == 0 && !binary;
    if (binary) {
        std::uint32_t n;
        std::memcpy(&n, data.data() + 80, 4);
        mesh.positions.reserve(3ull * n);
        mesh.triangles.reserve(n);
        for (std::uint32_t i = 0; i < n; ++i) {
            const char* rec = data.data() + 84 + 50ull * i;
            for (int k = 0; k < 3; ++k) {
                float p[3];
                std::memcpy(p, rec + 12 + 12 * k, 12);
                if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
                    throw IoError(file + ": byte " + std::to_string(84 + 50ull * i + 12 + 12 * k) + ": triangle " +
                                  std::to_string(i) + " has a non-finite coordinate");
                mesh.positions.emplace_back(p[0], p[1], p[2]);
            }
            mesh.triangles.emplace_back(3 * i, 3 * i + 1, 3 * i + 2);
        }
    } else if (looksAscii) {
        TextCursor cur(data, file);
        cur.nextLine();
        std::vector<glm::vec3> corner;
        while (!cur.atEnd()) {
            std::string_view kw = cur.word();
            if (kw == "vertex") {
                float x = cur.number<float>("vertex x"), y = cur.number<float>("vertex y"),
                      z = cur.number<float>("vertex z");
                corner.emplace_back(x, y, z);
            } else if (kw == "endfacet") {
                if (corner.size() != 3)
                    cur.fail("facet has " + std::to_string(corner.size()) + " vertices, expected 3");
                auto b = static_cast<std::uint32_t>(mesh.positions.size());
                mesh.positions.insert(mesh.positions.end(), corner.begin(), corner.end());
                mesh.triangles.emplace_back(b, b + 1, b + 2);
                corner.clear();
            } else if (kw == "endsolid") {
                break;
            } else if (!kw.empty() && kw != "facet" && kw != "outer" && kw != "endloop" && kw != "solid") {
                cur.fail("unexpected '" + std::string(kw) + "' in ASCII STL");
            }
            cur.nextLine();
        }
        if (!corner.empty()) cur.fail("file ends inside a facet (truncated?)");
    } else {
        std::uint32_t n = 0;
        if (data.size() >= 84) std::memcpy(&n, data.data() + 80, 4);
        throw IoError(file + ": not an STL file: binary STL of " + std::to_string(n) + " triangles needs " +
                      std::to_string(84 + 50ull * n) + " bytes, the file has " + std::to_string(data.size()) +
                      " (truncated?), and it does not start with 'solid'");
    }
    if (mesh.triangles.empty()) throw IoError(file + ": STL file has no triangles");
    weldIdenticalPositions(mesh);
    return mesh;
}

void writeStl(const std::filesystem::path& path, const TriMesh& mesh) {
    AtomicFile out(path);
    out.write(records::stlHeader(static_cast<std::uint32_t>(mesh.triangles.size())));
    std::string buf;
    const auto position = [&](std::uint32_t i) -> const glm::vec3& { return mesh.positions[i]; };
    for (std::size_t b = 0; b < mesh.triangles.size(); b += kChunk) {
        buf.clear();
        records::appendStlTriangles(buf, chunkOf(mesh.triangles, b), position);
        out.write(buf);
    }
    out.commit();
}

void writeGlb(const std::filesystem::path& path, const TriMesh& mesh) {
    const std::string bytes = detail::encodeGlb(mesh);
    AtomicFile out(path);
    out.write(bytes.data(), bytes.size());
    out.commit();
}

}  // namespace

bool isMeshPath(const std::filesystem::path& path) {
    const std::string e = lowerExtension(path);
    return e == ".ply" || e == ".obj" || e == ".stl" || e == ".glb";
}

bool isReadableMeshPath(const std::filesystem::path& path) {
    const std::string e = lowerExtension(path);
    return e == ".ply" || e == ".obj" || e == ".stl" || e == ".off";
}

TriMesh readMesh(const std::filesystem::path& path) {
    const std::string e = lowerExtension(path);
    if (e == ".glb") throw IoError(path.string() + ": .glb is an output format here; read .ply, .obj, .stl or .off");
    if (e != ".ply" && e != ".obj" && e != ".stl" && e != ".off")
        throw IoError(path.string() + ": unknown mesh extension '" + e + "' (expected .ply, .obj, .stl or .off)");
    const std::string data = readWholeFile(path);
    if (e == ".ply") return readPly(path, data);
    if (e == ".obj") return readObj(path, data);
    if (e == ".off") return readOff(path, data);
    return readStl(path, data);
}

void writeMesh(const std::filesystem::path& path, const TriMesh& mesh, const WriteOptions& options) {
    const std::string e = lowerExtension(path);
    if (e == ".ply")
        writePly(path, mesh, options.ascii);
    else if (e == ".obj")
        writeObj(path, mesh);
    else if (e == ".stl")
        writeStl(path, mesh);
    else if (e == ".glb")
        writeGlb(path, mesh);
    else
        throw IoError(path.string() + ": cannot write '" + e + "' meshes (write .ply, .obj, .stl or .glb)");
}

std::string glbBytes(const TriMesh& mesh) {
    return detail::encodeGlb(mesh);
}

}  // namespace isoforge::mesh
