#include "mesh/stream_writer.h"

#include <algorithm>
#include <string>
#include <vector>

#include "core/error.h"
#include "mesh/records.h"
#include "mesh/text_cursor.h"

namespace isoforge::mesh {

namespace {

using detail::lowerExtension;

constexpr std::size_t kChunk = 1 << 16;

/// Reads the scratch file back `kChunk` values at a time.
template <class T, class F>
void forEachChunk(ScratchFile& file, F&& f) {
    file.rewind();
    std::vector<T> buf(kChunk);
    for (;;) {
        const std::size_t n = file.read(buf.data(), kChunk * sizeof(T)) / sizeof(T);
        if (n == 0) break;
        f(std::span<const T>(buf.data(), n));
    }
}

}  // namespace

bool MeshStreamWriter::canStream(const std::filesystem::path& path) {
    const std::string e = lowerExtension(path);
    return e == ".ply" || e == ".obj" || e == ".stl";
}

MeshStreamWriter::MeshStreamWriter(std::filesystem::path path, const StreamOptions& options)
    : path_(std::move(path)), options_(options) {
    const std::string e = lowerExtension(path_);
    if (e == ".ply")
        format_ = Format::Ply;
    else if (e == ".obj")
        format_ = Format::Obj;
    else if (e == ".stl")
        format_ = Format::Stl;
    else
        throw IoError(path_.string() + ": a mesh written piece by piece is .ply, .obj or .stl, not '" + e + "'");
    if (format_ == Format::Stl) {
        stl_ = std::make_unique<AtomicFile>(path_);
        stl_->write(records::stlHeader(0));
        return;
    }
    positions_ = std::make_unique<ScratchFile>(path_);
    faces_ = std::make_unique<ScratchFile>(path_);
    if (options_.normals) normals_ = std::make_unique<ScratchFile>(path_);
    if (options_.colors && format_ == Format::Ply) colors_ = std::make_unique<ScratchFile>(path_);
}

MeshStreamWriter::~MeshStreamWriter() = default;

void MeshStreamWriter::addVertices(std::span<const glm::vec3> positions, std::span<const glm::vec3> normals,
                                   std::span<const glm::vec3> colors) {
    vertices_ += positions.size();
    if (format_ == Format::Stl) return;
    positions_->write(positions.data(), positions.size_bytes());
    if (normals_) normals_->write(normals.data(), normals.size_bytes());
    if (colors_) {
        colors_->write(colors.data(), colors.size_bytes());
        anyColor_ = anyColor_ ||
                    std::any_of(colors.begin(), colors.end(), [](const glm::vec3& c) { return c != glm::vec3(1.f); });
    }
}

void MeshStreamWriter::addTriangles(std::span<const glm::uvec3> triangles,
                                    const std::function<const glm::vec3&(std::uint32_t)>& position) {
    triangles_ += triangles.size();
    if (format_ != Format::Stl) {
        faces_->write(triangles.data(), triangles.size_bytes());
        return;
    }
    std::string buf;
    records::appendStlTriangles(buf, triangles, position);
    stl_->write(buf);
}

void MeshStreamWriter::commit() {
    if (format_ == Format::Stl) {
        if (triangles_ > 0xFFFFFFFFull)
            throw IoError(path_.string() + ": binary STL holds at most 4,294,967,295 triangles");
        const std::string header = records::stlHeader(static_cast<std::uint32_t>(triangles_));
        if (std::fflush(stl_->stream()) != 0 || std::fseek(stl_->stream(), 80, SEEK_SET) != 0)
            throw IoError(path_.string() + ": write failed");
        stl_->write(header.data() + 80, 4);
        stl_->commit();
        return;
    }
    AtomicFile out(path_);
    std::string buf;
    auto flush = [&] {
        out.write(buf);
        buf.clear();
    };
    const bool colors = colors_ && anyColor_;
    if (format_ == Format::Ply) {
        out.write(records::plyHeader(vertices_, triangles_, normals_ != nullptr, colors, options_.ascii));
        // Positions, normals and colours interleaved: the three scratch files read in step.
        positions_->rewind();
        if (normals_) normals_->rewind();
        if (colors) colors_->rewind();
        std::vector<glm::vec3> p(kChunk), n(normals_ ? kChunk : 0), c(colors ? kChunk : 0);
        for (std::uint64_t done = 0; done < vertices_;) {
            const std::size_t k = static_cast<std::size_t>(std::min<std::uint64_t>(kChunk, vertices_ - done));
            bool ok = positions_->read(p.data(), k * 12) == k * 12;
            if (normals_) ok = ok && normals_->read(n.data(), k * 12) == k * 12;
            if (colors) ok = ok && colors_->read(c.data(), k * 12) == k * 12;
            if (!ok) throw IoError(path_.string() + ": scratch file shorter than what was written");
            records::appendPlyVertices(buf, std::span<const glm::vec3>(p.data(), k),
                                       std::span<const glm::vec3>(n.data(), normals_ ? k : 0),
                                       std::span<const glm::vec3>(c.data(), colors ? k : 0), options_.ascii);
            flush();
            done += k;
        }
        forEachChunk<glm::uvec3>(*faces_, [&](std::span<const glm::uvec3> t) {
            records::appendPlyFaces(buf, t, options_.ascii);
            flush();
        });
    } else {
        out.write(records::kObjHeader);
        forEachChunk<glm::vec3>(*positions_, [&](std::span<const glm::vec3> p) {
            records::appendObjPositions(buf, p);
            flush();
        });
        if (normals_)
            forEachChunk<glm::vec3>(*normals_, [&](std::span<const glm::vec3> n) {
                records::appendObjNormals(buf, n);
                flush();
            });
        forEachChunk<glm::uvec3>(*faces_, [&](std::span<const glm::uvec3> t) {
            records::appendObjFaces(buf, t, normals_ != nullptr);
            flush();
        });
    }
    out.commit();
}

}  // namespace isoforge::mesh
