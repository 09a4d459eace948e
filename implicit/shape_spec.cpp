#include "implicit/shape_spec.h"

#include <cctype>
#include <charconv>
#include <map>
#include <stdexcept>
#include <vector>

#include "core/error.h"
#include "implicit/primitives.h"
#include "implicit/quadric.h"

namespace isoforge::implicit {

namespace {

struct ShapeDef {
    std::vector<std::pair<std::string, float>> params;  // order and defaults
};

const std::map<std::string, ShapeDef>& shapes() {
    static const std::map<std::string, ShapeDef> s = {
        {"sphere", {{{"r", 1.f}}}},
        {"box", {{{"x", 1.f}, {"y", 1.f}, {"z", 1.f}, {"r", 0.f}}}},
        {"cylinder", {{{"r", 0.5f}, {"h", 1.f}}}},
        {"cone", {{{"r1", 0.5f}, {"r2", 0.f}, {"h", 1.f}}}},
        {"torus", {{{"R", 1.f}, {"r", 0.25f}}}},
        {"capsule", {{{"r", 0.25f}, {"h", 1.f}}}},
        {"tetrahedron", {{{"size", 1.f}}}},
        {"ellipsoid", {{{"a", 1.f}, {"b", 0.6f}, {"c", 0.4f}}}},
        {"plane", {{{"nx", 0.f}, {"ny", 0.f}, {"nz", 1.f}, {"d", 0.f}}}},
        {"quadric",
         {{{"a", 1.f},
           {"b", 1.f},
           {"c", 1.f},
           {"A", 0.f},
           {"B", 0.f},
           {"C", 0.f},
           {"D", 0.f},
           {"E", 0.f},
           {"F", 0.f},
           {"G", 0.f},
           {"H", 0.f},
           {"I", 0.f},
           {"J", 0.f}}}},
    };
    return s;
}

}  // namespace

std::string shapeHelp() {
    std::string h;
    for (const auto& [name, def] : shapes()) {
        h += "  " + name + "(";
        for (std::size_t i = 0; i < def.params.size() && (name != "quadric" || i < 3); ++i) {
            char buf[32];
            std::snprintf(buf, sizeof buf, "%g", def.params[i].second);
            h += (i ? ", " : "") + def.params[i].first + "=" + buf;
        }
        if (name == "quadric") h += ", type=NAME | A..J=coefficients";
        h += ")\n";
    }
    return h;
}

FieldPtr parseShape(std::string_view text) {
    std::size_t pos = 0;
    auto fail = [&](std::size_t at, const std::string& what) -> void {
        throw ParseError("shape:1:" + std::to_string(at + 1) + ": " + what + "\n  " + std::string(text) + "\n  " +
                         std::string(at, ' ') + "^");
    };
    auto skip = [&] {
        while (pos < text.size() && std::isspace(static_cast<unsigned char>(text[pos]))) ++pos;
    };
    auto ident = [&] {
        skip();
        const std::size_t b = pos;
        while (pos < text.size() && (std::isalnum(static_cast<unsigned char>(text[pos])) || text[pos] == '_')) ++pos;
        return std::string(text.substr(b, pos - b));
    };
    const std::size_t nameAt = (skip(), pos);
    const std::string name = ident();
    auto def = shapes().find(name);
    if (def == shapes().end()) {
        std::string known;
        for (const auto& [n, d] : shapes()) known += (known.empty() ? "" : ", ") + n;
        fail(nameAt, "unknown shape '" + name + "' (expected one of: " + known + ")");
    }
    std::map<std::string, float> values;
    for (const auto& [k, v] : def->second.params) values[k] = v;
    std::string quadricType;
    skip();
    if (pos < text.size() && text[pos] == '(') {
        ++pos;
        std::size_t positional = 0;
        skip();
        if (pos < text.size() && text[pos] == ')')
            ++pos;
        else
            for (;;) {
                skip();
                const std::size_t argAt = pos;
                std::string key;
                const std::size_t save = pos;
                std::string word = ident();
                skip();
                if (!word.empty() && pos < text.size() && text[pos] == '=') {
                    key = word;
                    ++pos;
                    skip();
                } else {
                    pos = save;
                }
                if (key == "type") {
                    const std::size_t at = pos;
                    quadricType = ident();
                    if (quadricType.empty()) fail(at, "expected a quadric type name");
                } else {
                    if (key.empty()) {
                        if (positional >= def->second.params.size())
                            fail(argAt,
                                 name + " takes at most " + std::to_string(def->second.params.size()) + " values");
                        key = def->second.params[positional++].first;
                    } else if (!values.count(key)) {
                        std::string known;
                        for (const auto& [k, v] : def->second.params) known += (known.empty() ? "" : ", ") + k;
                        fail(argAt, name + " has no parameter '" + key + "' (expected " + known + ")");
                    }
                    skip();
                    float v = 0;
                    const char* b = text.data() + pos;
                    if (pos < text.size() && text[pos] == '+') ++b;
                    auto [p, ec] = std::from_chars(b, text.data() + text.size(), v);
                    if (ec != std::errc()) fail(pos, "expected a number for '" + key + "'");
                    pos = static_cast<std::size_t>(p - text.data());
                    values[key] = v;
                }
                skip();
                if (pos < text.size() && text[pos] == ',') {
                    ++pos;
                    continue;
                }
                if (pos < text.size() && text[pos] == ')') {
                    ++pos;
                    break;
                }
                fail(pos, "expected ',' or ')'");
            }
    }
    skip();
    if (pos < text.size()) fail(pos, "unexpected text after the shape");
    try {
        auto v = [&](const char* k) { return values.at(k); };
        if (name == "sphere") return makeSphere(v("r"));
        if (name == "box") return makeBox({v("x"), v("y"), v("z")}, v("r"));
        if (name == "cylinder") return makeCylinder(v("r"), v("h"));
        if (name == "cone") return makeCone(v("r1"), v("r2"), v("h"));
        if (name == "torus") return makeTorus(v("R"), v("r"));
        if (name == "capsule") return makeCapsule(v("r"), v("h"));
        if (name == "tetrahedron") return makeTetrahedron(v("size"));
        if (name == "ellipsoid") return makeEllipsoid({v("a"), v("b"), v("c")});
        if (name == "plane") return makePlane({v("nx"), v("ny"), v("nz")}, v("d"));
        if (!quadricType.empty()) return makeNamedQuadric(quadricType, v("a"), v("b"), v("c"));
        return makeQuadric({v("A"), v("B"), v("C"), v("D"), v("E"), v("F"), v("G"), v("H"), v("I"), v("J")});
    } catch (const std::invalid_argument& e) {
        fail(nameAt, e.what());
    }
    return nullptr;
}

}  // namespace isoforge::implicit
