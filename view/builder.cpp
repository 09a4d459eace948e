#include "view/builder.h"

#include <chrono>
#include <filesystem>

#include "core/error.h"
#include "csg/scene.h"
#include "mesh/check.h"
#include "mesh/io.h"
#include "view/json.h"
#include "volume/sample.h"
#include "volume/surface.h"
#include "volume/vdb_io.h"

namespace isoforge::view {

namespace {

using Clock = std::chrono::steady_clock;

double since(Clock::time_point t) {
    return std::chrono::duration<double>(Clock::now() - t).count();
}

std::string vec3Json(const glm::vec3& v) {
    return "[" + jsonNumber(v.x) + "," + jsonNumber(v.y) + "," + jsonNumber(v.z) + "]";
}

/// What every stage's summary says about the input (camera, background, warnings).
struct Context {
    std::string what;  ///< the input, as the summary names it
    const csg::Scene* scene = nullptr;
    double readSeconds = 0;
};

std::string infoJson(const Context& c, const std::string& stage, const mesh::TriMesh& m, double voxel,
                     double sampleSeconds, double meshSeconds, double encodeSeconds, std::size_t glbBytes) {
    JsonObject o;
    o.str("input", c.what).str("stage", stage);
    if (voxel > 0) o.num("voxel", voxel);
    o.num("vertices", double(m.vertexCount())).num("triangles", double(m.triangleCount()));
    // The check of the full model (the coarse one is replaced within the second).
    if (stage == "full") {
        const mesh::MeshReport r = mesh::check(m);
        o.raw("check", JsonObject()
                           .flag("closed", r.isWatertight())
                           .flag("manifold", r.isEdgeManifold() && r.isVertexManifold())
                           .flag("oriented", r.isOriented())
                           .num("components", double(r.components))
                           .num("euler", double(r.eulerCharacteristic))
                           .num("area", r.area)
                           .num("volume", r.volume)
                           .text());
    }
    o.raw("seconds", JsonObject()
                         .num("read", c.readSeconds)
                         .num("sample", sampleSeconds)
                         .num("mesh", meshSeconds)
                         .num("encode", encodeSeconds)
                         .text());
    o.num("glb_bytes", double(glbBytes));
    if (!m.empty()) {
        glm::vec3 lo(m.positions[0]), hi(m.positions[0]);
        for (const glm::vec3& p : m.positions) {
            lo = glm::min(lo, p);
            hi = glm::max(hi, p);
        }
        o.raw("bounds", "[" + vec3Json(lo) + "," + vec3Json(hi) + "]");
    }
    std::string warnings = "[";
    if (c.scene) {
        const csg::Camera& cam = c.scene->camera;
        if (cam.given)
            o.raw("camera", JsonObject()
                                .raw("eye", vec3Json(cam.eye))
                                .raw("target", vec3Json(cam.target))
                                .raw("up", vec3Json(cam.up))
                                .num("fov", cam.fov)
                                .flag("orthographic", cam.orthographic)
                                .text());
        o.raw("background", "[" + vec3Json(c.scene->backgroundTop) + "," + vec3Json(c.scene->backgroundBottom) + "]");
        for (const csg::Warning& w : c.scene->warnings)
            warnings += (warnings.size() > 1 ? "," : "") +
                        JsonObject().str("where", w.loc.toString()).str("message", w.message).text();
    }
    o.raw("warnings", warnings + "]");
    return o.text();
}

ModelUpdate finish(const Context& c, const std::string& stage, const mesh::TriMesh& m, double voxel,
                   double sampleSeconds, double meshSeconds) {
    const auto t = Clock::now();
    ModelUpdate u;
    u.stage = stage;
    u.glb = mesh::glbBytes(m);
    u.info = infoJson(c, stage, m, voxel, sampleSeconds, meshSeconds, since(t), u.glb.size());
    return u;
}

}  // namespace

void buildModel(const ModelRequest& rq, Progress& progress, std::vector<std::string>& files,
                const std::function<void(ModelUpdate)>& publish) {
    const auto t0 = Clock::now();
    Context c;
    c.what = rq.input.empty() ? (rq.field.shape.empty() ? rq.field.expr : rq.field.shape) : rq.input;
    if (!rq.input.empty()) files = {rq.input};
    volume::SurfaceOptions opt;
    opt.isovalue = rq.iso;
    opt.inside = app::insideSideOf(rq.inside);
    opt.progress = &progress;

    if (!rq.input.empty() && mesh::isReadableMeshPath(rq.input)) {
        progress.begin("reading");
        const mesh::TriMesh m = mesh::readMesh(rq.input);
        c.readSeconds = since(t0);
        publish(finish(c, "full", m, 0, 0, 0));
        return;
    }
    if (!app::namesField(rq.input, rq.field)) {
        progress.begin("reading");
        openvdb::FloatGrid::Ptr grid;
        if (app::isDenseVolumeFile(rq.input)) {
            app::GlobalOptions quiet;
            quiet.quiet = true;
            const volume::DenseVolume v = app::loadVolume(rq.input, rq.volume, quiet);
            grid = app::volumeGrid(v, rq.volume, 0, &progress);
        } else {
            const std::string ext = std::filesystem::path(rq.input).extension().string();
            if (ext != ".vdb")
                throw IoError(rq.input +
                              ": expected a scene (.isf .csg .scad), a .vm model, a volume or a mesh (.ply .obj .stl "
                              ".off)");
            grid = volume::readFloatGrid(rq.input, std::nullopt);
        }
        c.readSeconds = since(t0);
        opt.normals = true;
        const auto t1 = Clock::now();
        const mesh::TriMesh m = volume::meshSurface(*grid, nullptr, opt);
        publish(finish(c, "full", m, grid->voxelSize()[0], 0, since(t1)));
        return;
    }

    implicit::Box3 clip;
    csg::Scene scene;
    const implicit::FieldPtr field = app::makeField(rq.input, rq.field, clip, &scene, false);
    if (app::isSceneFile(rq.input)) {
        c.scene = &scene;
        files = scene.files;
    }
    c.readSeconds = since(t0);
    const bool sharp = rq.sharp || (!rq.noSharp && app::isOpenScadModel(rq.input));
    const float fullVoxel = app::voxelSize(*field, clip, rq.field);
    app::FieldInput coarseInput = rq.field;
    coarseInput.voxel = 0;
    coarseInput.resolution = rq.coarseResolution;
    const float coarseVoxel = rq.coarseResolution > 0 ? app::voxelSize(*field, clip, coarseInput) : 0.f;
    struct Stage {
        const char* name;
        float voxel;
        bool sharp;
    };
    std::vector<Stage> stages;
    // A first look only where it is much cheaper than the model: plain marching cubes, 2x coarser at least.
    if (coarseVoxel >= 2 * fullVoxel) stages.push_back({"coarse", coarseVoxel, false});
    stages.push_back({"full", fullVoxel, sharp});
    for (const Stage& s : stages) {
        const auto t1 = Clock::now();
        volume::SampleOptions so;
        so.voxelSize = s.voxel;
        so.halfWidth = rq.field.halfWidth;
        so.clip = clip;
        so.progress = &progress;
        const openvdb::FloatGrid::Ptr grid = volume::sample(field, so);
        const double sampleSeconds = since(t1);
        const auto t2 = Clock::now();
        opt.sharp = s.sharp;
        opt.normals = true;
        const mesh::TriMesh m = volume::meshSurface(*grid, field, opt);
        publish(finish(c, s.name, m, s.voxel, sampleSeconds, since(t2)));
    }
}

}  // namespace isoforge::view
