#include "mesh/records.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>

#include <glm/geometric.hpp>

namespace isoforge::mesh::records {

namespace {

static_assert(std::endian::native == std::endian::little, "the binary writers assume a little-endian host");

unsigned colorByte(float c) {
    return static_cast<unsigned>(std::lround(std::clamp(c, 0.f, 1.f) * 255.f));
}

void appendBytes(std::string& out, const void* data, std::size_t n) {
    out.append(static_cast<const char*>(data), n);
}

}  // namespace

std::string plyHeader(std::uint64_t vertices, std::uint64_t triangles, bool normals, bool colors, bool ascii) {
    std::string h = "ply\nformat ";
    h += ascii ? "ascii" : "binary_little_endian";
    h += " 1.0\ncomment made by isoforge\nelement vertex " + std::to_string(vertices) +
         "\nproperty float x\nproperty float y\nproperty float z\n";
    if (normals) h += "property float nx\nproperty float ny\nproperty float nz\n";
    if (colors) h += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
    h += "element face " + std::to_string(triangles) + "\nproperty list uchar int vertex_indices\nend_header\n";
    return h;
}

void appendPlyVertices(std::string& out, std::span<const glm::vec3> positions, std::span<const glm::vec3> normals,
                       std::span<const glm::vec3> colors, bool ascii) {
    const bool withNormals = !normals.empty(), withColors = !colors.empty();
    if (ascii) {
        char buf[256];
        for (std::size_t i = 0; i < positions.size(); ++i) {
            const glm::vec3& p = positions[i];
            int n = std::snprintf(buf, sizeof buf, "%.9g %.9g %.9g", p.x, p.y, p.z);
            if (withNormals)
                n += std::snprintf(buf + n, sizeof buf - static_cast<std::size_t>(n), " %.6g %.6g %.6g", normals[i].x,
                                   normals[i].y, normals[i].z);
            if (withColors)
                n += std::snprintf(buf + n, sizeof buf - static_cast<std::size_t>(n), " %u %u %u",
                                   colorByte(colors[i].r), colorByte(colors[i].g), colorByte(colors[i].b));
            buf[n++] = '\n';
            out.append(buf, static_cast<std::size_t>(n));
        }
        return;
    }
    out.reserve(out.size() + positions.size() * (12 + 12 * withNormals + 3 * withColors));
    for (std::size_t i = 0; i < positions.size(); ++i) {
        appendBytes(out, &positions[i], 12);
        if (withNormals) appendBytes(out, &normals[i], 12);
        if (withColors)
            for (int k = 0; k < 3; ++k) out.push_back(static_cast<char>(colorByte(colors[i][k])));
    }
}

void appendPlyFaces(std::string& out, std::span<const glm::uvec3> triangles, bool ascii) {
    if (ascii) {
        char buf[64];
        for (const glm::uvec3& t : triangles)
            out.append(buf, static_cast<std::size_t>(std::snprintf(buf, sizeof buf, "3 %u %u %u\n", t.x, t.y, t.z)));
        return;
    }
    out.reserve(out.size() + triangles.size() * 13);
    for (const glm::uvec3& t : triangles) {
        out.push_back(3);
        const std::int32_t idx[3] = {static_cast<std::int32_t>(t.x), static_cast<std::int32_t>(t.y),
                                     static_cast<std::int32_t>(t.z)};
        appendBytes(out, idx, sizeof idx);
    }
}

void appendObjPositions(std::string& out, std::span<const glm::vec3> positions) {
    char buf[128];
    for (const glm::vec3& p : positions)
        out.append(buf, static_cast<std::size_t>(std::snprintf(buf, sizeof buf, "v %.9g %.9g %.9g\n", p.x, p.y, p.z)));
}

void appendObjNormals(std::string& out, std::span<const glm::vec3> normals) {
    char buf[128];
    for (const glm::vec3& n : normals)
        out.append(buf, static_cast<std::size_t>(std::snprintf(buf, sizeof buf, "vn %.6g %.6g %.6g\n", n.x, n.y, n.z)));
}

void appendObjFaces(std::string& out, std::span<const glm::uvec3> triangles, bool normals) {
    char buf[128];
    for (const glm::uvec3& t : triangles) {
        const int n = normals ? std::snprintf(buf, sizeof buf, "f %u//%u %u//%u %u//%u\n", t.x + 1, t.x + 1, t.y + 1,
                                              t.y + 1, t.z + 1, t.z + 1)
                              : std::snprintf(buf, sizeof buf, "f %u %u %u\n", t.x + 1, t.y + 1, t.z + 1);
        out.append(buf, static_cast<std::size_t>(n));
    }
}

std::string stlHeader(std::uint32_t triangles) {
    char header[84] = {};
    std::snprintf(header, 80, "binary STL made by isoforge");
    std::memcpy(header + 80, &triangles, 4);
    return std::string(header, 84);
}

void appendStlTriangles(std::string& out, std::span<const glm::uvec3> triangles,
                        const std::function<const glm::vec3&(std::uint32_t)>& position) {
    out.reserve(out.size() + triangles.size() * 50);
    for (const glm::uvec3& t : triangles) {
        const glm::vec3 a = position(t.x), b = position(t.y), c = position(t.z);
        glm::vec3 nrm = glm::cross(b - a, c - a);
        const float len = glm::length(nrm);
        if (len > 0) nrm /= len;
        const float rec[12] = {nrm.x, nrm.y, nrm.z, a.x, a.y, a.z, b.x, b.y, b.z, c.x, c.y, c.z};
        appendBytes(out, rec, 48);
        out.push_back(0);
        out.push_back(0);
    }
}

}  // namespace isoforge::mesh::records
