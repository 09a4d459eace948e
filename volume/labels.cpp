#include "volume/labels.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

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

std::vector<LabelSurface> labelSurfaces(const DenseVolume& v, Progress* progress) {
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

}  // namespace isoforge::volume
