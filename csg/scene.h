#pragma once
/// @file Scenes: a CSG tree with camera, lights and background, read from our scene language — a
/// superset of the CSG subset of OpenSCAD, so that `openscad -o model.csg model.scad` exports read
/// as they are. The language is documented in docs/scene-language.md.

#include <string>
#include <string_view>
#include <vector>

#include "implicit/field.h"

namespace isoforge::csg {

/// A place in a scene file, carried into what the parser builds.
struct FileLoc {
    std::string file;
    int line = 0, column = 0;
    /// file:line:column, or file:line without a column, or the file alone without a line.
    std::string toString() const {
        if (line <= 0) return file;
        return file + ":" + std::to_string(line) + (column > 0 ? ":" + std::to_string(column) : std::string());
    }
};

struct Warning {
    FileLoc loc;
    std::string message;
};

struct Camera {
    bool given = false;
    glm::vec3 eye{0.f, -5.f, 3.f}, target{0.f}, up{0.f, 0.f, 1.f};
    float fov = 40.f;  ///< vertical, degrees
    bool orthographic = false;
};

struct Light {
    bool point = false;  ///< point light at `vector`, else directional towards `vector`
    glm::vec3 vector{-1.f, -1.f, -2.f};
    glm::vec3 color{1.f};
    float intensity = 1.f;
};

struct Scene {
    implicit::FieldPtr root;  ///< negative inside; never null (an empty scene is an empty field)
    Camera camera;
    std::vector<Light> lights;
    glm::vec3 backgroundTop{0.85f, 0.9f, 1.f}, backgroundBottom{0.55f, 0.6f, 0.7f};
    std::vector<Warning> warnings;
    std::size_t primitives = 0;  ///< leaf shapes in the tree
    std::string tree;            ///< an indented outline of the tree, for check-scene
    /// Every file the scene was made from: the scene file, what its statements read (vm(), volume(),
    /// mesh(), import(), bezier_patches(), ...) and, for a .scad model, what OpenSCAD read (include<>,
    /// use<>). Each once, in the order first read. What `isoforge view` watches.
    std::vector<std::string> files;
};

/// A colour by SVG/CSS name ("steelblue") or "#rrggbb", as RGBA in [0, 1] (sRGB); ok = false if unknown.
glm::vec4 parseColor(std::string name, bool& ok);

/// Parses and evaluates a scene. Several errors are reported at once where possible.
/// @throw ParseError with one "file:line:column: message" line per error, each followed by the
///        source line and a caret under the spot.
Scene parseScene(std::string_view text, const std::string& fileName);
/// Reads a file (.isf, .csg, or .scad through OpenSCAD) and parses it; relative paths inside
/// (vm("..."), volume("..."), mesh("...")) are relative to the file's directory.
Scene readScene(const std::string& path);
/// The same; a .scad file is first exported by OpenSCAD (csg/openscad.h) with `defines` (NAME=VALUE,
/// OpenSCAD's -D), and OpenSCAD's messages come first among the warnings.
Scene readScene(const std::string& path, const std::vector<std::string>& defines);

}  // namespace isoforge::csg
