#pragma once
/// @file OpenSCAD models (.scad) read through OpenSCAD itself: `openscad -o TMP.csg model.scad`
/// (Debian package openscad) gives the CSG tree with modules, loops and functions expanded, which
/// the scene parser reads. OpenSCAD's own messages become the scene's warnings, on their lines.

#include <string>
#include <vector>

#include "csg/scene.h"

namespace isoforge::csg {

/// The OpenSCAD program to run: $ISOFORGE_OPENSCAD if set, else `openscad` from PATH.
std::string openscadProgram();

/// A CSG export of a .scad file and what OpenSCAD said while making it.
struct ScadExport {
    std::string csg;                        ///< the exported text
    std::vector<Warning> messages;          ///< OpenSCAD's WARNING/ECHO lines, with file:line where it gives them
    std::vector<std::string> dependencies;  ///< every file OpenSCAD read (the model, include<>, use<>, import())
};

/// The prerequisites of a make rule as OpenSCAD's -d writes them ("out: a.scad b\ c.scad \\\n d.stl").
std::vector<std::string> parseMakeDependencies(const std::string& text);

/// Runs OpenSCAD on `path` with `defines` (NAME=VALUE each, passed as -D NAME=VALUE).
/// @throw IoError when OpenSCAD is missing (the message names the Debian package) or cannot run;
///        ParseError with OpenSCAD's errors (file:line: message) when it fails on the model.
ScadExport exportScad(const std::string& path, const std::vector<std::string>& defines);

}  // namespace isoforge::csg
