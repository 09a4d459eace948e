#pragma once
/// @file The ways a command names an implicit field: a .vm file, --shape, or --expr, with --box,
/// and the resolution options that turn it into a grid.

#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "csg/scene.h"
#include "implicit/field.h"
#include "volume/marching_cubes.h"

namespace isoforge::app {

struct FieldInput {
    std::string shape, expr;
    std::vector<float> box;  ///< x0,y0,z0,x1,y1,z1
    float voxel = 0.f;
    int resolution = 0;
    float halfWidth = 3.f;
    std::vector<std::string> defines;  ///< --define NAME=VALUE for .scad files (OpenSCAD's -D)
};

/// --define NAME=VALUE (repeatable): OpenSCAD's -D, for .scad inputs.
void addDefineOption(CLI::App* cmd, std::vector<std::string>& defines);

/// --shape, --expr, --box, and (with `sampling`) --voxel, --resolution, --half-width.
void addFieldOptions(CLI::App* cmd, FieldInput& in, bool sampling);

/// True for scene files (.isf, .csg, .scad).
bool isSceneFile(const std::string& file);
/// .csg or .scad: an OpenSCAD model (its solids are polyhedra, with sharp edges).
bool isOpenScadModel(const std::string& file);

/// True if the command's input is a field rather than a volume file.
bool namesField(const std::string& file, const FieldInput& in);

/// The field and the box it is clipped to (everything, --box, or [-1,1]^3 for .vm files).
/// @throw ParseError / IoError / CLI::ValidationError.
/// `printWarnings`: the scene's warnings on stderr (off on all but one rank of a distributed job).
implicit::FieldPtr makeField(const std::string& file, const FieldInput& in, implicit::Box3& clip,
                             csg::Scene* sceneOut = nullptr, bool printWarnings = true);

/// --inside's word (auto, below, above) as the mesher's enum.
volume::InsideSide insideSideOf(const std::string& word);

/// Voxel size from --voxel or --resolution (default 256 along the longest side of the domain).
float voxelSize(const implicit::Field& field, const implicit::Box3& clip, const FieldInput& in);

}  // namespace isoforge::app
