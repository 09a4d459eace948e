#include "volume/mc_table.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

namespace isoforge::volume::mc {

namespace {

struct V3 {
    double x, y, z;
};
V3 sub(V3 a, V3 b) {
    return {a.x - b.x, a.y - b.y, a.z - b.z};
}
V3 cross(V3 a, V3 b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
double dot(V3 a, V3 b) {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

V3 cornerPos(int c) {
    return {double(c & 1), double((c >> 1) & 1), double((c >> 2) & 1)};
}
int edgeCorner(int e, int end) {
    EdgeInfo i = edgeInfo(e);
    int c = i.dx | (i.dy << 1) | (i.dz << 2);
    return end ? c | (1 << i.axis) : c;
}
V3 edgeMid(int e) {
    V3 a = cornerPos(edgeCorner(e, 0)), b = cornerPos(edgeCorner(e, 1));
    return {(a.x + b.x) / 2, (a.y + b.y) / 2, (a.z + b.z) / 2};
}
double coord(V3 p, int a) {
    return a == 0 ? p.x : (a == 1 ? p.y : p.z);
}

// Edges lying in face f (axis f/2, side f%2).
std::vector<int> faceEdges(int f) {
    std::vector<int> out;
    for (int e = 0; e < 12; ++e) {
        EdgeInfo i = edgeInfo(e);
        int c = edgeCorner(e, 0);
        if (i.axis != f / 2 && coord(cornerPos(c), f / 2) == f % 2) out.push_back(e);
    }
    return out;
}
bool edgesShareFace(int e1, int e2) {
    for (int f = 0; f < 6; ++f) {
        auto fe = faceEdges(f);
        if (std::count(fe.begin(), fe.end(), e1) && std::count(fe.begin(), fe.end(), e2)) return true;
    }
    return false;
}

// Best triangulation of polygon[i..j] (indices into the cycle), maximizing the minimum quality.
struct Tri {
    int a, b, c;
};
double quality(V3 a, V3 b, V3 c) {
    V3 n = cross(sub(b, a), sub(c, a));
    double l = dot(sub(b, a), sub(b, a)) + dot(sub(c, b), sub(c, b)) + dot(sub(a, c), sub(a, c));
    return std::sqrt(dot(n, n)) / l;
}

CaseTable build() {
    CaseTable t;
    for (int code = 0; code < 256; ++code) {
        auto inside = [&](int c) { return ((code >> c) & 1) != 0; };
        auto cut = [&](int e) { return inside(edgeCorner(e, 0)) != inside(edgeCorner(e, 1)); };
        int next[12];
        std::fill(next, next + 12, -1);
        int incoming[12] = {};
        for (int f = 0; f < 6; ++f) {
            std::vector<int> fe;
            for (int e : faceEdges(f))
                if (cut(e)) fe.push_back(e);
            std::vector<std::pair<int, int>> segs;  // (edge, edge, inside corner)
            std::vector<int> insideCorner;
            if (fe.size() == 2) {
                int ic = -1;
                for (int e : faceEdges(f))
                    for (int k = 0; k < 2; ++k)
                        if (inside(edgeCorner(e, k))) ic = edgeCorner(e, k);
                segs.push_back({fe[0], fe[1]});
                insideCorner.push_back(ic);
            } else if (fe.size() == 4) {
                // Separate the inside corners: pair the two edges around each inside corner.
                for (int c = 0; c < 8; ++c) {
                    if (!inside(c) || coord(cornerPos(c), f / 2) != f % 2) continue;
                    std::vector<int> around;
                    for (int e : fe)
                        if (edgeCorner(e, 0) == c || edgeCorner(e, 1) == c) around.push_back(e);
                    if (around.size() != 2) throw std::logic_error("mc table: bad ambiguous face");
                    segs.push_back({around[0], around[1]});
                    insideCorner.push_back(c);
                }
            } else if (!fe.empty()) {
                throw std::logic_error("mc table: odd number of cut edges on a face");
            }
            V3 n{0, 0, 0};
            (f / 2 == 0 ? n.x : (f / 2 == 1 ? n.y : n.z)) = (f % 2) ? 1.0 : -1.0;
            for (std::size_t s = 0; s < segs.size(); ++s) {
                auto [p, q] = segs[s];
                V3 P = edgeMid(p), Q = edgeMid(q), I = cornerPos(insideCorner[s]);
                if (dot(n, cross(sub(Q, P), sub(I, P))) > 0) std::swap(p, q);  // inside on the right, seen from outside
                if (next[p] != -1) throw std::logic_error("mc table: two segments leave one edge");
                next[p] = q;
                ++incoming[q];
            }
        }
        int nt = 0;
        bool visited[12] = {};
        for (int start = 0; start < 12; ++start) {
            if (!cut(start) || visited[start]) continue;
            std::vector<int> cycle;
            for (int e = start; !visited[e]; e = next[e]) {
                if (next[e] < 0 || incoming[e] != 1) throw std::logic_error("mc table: open cycle");
                visited[e] = true;
                cycle.push_back(e);
            }
            const int n = static_cast<int>(cycle.size());
            auto allowed = [&](int i, int j) {                          // chord between cycle positions i < j
                if (j - i == 1 || (i == 0 && j == n - 1)) return true;  // a side
                return !edgesShareFace(cycle[i], cycle[j]);
            };
            // Dynamic programming over sub-polygons [i, j].
            std::vector<std::vector<double>> best(n, std::vector<double>(n, -1));
            std::vector<std::vector<int>> split(n, std::vector<int>(n, -1));
            for (int len = 2; len < n; ++len)
                for (int i = 0; i + len < n; ++i) {
                    int j = i + len;
                    if (!allowed(i, j)) continue;
                    for (int k = i + 1; k < j; ++k) {
                        if (!allowed(i, k) || !allowed(k, j)) continue;
                        double qa = k - i > 1 ? best[i][k] : 1e9, qb = j - k > 1 ? best[k][j] : 1e9;
                        if (qa < 0 || qb < 0) continue;
                        double q = std::min({qa, qb, quality(edgeMid(cycle[i]), edgeMid(cycle[k]), edgeMid(cycle[j]))});
                        if (q > best[i][j] + 1e-12) {
                            best[i][j] = q;
                            split[i][j] = k;
                        }
                    }
                }
            if (best[0][n - 1] < 0)
                throw std::logic_error("mc table: no valid triangulation for case " + std::to_string(code));
            std::vector<std::pair<int, int>> stack{{0, n - 1}};
            while (!stack.empty()) {
                auto [i, j] = stack.back();
                stack.pop_back();
                if (j - i < 2) continue;
                int k = split[i][j];
                if (nt >= kMaxTriangles) throw std::logic_error("mc table: too many triangles");
                t.edges[code][3 * nt + 0] = static_cast<std::uint8_t>(cycle[i]);
                t.edges[code][3 * nt + 1] = static_cast<std::uint8_t>(cycle[k]);
                t.edges[code][3 * nt + 2] = static_cast<std::uint8_t>(cycle[j]);
                ++nt;
                stack.push_back({i, k});
                stack.push_back({k, j});
            }
        }
        t.triangleCount[code] = static_cast<std::uint8_t>(nt);
    }
    return t;
}

}  // namespace

const CaseTable& caseTable() {
    static const CaseTable table = build();
    return table;
}

}  // namespace isoforge::volume::mc
