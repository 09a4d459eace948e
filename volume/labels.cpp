#include "volume/labels.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <fstream>
#include <sstream>
#include <unordered_map>

#include <glm/gtc/type_precision.hpp>
#include <glm/matrix.hpp>

#include <tbb/parallel_for.h>

#include "core/error.h"
#include "volume/dense_grid.h"
#include "volume/marching_cubes.h"

namespace isoforge::volume {

std::array<float, 3> defaultLabelColor(int label) {
    const float h = std::fmod(float(label) * 0.618034f, 1.f) * 6.f, s = 0.55f, v = 0.9f;
    const int i = int(h);
    const float f = h - float(i), p = v * (1 - s), q = v * (1 - s * f), t = v * (1 - s * (1 - f));
    switch (i % 6) {
        case 0:
            return {v, t, p};
        case 1:
            return {q, v, p};
        case 2:
            return {p, v, t};
        case 3:
            return {p, q, v};
        case 4:
            return {t, p, v};
        default:
            return {v, p, q};
    }
}

namespace {
bool isInteger(const std::string& s, long& out) {
    char* end = nullptr;
    out = std::strtol(s.c_str(), &end, 10);
    return !s.empty() && end && *end == '\0';
}
bool isNumber(const std::string& s) {
    char* end = nullptr;
    std::strtod(s.c_str(), &end);
    return !s.empty() && end && *end == '\0';
}
}  // namespace

LabelTable readLabelTable(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw IoError(path.string() + ": cannot open the label table");
    const std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    LabelTable table;
    std::string ext = path.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    if (ext == ".lut") {
        if (data.size() != 768)
            throw IoError(path.string() + ": a binary .lut holds 768 bytes (256 reds, greens, blues); this one has " +
                          std::to_string(data.size()));
        for (int i = 0; i < 256; ++i) {
            LabelInfo& l = table[i];
            for (int c = 0; c < 3; ++c)
                l.color[std::size_t(c)] = float(static_cast<unsigned char>(data[std::size_t(c * 256 + i)])) / 255.f;
            l.hasColor = true;
        }
        return table;
    }
    std::istringstream lines(data);
    std::string line;
    int lineNo = 0;
    while (std::getline(lines, line)) {
        ++lineNo;
        if (!line.empty() && line.back() == '\r') line.pop_back();
        const auto first = line.find_first_not_of(" \t");
        if (first == std::string::npos || line[first] == '#') continue;
        // Tokens, with "quoted names" kept whole.
        std::vector<std::string> tok;
        for (std::size_t i = first; i < line.size();) {
            if (line[i] == ' ' || line[i] == '\t') {
                ++i;
                continue;
            }
            if (line[i] == '"') {
                const auto close = line.find('"', i + 1);
                if (close == std::string::npos)
                    throw IoError(path.string() + ":" + std::to_string(lineNo) + ": unterminated quoted name");
                tok.push_back(line.substr(i + 1, close - i - 1));
                i = close + 1;
                continue;
            }
            const auto end = line.find_first_of(" \t", i);
            tok.push_back(line.substr(i, end == std::string::npos ? std::string::npos : end - i));
            i = end == std::string::npos ? line.size() : end;
        }
        long idx = 0;
        if (!isInteger(tok[0], idx) || idx < 0 || idx > 65535)
            throw IoError(path.string() + ":" + std::to_string(lineNo) +
                          ": expected a label number from 0 to 65535, found '" + tok[0] + "'");
        LabelInfo info;
        for (std::size_t i = 1; i < tok.size(); ++i)
            if (!isNumber(tok[i])) {
                info.name = tok[i];
                break;
            }
        // The first run of three integers from 0 to 255 after the index is the colour.
        for (std::size_t i = 1; i + 2 < tok.size(); ++i) {
            long r, g, b;
            if (isInteger(tok[i], r) && isInteger(tok[i + 1], g) && isInteger(tok[i + 2], b) && r >= 0 && r <= 255 &&
                g >= 0 && g <= 255 && b >= 0 && b <= 255) {
                info.color = {float(r) / 255.f, float(g) / 255.f, float(b) / 255.f};
                info.hasColor = true;
                break;
            }
        }
        table[int(idx)] = info;
    }
    if (table.empty()) throw IoError(path.string() + ": no labels in the table");
    return table;
}

namespace {

std::vector<LabelSurface> labelSurfacesMc(const DenseVolume& v, Progress* progress) {
    // One pass: the voxels of each label, and each label's bounding box.
    std::map<int, std::vector<std::uint32_t>> voxels;
    const auto nx = v.dims[0], ny = v.dims[1];
    for (std::size_t i = 0; i < v.values.size(); ++i) {
        const float x = v.values[i];
        if (!(std::abs(x) >= 0.5f)) continue;  // background (and NaN)
        const long label = std::lround(x);
        if (label < -65535 || label > 65535) continue;
        voxels[int(label)].push_back(static_cast<std::uint32_t>(i));
    }
    if (v.values.size() > 0xFFFFFFFFu) throw ResourceError("label maps over 2^32 voxels are not supported");
    std::vector<LabelSurface> out(voxels.size());
    std::vector<const std::vector<std::uint32_t>*> lists;
    std::size_t k = 0;
    for (const auto& [label, list] : voxels) {
        out[k].label = label;
        out[k].voxels = list.size();
        lists.push_back(&list);
        ++k;
    }
    const auto xform = transformOf(v.indexToWorld);
    std::atomic<std::size_t> done{0};
    if (progress) progress->begin("meshing labels");
    tbb::parallel_for(std::size_t(0), out.size(), [&](std::size_t i) {
        auto grid = openvdb::FloatGrid::create(0.f);
        grid->setTransform(xform->copy());
        grid->setGridClass(openvdb::GRID_FOG_VOLUME);
        auto acc = grid->getAccessor();
        for (std::uint32_t idx : *lists[i]) {
            const auto x = std::int64_t(idx) % nx, y = (std::int64_t(idx) / nx) % ny, z = std::int64_t(idx) / (nx * ny);
            acc.setValue(openvdb::Coord(int(x), int(y), int(z)), 1.f);
        }
        MeshingOptions o;
        o.isovalue = 0.5f;
        o.inside = InsideSide::Above;
        out[i].mesh = extractIsosurface(*grid, o);
        if (progress) progress->update(++done, out.size());
    });
    if (progress) progress->end();
    return out;
}

/// The shared-boundary surfaces (LabelMethod::Shared). Positions are barycentres of simplices of the Kuhn
/// triangulation, kept as integers in units of 1/12 voxel (edge midpoints, face and tetrahedron centroids
/// are all whole there), so every label finds exactly the same vertices.
std::vector<LabelSurface> labelSurfacesShared(const DenseVolume& v, Progress* progress) {
    const std::int64_t nx = v.dims[0], ny = v.dims[1], nz = v.dims[2];
    if (12 * (std::max({nx, ny, nz}) + 2) >= (1 << 20))
        throw ResourceError("label volumes over 87,000 voxels along an axis are not supported by shared surfaces");
    auto label = [&](std::int64_t i, std::int64_t j, std::int64_t k) -> long {
        if (i < 0 || j < 0 || k < 0 || i >= nx || j >= ny || k >= nz) return 0;
        const float x = v.values[std::size_t((k * ny + j) * nx + i)];
        return std::isfinite(x) ? std::lround(x) : 0;
    };
    // Kuhn's six tetrahedra: corner 0 to corner 7 through one axis, then two (bit x = 1, y = 2, z = 4).
    static const int kTets[6][4] = {{0, 1, 3, 7}, {0, 1, 5, 7}, {0, 2, 3, 7}, {0, 2, 6, 7}, {0, 4, 5, 7}, {0, 4, 6, 7}};
    struct Tri {
        std::array<std::uint64_t, 3> key;  ///< packed 1/12-voxel coordinates
        long a, b;                         ///< labels: the triangle faces from a towards b
    };
    auto pack = [](std::int64_t x, std::int64_t y, std::int64_t z) {
        return (std::uint64_t(x + 24) << 42) | (std::uint64_t(y + 24) << 21) | std::uint64_t(z + 24);
    };
    // Cells [i, i + 1] x ... between voxel centres, from -1 so that the volume's border closes the surfaces.
    // Parallel over slabs of cells in z; each slab's triangles in a fixed order, slabs concatenated in order.
    const std::int64_t cz = nz + 1;
    std::vector<std::vector<Tri>> slabs(static_cast<std::size_t>(cz));
    std::atomic<std::size_t> done{0};
    if (progress) progress->begin("label surfaces");
    tbb::parallel_for(std::int64_t(0), cz, [&](std::int64_t s) {
        const std::int64_t k = s - 1;
        std::vector<Tri>& out = slabs[std::size_t(s)];
        for (std::int64_t j = -1; j < ny; ++j)
            for (std::int64_t i = -1; i < nx; ++i) {
                long c[8];
                bool uniform = true;
                for (int q = 0; q < 8; ++q) {
                    c[q] = label(i + (q & 1), j + ((q >> 1) & 1), k + ((q >> 2) & 1));
                    uniform = uniform && c[q] == c[0];
                }
                if (uniform) continue;
                auto corner = [&](int q) {
                    return glm::i64vec3(12 * (i + (q & 1)), 12 * (j + ((q >> 1) & 1)), 12 * (k + ((q >> 2) & 1)));
                };
                for (const auto& t : kTets) {
                    const long l[4] = {c[t[0]], c[t[1]], c[t[2]], c[t[3]]};
                    const glm::i64vec3 p[4] = {corner(t[0]), corner(t[1]), corner(t[2]), corner(t[3])};
                    auto mid = [&](int a, int b) { return (p[a] + p[b]) / std::int64_t(2); };
                    // One triangle between labels la (on the side of corner from) and lb (corner to).
                    auto emit = [&](glm::i64vec3 q0, glm::i64vec3 q1, glm::i64vec3 q2, int from, int to) {
                        const glm::i64vec3 u = q1 - q0, w = q2 - q0, d = p[to] - p[from];
                        const glm::i64vec3 n(u.y * w.z - u.z * w.y, u.z * w.x - u.x * w.z, u.x * w.y - u.y * w.x);
                        if (n.x * d.x + n.y * d.y + n.z * d.z < 0) std::swap(q1, q2);
                        out.push_back(
                            {{pack(q0.x, q0.y, q0.z), pack(q1.x, q1.y, q1.z), pack(q2.x, q2.y, q2.z)}, l[from], l[to]});
                    };
                    int distinct = 1;
                    for (int a = 1; a < 4; ++a) {
                        bool seen = false;
                        for (int b = 0; b < a; ++b) seen = seen || l[b] == l[a];
                        distinct += !seen;
                    }
                    if (distinct == 1) continue;
                    if (distinct == 2) {
                        // Marching tetrahedra: one label's corners cut off by a triangle (1 : 3) or a quad (2 : 2).
                        int same[4], other[4], ns = 0, no = 0;
                        for (int a = 0; a < 4; ++a) (l[a] == l[0] ? same[ns++] : other[no++]) = a;
                        if (ns == 1 || no == 1) {
                            const int lone = ns == 1 ? same[0] : other[0];
                            int rest[3], nr = 0;
                            for (int a = 0; a < 4; ++a)
                                if (a != lone) rest[nr++] = a;
                            emit(mid(lone, rest[0]), mid(lone, rest[1]), mid(lone, rest[2]), lone, rest[0]);
                        } else {
                            const int x = same[0], y = same[1], z = other[0], w = other[1];
                            const glm::i64vec3 q[4] = {mid(x, z), mid(x, w), mid(y, w), mid(y, z)};
                            const auto key = [&](int n) { return pack(q[n].x, q[n].y, q[n].z); };
                            if (std::min(key(0), key(2)) < std::min(key(1), key(3))) {
                                emit(q[0], q[1], q[2], x, z);
                                emit(q[0], q[2], q[3], x, z);
                            } else {
                                emit(q[1], q[2], q[3], x, z);
                                emit(q[1], q[3], q[0], x, z);
                            }
                        }
                        continue;
                    }
                    // Three or four labels: the barycentric construction around the tetrahedron's centroid,
                    // through face centroids where a face has three labels, straight across two-label faces.
                    const glm::i64vec3 centre = (p[0] + p[1] + p[2] + p[3]) / std::int64_t(4);
                    for (int omit = 0; omit < 4; ++omit) {
                        int f[3], nf = 0;
                        for (int a = 0; a < 4; ++a)
                            if (a != omit) f[nf++] = a;
                        const bool ab = l[f[0]] == l[f[1]], bc = l[f[1]] == l[f[2]], ac = l[f[0]] == l[f[2]];
                        if (ab && bc) continue;
                        if (!ab && !bc && !ac) {
                            const glm::i64vec3 fc = (p[f[0]] + p[f[1]] + p[f[2]]) / std::int64_t(3);
                            for (int fi = 0; fi < 3; ++fi)
                                for (int fj = fi + 1; fj < 3; ++fj) emit(mid(f[fi], f[fj]), fc, centre, f[fi], f[fj]);
                        } else {
                            const int lone = ab ? f[2] : (bc ? f[0] : f[1]);
                            int q[2], nq = 0;
                            for (int fi = 0; fi < 3; ++fi)
                                if (f[fi] != lone) q[nq++] = f[fi];
                            emit(mid(lone, q[0]), mid(lone, q[1]), centre, lone, q[0]);
                        }
                    }
                }
            }
        if (progress) progress->update(++done, std::size_t(cz));
    });
    if (progress) progress->end();

    // Each triangle to both of its labels (background 0 gets none): first the lists (in slab order), then
    // each label's mesh with its own vertex numbering, labels in parallel.
    std::map<long, std::size_t> slotOf;
    for (const auto& slab : slabs)
        for (const Tri& t : slab) {
            if (t.a != 0) slotOf.emplace(t.a, 0);
            if (t.b != 0) slotOf.emplace(t.b, 0);
        }
    std::vector<long> labels;
    for (auto& [l, slot] : slotOf) {
        slot = labels.size();
        labels.push_back(l);
    }
    struct Ref {
        std::uint32_t slab, index;
        bool reversed;
    };
    std::vector<std::vector<Ref>> refs(labels.size());
    for (std::uint32_t sl = 0; sl < slabs.size(); ++sl)
        for (std::uint32_t i = 0; i < slabs[sl].size(); ++i) {
            const Tri& t = slabs[sl][i];
            if (t.a != 0) refs[slotOf[t.a]].push_back({sl, i, false});  // faces from a to b: outward for a
            if (t.b != 0) refs[slotOf[t.b]].push_back({sl, i, true});   // inward for b
        }
    const bool mirror = glm::determinant(glm::dmat3(v.indexToWorld)) < 0;
    std::vector<LabelSurface> surfaces(labels.size());
    tbb::parallel_for(std::size_t(0), labels.size(), [&](std::size_t li) {
        LabelSurface& surf = surfaces[li];
        surf.label = int(labels[li]);
        std::unordered_map<std::uint64_t, std::uint32_t> ids;
        ids.reserve(refs[li].size());
        surf.mesh.triangles.reserve(refs[li].size());
        for (const Ref& r : refs[li]) {
            const Tri& t = slabs[r.slab][r.index];
            std::uint32_t idx[3];
            for (int q = 0; q < 3; ++q) {
                const std::uint64_t kk = t.key[std::size_t(q)];
                auto [it, added] = ids.try_emplace(kk, std::uint32_t(surf.mesh.positions.size()));
                if (added) {
                    const double x = double(std::int64_t(kk >> 42) - 24) / 12.0,
                                 y = double(std::int64_t((kk >> 21) & 0x1FFFFF) - 24) / 12.0,
                                 z = double(std::int64_t(kk & 0x1FFFFF) - 24) / 12.0;
                    surf.mesh.positions.emplace_back(v.indexToWorld * glm::dvec4(x, y, z, 1.0));
                }
                idx[q] = it->second;
            }
            if (r.reversed != mirror)
                surf.mesh.triangles.emplace_back(idx[0], idx[2], idx[1]);
            else
                surf.mesh.triangles.emplace_back(idx[0], idx[1], idx[2]);
        }
    });
    std::map<long, LabelSurface> byLabel;
    for (auto& surf : surfaces) byLabel.emplace(surf.label, std::move(surf));
    // Voxel counts.
    for (float x : v.values)
        if (std::isfinite(x) && std::lround(x) != 0)
            if (auto it = byLabel.find(std::lround(x)); it != byLabel.end()) ++it->second.voxels;
    std::vector<LabelSurface> out;
    out.reserve(byLabel.size());
    for (auto& [l, s] : byLabel) out.push_back(std::move(s));
    return out;
}

}  // namespace

std::vector<LabelSurface> labelSurfaces(const DenseVolume& v, Progress* progress, LabelMethod method) {
    return method == LabelMethod::Shared ? labelSurfacesShared(v, progress) : labelSurfacesMc(v, progress);
}

}  // namespace isoforge::volume
