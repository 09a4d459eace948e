#include "csg/scene.h"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/error.h"
#include "csg/evaluator.h"
#include "csg/lexer.h"
#include "csg/nodes.h"
#include "csg/openscad.h"
#include "csg/parser.h"

namespace isoforge::csg {

namespace {

std::vector<std::string_view> splitLines(std::string_view t) {
    std::vector<std::string_view> out;
    std::size_t b = 0;
    for (std::size_t i = 0; i <= t.size(); ++i)
        if (i == t.size() || t[i] == '\n') {
            std::string_view l = t.substr(b, i - b);
            if (!l.empty() && l.back() == '\r') l.remove_suffix(1);
            out.push_back(l);
            b = i + 1;
        }
    return out;
}

Scene parse(std::string_view text, const std::string& file, const std::filesystem::path& dir) {
    Diagnostics d;
    d.file = file;
    d.lines = splitLines(text);
    std::vector<Token> toks = tokenize(text, d);
    std::vector<Statement> program = parseProgram(std::move(toks), d);
    Scene scene;
    Evaluator ev(d, scene, dir);
    Scope global;
    global.vars["$fn"] = Value::num(0);
    std::vector<FieldPtr> top;
    if (d.errors.empty()) top = ev.runScene(program, global);
    if (!d.errors.empty()) {
        std::string all;
        for (const auto& e : d.errors) all += (all.empty() ? "" : "\n") + e;
        if (d.errors.size() > 1) all += "\n" + std::to_string(d.errors.size()) + " errors";
        throw ParseError(all);
    }
    FieldPtr root = ev.rootOverride();
    if (!root) root = top.empty() ? makeEmpty() : makeUnion(std::move(top));
    if (!root->bounds().isBounded() && !top.empty())
        d.warn(1, 1,
               "the scene is unbounded (a plane, a quadric, an expression or a 2D shape not extruded): give a box to "
               "sample it");
    scene.root = root;
    scene.warnings = std::move(d.warnings);
    scene.tree = ev.outline;
    return scene;
}

}  // namespace

Scene parseScene(std::string_view text, const std::string& fileName) {
    return parse(text, fileName, ".");
}

Scene readScene(const std::string& path) {
    return readScene(path, {});
}

Scene readScene(const std::string& path, const std::vector<std::string>& defines) {
    std::error_code ec;
    if (std::filesystem::is_directory(path, ec)) throw IoError(path + ": is a directory, expected a scene file");
    std::string ext = std::filesystem::path(path).extension().string();
    for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (ext == ".scad") {
        // Errors in the export name the model and the export's line, which the message shows.
        ScadExport e = exportScad(path, defines);
        Scene s = parse(e.csg, path + " (as CSG)", std::filesystem::path(path).parent_path());
        e.messages.insert(e.messages.end(), s.warnings.begin(), s.warnings.end());
        s.warnings = std::move(e.messages);
        for (std::string& f : s.files) e.dependencies.push_back(std::move(f));
        s.files.clear();
        for (std::string& f : e.dependencies)
            if (std::find(s.files.begin(), s.files.end(), f) == s.files.end()) s.files.push_back(std::move(f));
        return s;
    }
    std::ifstream in(path, std::ios::binary);
    if (!in) throw IoError(path + ": cannot open");
    std::stringstream s;
    s << in.rdbuf();
    const std::string text = s.str();
    if (text.find('\0') != std::string::npos) throw IoError(path + ": not a text file (it contains NUL bytes)");
    Scene scene = parse(text, path, std::filesystem::path(path).parent_path());
    scene.files.insert(scene.files.begin(), path);
    return scene;
}

}  // namespace isoforge::csg
