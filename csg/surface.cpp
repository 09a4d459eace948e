#include "csg/surface.h"

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "core/error.h"

namespace isoforge::csg {

namespace {
/// Cells past which a height map is refused (100 million triangles).
constexpr double kMaxCells = 25e6;
}  // namespace

HeightMap readHeightMap(const std::string& path, std::vector<std::string>& warnings) {
    std::ifstream in(path);
    if (!in) throw IoError(path + ": cannot open");
    HeightMap map;
    std::string line;
    int number = 0;
    while (std::getline(in, line)) {
        ++number;
        const auto first = line.find_first_not_of(" \t\r");
        if (first == std::string::npos || line[first] == '#') continue;
        std::vector<double> row;
        std::size_t pos = first;
        bool bad = false;
        while (pos < line.size()) {
            const auto end = line.find_first_of(" \t\r", pos);
            const std::string token = line.substr(pos, end == std::string::npos ? std::string::npos : end - pos);
            char* stop = nullptr;
            errno = 0;
            const double v = std::strtod(token.c_str(), &stop);
            if (token.empty() || *stop != '\0' || errno == ERANGE) {
                warnings.push_back(path + ":" + std::to_string(number) + ": '" + token +
                                   "' is not a number: the height map ends there, as in OpenSCAD");
                bad = true;
                break;
            }
            row.push_back(v);
            pos = end == std::string::npos ? line.size() : line.find_first_not_of(" \t\r", end);
            if (pos == std::string::npos) pos = line.size();
        }
        map.columns = std::max(map.columns, row.size());
        // OpenSCAD keeps the values read before a bad one, on a row it does not count.
        if (!row.empty()) map.rows.push_back(std::move(row));
        if (double(map.rows.size()) * double(map.columns) > kMaxCells)
            throw ResourceError(path + ": the height map has more than 25 million cells (" +
                                std::to_string(map.rows.size()) + " rows of up to " + std::to_string(map.columns) +
                                " values)");
        if (bad) break;
    }
    if (in.bad()) throw IoError(path + ": read error");
    return map;
}

mesh::TriMesh surfaceMesh(const HeightMap& map, bool center) {
    mesh::TriMesh m;
    const std::size_t lines = map.rows.size(), columns = map.columns;
    if (lines < 2 || columns < 2) return m;
    auto at = [&](std::size_t i, std::size_t j) { return j < map.rows[i].size() ? map.rows[i][j] : 0.0; };
    // OpenSCAD takes the floor from the values given; a missing one is 0 only where it is used.
    double lowest = 0;
    for (const auto& row : map.rows)
        for (double v : row) lowest = std::min(lowest, v - 1);
    const double ox = center ? -(double(columns) - 1) / 2 : 0, oy = center ? -(double(lines) - 1) / 2 : 0;
    // Top: the grid points, then the cell centres.
    auto top = [&](std::size_t i, std::size_t j) { return unsigned(i * columns + j); };
    for (std::size_t i = 0; i < lines; ++i)
        for (std::size_t j = 0; j < columns; ++j) m.positions.emplace_back(ox + double(j), oy + double(i), at(i, j));
    for (std::size_t i = 1; i < lines; ++i)
        for (std::size_t j = 1; j < columns; ++j) {
            const double mean = (at(i - 1, j - 1) + at(i - 1, j) + at(i, j - 1) + at(i, j)) / 4;
            const auto c = unsigned(m.positions.size());
            m.positions.emplace_back(ox + double(j) - 0.5, oy + double(i) - 0.5, mean);
            const unsigned v1 = top(i - 1, j - 1), v2 = top(i - 1, j), v3 = top(i, j - 1), v4 = top(i, j);
            m.triangles.insert(m.triangles.end(), {{v1, v2, c}, {v2, v4, c}, {v4, v3, c}, {v3, v1, c}});
        }
    // The floor: the same lattice at the lowest height, two triangles a cell (no slivers along the
    // rim, as one polygon of collinear points would give), facing down.
    const auto floor0 = unsigned(m.positions.size());
    auto below = [&](unsigned topIndex) { return floor0 + topIndex; };
    for (std::size_t k = 0; k < lines * columns; ++k)
        m.positions.emplace_back(m.positions[k].x, m.positions[k].y, lowest);
    for (std::size_t i = 1; i < lines; ++i)
        for (std::size_t j = 1; j < columns; ++j) {
            const unsigned p00 = below(top(i - 1, j - 1)), p01 = below(top(i - 1, j)), p10 = below(top(i, j - 1)),
                           p11 = below(top(i, j));
            m.triangles.insert(m.triangles.end(), {{p00, p10, p11}, {p00, p11, p01}});
        }
    // Walls down from each rim edge, the rim walked counter-clockwise seen from above: along row 0,
    // up the last column, back along the last row, down column 0.
    std::vector<unsigned> rim;
    for (std::size_t j = 0; j + 1 < columns; ++j) rim.push_back(top(0, j));
    for (std::size_t i = 0; i + 1 < lines; ++i) rim.push_back(top(i, columns - 1));
    for (std::size_t j = columns - 1; j > 0; --j) rim.push_back(top(lines - 1, j));
    for (std::size_t i = lines - 1; i > 0; --i) rim.push_back(top(i, 0));
    for (std::size_t k = 0; k < rim.size(); ++k) {
        const unsigned a = rim[k], b = rim[(k + 1) % rim.size()];
        m.triangles.insert(m.triangles.end(), {{a, below(a), below(b)}, {a, below(b), b}});
    }
    return m;
}

}  // namespace isoforge::csg
