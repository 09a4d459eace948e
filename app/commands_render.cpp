// isoforge render: scenes, fields, grids and meshes to images, through Embree (on a mesh) or by
// direct ray marching (no mesh).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <sstream>

#include <glm/geometric.hpp>

#include "app/commands.h"
#include "app/field_input.h"
#include "app/volume_input.h"
#include "core/error.h"
#include "core/progress.h"
#include "csg/scene.h"
#include "mesh/io.h"
#include "render/embree_renderer.h"
#include "render/grid_march.h"
#include "render/image.h"
#include "render/ray_march.h"
#include "render/volume_views.h"
#include "volume/marching_cubes.h"
#include "volume/sample.h"
#include "volume/surface_box.h"
#include "volume/vdb_io.h"

namespace isoforge::app {

namespace {

/// "--iso 500:ivory:0.35" -> iso 500, colour ivory, opacity 0.35.
render::IsoLayer parseIsoLayer(const std::string& text) {
    std::vector<std::string> parts;
    std::stringstream ss(text);
    for (std::string p; std::getline(ss, p, ':');) parts.push_back(p);
    if (parts.empty() || parts.size() > 3) throw CLI::ValidationError("--iso", "expected VALUE[:COLOUR[:OPACITY]]");
    render::IsoLayer l;
    try {
        std::size_t used = 0;
        l.iso = std::stof(parts[0], &used);
        if (used != parts[0].size()) throw std::invalid_argument(parts[0]);
        if (parts.size() == 3) l.material.color.a = std::stof(parts[2]);
    } catch (const std::exception&) {
        throw CLI::ValidationError("--iso", "'" + text + "': expected VALUE[:COLOUR[:OPACITY]] with numbers");
    }
    if (parts.size() >= 2) {
        bool ok = false;
        const glm::vec4 c = parts[1] == "skin" ? glm::vec4(0.96f, 0.76f, 0.62f, 1.f) : csg::parseColor(parts[1], ok);
        if (!ok && parts[1] != "skin")
            throw CLI::ValidationError("--iso", "unknown colour '" + parts[1] + "' (a name such as ivory, or #rrggbb)");
        l.material.color = glm::vec4(glm::vec3(c), l.material.color.a);
    }
    if (!(l.material.color.a > 0.f && l.material.color.a <= 1.f))
        throw CLI::ValidationError("--iso", "opacity must be in (0, 1]");
    return l;
}

std::pair<int, int> parseSize(const std::string& s) {
    int w = 0, h = 0;
    char x = 0;
    std::stringstream ss(s);
    if (!(ss >> w >> x >> h) || x != 'x' || !ss.eof() || w <= 0 || h <= 0)
        throw CLI::ValidationError("--size", "'" + s + "': expected WIDTHxHEIGHT, e.g. 1920x1080");
    if (static_cast<double>(w) * h > 2.5e8)
        throw ResourceError("--size " + s + " is " + std::to_string(static_cast<double>(w) * h * 16 / 1e9) +
                            " GB of frame buffer; at most 250 megapixels");
    return {w, h};
}

}  // namespace

void addRenderCommand(CLI::App& app, const GlobalOptions& g, Commands& c) {
    struct Args {
        std::string input, output, method = "auto", size = "1024x768", grid, aov, inside = "auto";
        std::string mip, preset, tf, colors;
        bool volume = false, voxels = false;
        float window = 0.f, level = 0.f;
        VolumeInput vin;
        std::vector<std::string> iso;
        int spp = 1, ao = 0;
        bool cameraAuto = false, noShadows = false, orthographic = false;
        std::vector<float> eye, target, up;
        float fov = 0.f;
        FieldInput field;
    };
    auto a = std::make_shared<Args>();
    auto* cmd = app.add_subcommand("render", "Render a scene, a field, a grid or a mesh to an image");
    cmd->add_option("input", a->input,
                    "Scene (.isf, .csg), implicit model (.vm), volume (.vdb) or mesh (.ply .obj .stl); or --shape / "
                    "--expr");
    cmd->add_option("-o,--output", a->output, "Image: .png, .jpg, .tif (8-bit sRGB) or .exr (float, with AOVs)")
        ->required();
    cmd->add_option("--method", a->method,
                    "mesh: marching cubes, then Embree ray casting; march: rays against the field or grid, no mesh; "
                    "auto: march for grids, mesh otherwise")
        ->check(CLI::IsMember({"auto", "mesh", "march"}));
    cmd->add_option("--size", a->size, "Image size WIDTHxHEIGHT (default 1024x768)");
    cmd->add_option("--spp", a->spp, "Samples per pixel (anti-aliasing; default 1)")->check(CLI::Range(1, 1024));
    cmd->add_option("--iso", a->iso, "Iso-surface of a grid, VALUE[:COLOUR[:OPACITY]]; repeat for several (default 0)");
    cmd->add_option("--inside", a->inside, "For grids: below, above or auto (by grid class)")
        ->check(CLI::IsMember({"auto", "below", "above"}));
    cmd->add_option("--grid", a->grid, "Grid name in a .vdb file");
    cmd->add_option("--aov", a->aov, "Extra channels for .exr: any of depth,normal,id (comma-separated)");
    cmd->add_flag("--camera-auto", a->cameraAuto, "Frame the object automatically, ignoring the scene's camera");
    cmd->add_option("--eye", a->eye, "Camera position x,y,z")->expected(3)->delimiter(',');
    cmd->add_option("--target", a->target, "Point looked at x,y,z")->expected(3)->delimiter(',');
    cmd->add_option("--up", a->up, "Camera up direction x,y,z (e.g. 0,0,-1 for volumes stored head down)")
        ->expected(3)
        ->delimiter(',');
    cmd->add_option("--fov", a->fov, "Vertical field of view, degrees")->check(CLI::Range(1.f, 179.f));
    cmd->add_flag("--orthographic", a->orthographic, "Orthographic projection");
    cmd->add_flag("--no-shadows", a->noShadows, "No shadow rays");
    cmd->add_option("--ao", a->ao, "Ambient-occlusion rays per hit (default 0: off)")->check(CLI::Range(0, 256));
    addFieldOptions(cmd, a->field, true);
    // Images want finer meshes than files: the mesh path samples at 512 unless told otherwise.
    cmd->get_option("--resolution")
        ->description("Voxels along the longest side of the box when meshing (--method mesh; default 512)");
    auto* med = cmd->add_option_group("Medical volumes (NIfTI, NRRD, MetaImage, DICOM, raw)");
    med->add_option("--mip", a->mip, "Maximum intensity projection along axial, coronal or sagittal")
        ->check(CLI::IsMember({"axial", "coronal", "sagittal"}));
    med->add_flag("--volume", a->volume, "Emission-absorption volume rendering with a transfer function");
    med->add_option("--preset", a->preset, "Transfer function for --volume: ct-bone (default), ct-soft, mr")
        ->check(CLI::IsMember({"ct-bone", "ct-soft", "mr"}));
    med->add_option("--tf", a->tf,
                    "Transfer function for --volume as control points 'V:R,G,B,A ...' (colour 0-1, A opacity per mm)");
    med->add_flag("--voxels", a->voxels, "Label voxels drawn as cubes (exact ray-voxel traversal)");
    med->add_option("--colors", a->colors, "Label colours for --voxels (a .lut, ITK-SNAP, Slicer or text table)");
    med->add_option("--window", a->window, "--mip: window width (default: the whole range)");
    med->add_option("--level", a->level, "--mip: window centre");
    addVolumeReadOptions(cmd, a->vin);
    cmd->callback([&c, &g, a] {
        c.run = [&g, a] {
            using Clock = std::chrono::steady_clock;
            const auto t0 = Clock::now();
            const std::string ext = std::filesystem::path(a->output).extension().string();
            static const std::vector<std::string> kImage{".png", ".jpg", ".jpeg", ".tif", ".tiff", ".exr"};
            if (std::find(kImage.begin(), kImage.end(), ext) == kImage.end())
                throw CLI::ValidationError("--output", a->output + ": expected a .png, .jpg, .tif or .exr file name");
            render::RenderOptions opt;
            std::tie(opt.width, opt.height) = parseSize(a->size);
            opt.spp = a->spp;
            opt.shadows = !a->noShadows;
            opt.aoSamples = a->ao;
            for (std::stringstream ss(a->aov); ss.good();) {
                std::string k;
                std::getline(ss, k, ',');
                if (k == "depth")
                    opt.depth = true;
                else if (k == "normal")
                    opt.normal = true;
                else if (k == "id")
                    opt.objectId = true;
                else if (!k.empty())
                    throw CLI::ValidationError("--aov", "unknown channel '" + k + "' (depth, normal, id)");
            }
            if ((opt.depth || opt.normal || opt.objectId) && ext != ".exr")
                throw CLI::ValidationError("--aov", "extra channels need an .exr output");
            TerminalProgress progress;
            Progress* prog = g.quiet ? nullptr : &progress;
            opt.progress = prog;

            render::Look look;
            bool haveCamera = false;
            implicit::Box3 bounds;
            std::vector<mesh::TriMesh> meshes;
            std::vector<implicit::Material> materials;
            implicit::FieldPtr field;
            implicit::Box3 clip;
            openvdb::FloatGrid::Ptr grid;
            std::string what, method = a->method;
            std::vector<render::IsoLayer> layers;
            for (const auto& s : a->iso) layers.push_back(parseIsoLayer(s));

            // Medical volumes: a projection, a volume rendering, voxels, or iso-surfaces (meshed).
            const bool dense = isDenseVolumeFile(a->input);
            if ((!a->mip.empty() || a->volume || a->voxels) && !dense)
                throw CLI::ValidationError("input",
                                           "--mip, --volume and --voxels take a volume file (NIfTI, NRRD, "
                                           "MetaImage, DICOM directory, raw)");
            if (int(!a->mip.empty()) + int(a->volume) + int(a->voxels) > 1)
                throw CLI::ValidationError("--mip", "choose one of --mip, --volume and --voxels");
            volume::DenseVolume vol;
            if (dense) vol = loadVolume(a->input, a->vin, g);
            if (!a->mip.empty()) {
                render::SliceLook sl;
                sl.wl = {a->window, a->level};
                const auto t1 = Clock::now();
                const render::Image img = render::maximumIntensityProjection(vol, render::parseAnatomical(a->mip), sl);
                render::writeImage(a->output, img);
                if (!g.quiet)
                    std::printf("maximum intensity projection (%s) %dx%d in %.3f s -> %s\n", a->mip.c_str(), img.width,
                                img.height, std::chrono::duration<double>(Clock::now() - t1).count(),
                                a->output.c_str());
                return 0;
            }
            if (a->volume || a->voxels) {
                method = a->volume ? "volume" : "voxels";
                bounds = render::volumeBounds(vol);
                what = a->input;
            }

            const bool meshInput = !a->input.empty() && mesh::isReadableMeshPath(a->input) && a->field.shape.empty() &&
                                   a->field.expr.empty();
            if (meshInput) {
                if (method == "march") throw CLI::ValidationError("--method", "a mesh is rendered with --method mesh");
                method = "mesh";
                meshes.push_back(mesh::readMesh(a->input));
                materials.emplace_back();
                what = a->input;
            } else if (namesField(a->input, a->field)) {
                csg::Scene scene;
                field = makeField(a->input, a->field, clip, &scene);
                if (scene.root) {
                    look.camera.eye = scene.camera.eye;
                    look.camera.target = scene.camera.target;
                    look.camera.up = scene.camera.up;
                    look.camera.fov = scene.camera.fov;
                    look.camera.orthographic = scene.camera.orthographic;
                    haveCamera = scene.camera.given;
                    for (const auto& l : scene.lights) look.lights.push_back({l.point, l.vector, l.color, l.intensity});
                    look.backgroundTop = scene.backgroundTop;
                    look.backgroundBottom = scene.backgroundBottom;
                }
                bounds = volume::sampleDomain(*field, clip);
                what = field->describe();
                if (method == "auto") method = "mesh";
                if (method == "mesh") {
                    volume::SampleOptions so;
                    FieldInput fine = a->field;  // images want finer meshes than files: 512 by default
                    if (fine.voxel <= 0 && fine.resolution <= 0) fine.resolution = 512;
                    so.voxelSize = voxelSize(*field, clip, fine);
                    so.clip = clip;
                    so.progress = prog;
                    const auto sampled = volume::sample(field, so);
                    volume::MeshingOptions mo;
                    mo.normals = true;
                    mo.progress = prog;
                    const mesh::TriMesh m = volume::extractIsosurface(*sampled, mo);
                    meshes = render::splitByMaterial(m, *field, materials);
                }
            } else if (method == "volume" || method == "voxels") {
                // rendered from the dense volume below
            } else {
                if (a->input.empty()) throw CLI::ValidationError("input", "give a file, --shape or --expr");
                if (dense) {
                    grid = volumeGrid(vol, a->vin, 0, prog);
                    if (method == "auto") method = "mesh";  // any spacing and orientation; the marcher wants cubes
                } else {
                    grid = volume::readFloatGrid(a->input, a->grid.empty() ? std::nullopt : std::optional(a->grid));
                }
                what = dense ? a->input : "grid '" + grid->getName() + "'";
                if (layers.empty()) layers.push_back({});
                const openvdb::CoordBBox ab = grid->evalActiveVoxelBoundingBox();
                if (!ab.empty()) {
                    const openvdb::BBoxd w = grid->transform().indexToWorld(ab);
                    bounds = {glm::vec3(float(w.min().x()), float(w.min().y()), float(w.min().z())),
                              glm::vec3(float(w.max().x()), float(w.max().y()), float(w.max().z()))};
                }
                if (method == "auto") method = "march";
                if (method == "mesh") {
                    const bool below = volume::insideIsBelow(*grid, insideSideOf(a->inside));
                    for (const auto& l : layers) {
                        volume::MeshingOptions mo;
                        mo.isovalue = l.iso;
                        mo.normals = true;
                        mo.inside = below ? volume::InsideSide::Below : volume::InsideSide::Above;
                        mo.progress = prog;
                        meshes.push_back(volume::extractIsosurface(*grid, mo));
                        materials.push_back(l.material);
                    }
                }
            }
            if (!meshes.empty()) {
                bounds = {};
                for (const auto& m : meshes)
                    for (const auto& p : m.positions) bounds = bounds.unite(implicit::Box3{p, p});
            }
            const float aspect = float(opt.width) / float(opt.height);
            if (!haveCamera || a->cameraAuto) {
                implicit::Box3 frameOf = bounds.isEmpty() ? implicit::Box3{glm::vec3(-1.f), glm::vec3(1.f)} : bounds;
                // The mesh path frames its mesh's vertices; marching frames those of a coarse mesh of
                // the same surface, not the field's often loose bounds.
                if (field && meshes.empty() && !grid) frameOf = volume::framingBox(field, clip);
                // Volumes from scanners: seen from the front (anterior), head up, the patient's left on the right.
                look.camera = dense ? render::frameBox(frameOf, aspect, glm::vec3(0.f, 1.f, 0.f))
                                    : render::frameBox(frameOf, aspect);
            }
            if (!a->eye.empty()) look.camera.eye = glm::vec3(a->eye[0], a->eye[1], a->eye[2]);
            if (!a->target.empty()) look.camera.target = glm::vec3(a->target[0], a->target[1], a->target[2]);
            if (!a->up.empty()) {
                look.camera.up = glm::vec3(a->up[0], a->up[1], a->up[2]);
                if (glm::length(look.camera.up) <= 0.f) throw CLI::ValidationError("--up", "a zero up direction");
            }
            if (a->fov > 0) look.camera.fov = a->fov;
            if (a->orthographic) look.camera.orthographic = true;
            if (glm::length(look.camera.target - look.camera.eye) <= 0.f) {
                // The scene file's camera (exit 1), or the command line's --eye/--target (2).
                if (a->eye.empty() && a->target.empty())
                    throw ParseError(a->input + ": the scene's camera has its eye at its target");
                throw CLI::ValidationError("--eye", "the camera's eye and target are the same point");
            }

            render::RenderStats st;
            render::Frame frame;
            if (method == "volume") {
                render::TransferFunction tf;
                const auto [lo, hi] = vol.range();
                if (!a->tf.empty()) {
                    try {
                        tf = render::parseTransferFunction(a->tf);
                    } catch (const std::invalid_argument& e) {
                        throw CLI::ValidationError("--tf", e.what());
                    }
                } else {
                    tf = render::transferPreset(
                        a->preset.empty() ? (vol.modality == "MR" ? "mr" : "ct-bone") : a->preset, lo, hi);
                }
                frame = render::renderVolume(vol, tf, look, opt, &st);
            } else if (method == "voxels") {
                volume::LabelTable table;
                if (!a->colors.empty()) table = volume::readLabelTable(a->colors);
                frame = render::renderVoxels(vol, table, look, opt, &st);
            } else if (method == "mesh") {
                std::vector<render::MeshObject> objs;
                for (std::size_t i = 0; i < meshes.size(); ++i) objs.push_back({&meshes[i], materials[i], true});
                frame = render::renderMeshes(objs, look, opt, &st);
            } else if (grid) {
                const bool below = volume::insideIsBelow(*grid, insideSideOf(a->inside));
                frame = render::marchGrid(*grid, layers, below, look, opt, &st);
            } else {
                frame = render::marchField(field, bounds, look, opt, &st);
            }
            for (const auto& w : st.warnings) std::fprintf(stderr, "isoforge: warning: %s\n", w.c_str());
            render::writeImage(a->output, ext == ".exr" ? render::toImage(frame) : render::toDisplayImage(frame));
            if (!g.quiet) {
                std::size_t tris = 0;
                for (const auto& m : meshes) tris += m.triangleCount();
                // The frame's own time and ray rate; building the BVH (or a grid's tables) apart, since
                // it depends on the geometry, not on the image.
                const double frameSeconds = std::max(st.seconds - st.setupSeconds, 1e-9);
                char setup[64] = "";
                if (st.setupSeconds > 0)
                    std::snprintf(setup, sizeof setup, "%s %.2f s, ", method == "mesh" ? "BVH" : "preparation",
                                  st.setupSeconds);
                std::printf(
                    "rendered %s (%s%s) at %dx%d, %d spp: %s of %s pixels hit; %sframe %.2f s (%.2f Mrays/s); "
                    "%.2f s total -> %s\n",
                    what.c_str(),
                    method == "mesh"     ? "Embree, "
                    : method == "volume" ? "volume rendering"
                    : method == "voxels" ? "voxels"
                                         : "ray marching",
                    method == "mesh" ? (withCommas(tris) + " triangles").c_str() : "", opt.width, opt.height, opt.spp,
                    withCommas(st.hitPixels).c_str(), withCommas(frame.pixels()).c_str(), setup, frameSeconds,
                    double(st.primaryRays) / frameSeconds / 1e6,
                    std::chrono::duration<double>(Clock::now() - t0).count(), a->output.c_str());
            }
            return 0;
        };
    });
}

}  // namespace isoforge::app
