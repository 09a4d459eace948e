#pragma once
/// @file What `isoforge view` shows: the model of a scene, .vm model, field, volume or mesh file, made
/// as `isoforge mesh` makes it, in stages (a coarse look first, then the full model), each as the .glb
/// the page loads and a summary in JSON.

#include <exception>
#include <functional>
#include <string>
#include <vector>

#include "app/field_input.h"
#include "app/volume_input.h"
#include "core/progress.h"

namespace isoforge::view {

struct ModelRequest {
    std::string input;        ///< a file; empty with --shape / --expr
    app::FieldInput field;    ///< --shape, --expr, --box, --voxel, --resolution, -D
    app::VolumeInput volume;  ///< raw and DICOM options for volume files
    float iso = 0.f;          ///< volumes: the iso-value
    std::string inside = "auto";
    bool sharp = false, noSharp = false;  ///< as `isoforge mesh` (feature vertices for OpenSCAD models)
    int coarseResolution = 48;            ///< the first look's voxels along the longest side (0: none)
};

/// One stage of a model.
struct ModelUpdate {
    std::string stage;  ///< "coarse" or "full"
    std::string glb;    ///< the mesh (glTF binary)
    std::string info;   ///< JSON: counts, check, timings, camera, background, warnings
};

/// Thrown by a Progress to stop a build that a newer save has made stale.
struct Cancelled : std::exception {
    const char* what() const noexcept override { return "cancelled by a newer change"; }
};

/// Builds `request`'s model: `publish` is called once per stage, from the calling thread. Every long
/// step reports to `progress` (which may throw Cancelled). `files` receives the files the model is
/// made from as soon as they are known (before meshing), to be watched.
/// @throw ParseError / IoError / ResourceError / CLI::ValidationError with the CLI's messages; Cancelled.
void buildModel(const ModelRequest& request, Progress& progress, std::vector<std::string>& files,
                const std::function<void(ModelUpdate)>& publish);

}  // namespace isoforge::view
