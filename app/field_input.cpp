#include "app/field_input.h"

#include <filesystem>

#include "core/error.h"
#include "csg/scene.h"
#include "implicit/shape_spec.h"
#include "implicit/tape.h"
#include "volume/sample.h"

namespace isoforge::app {

void addDefineOption(CLI::App* cmd, std::vector<std::string>& defines) {
    cmd->add_option("-D,--define", defines,
                    "NAME=VALUE for a .scad model, as openscad -D takes it (repeatable), e.g. -D '$fn=96'")
        ->check([](const std::string& d) {
            const auto eq = d.find('=');
            if (eq == 0 || eq == std::string::npos) return std::string("expected NAME=VALUE, got '" + d + "'");
            return std::string();
        })
        ->take_last()
        ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
}

void addFieldOptions(CLI::App* cmd, FieldInput& in, bool sampling) {
    addDefineOption(cmd, in.defines);
    cmd->add_option("--shape", in.shape, "A primitive, e.g. \"torus(R=1, r=0.3)\" (see 'isoforge shapes')");
    cmd->add_option("--expr", in.expr, "An algebraic surface f(x,y,z) = 0, negative inside, e.g. \"x^2+y^2+z^2-1\"");
    cmd->add_option("--box", in.box, "Clip box x0,y0,z0,x1,y1,z1 (needed for unbounded fields; .vm default [-1,1]^3)")
        ->delimiter(',')
        ->expected(6);
    if (sampling) {
        auto* v = cmd->add_option("--voxel", in.voxel, "Voxel size in world units")->check(CLI::PositiveNumber);
        cmd->add_option("--resolution", in.resolution, "Voxels along the longest side of the box (default 256)")
            ->check(CLI::Range(1, 1 << 30))
            ->excludes(v);
        cmd->add_option("--half-width", in.halfWidth, "Narrow-band half-width in voxels, distance fields (default 3)")
            ->check(CLI::Range(1.f, 1000.f));
    }
}

namespace {
std::string extensionOf(const std::string& file) {
    std::string ext = std::filesystem::path(file).extension().string();
    for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return ext;
}
}  // namespace

bool isSceneFile(const std::string& file) {
    const std::string ext = extensionOf(file);
    return ext == ".isf" || ext == ".csg" || ext == ".scad";
}

bool isOpenScadModel(const std::string& file) {
    const std::string ext = extensionOf(file);
    return ext == ".csg" || ext == ".scad";
}

bool namesField(const std::string& file, const FieldInput& in) {
    if (!in.shape.empty() || !in.expr.empty()) return true;
    return extensionOf(file) == ".vm" || isSceneFile(file);
}

implicit::FieldPtr makeField(const std::string& file, const FieldInput& in, implicit::Box3& clip, csg::Scene* sceneOut,
                             bool printWarnings) {
    const int sources = !file.empty() + !in.shape.empty() + !in.expr.empty();
    if (sources != 1) throw CLI::ValidationError("input", "give exactly one of: a file, --shape, --expr");
    clip = implicit::Box3::everything();
    implicit::FieldPtr f;
    if (!in.shape.empty()) {
        f = implicit::parseShape(in.shape);
    } else if (!in.expr.empty()) {
        f = implicit::makeTapeField(implicit::parseExpression(in.expr), implicit::Box3::everything(), in.expr);
    } else if (isSceneFile(file)) {
        csg::Scene scene = csg::readScene(file, in.defines);
        for (const auto& w : scene.warnings)
            if (printWarnings)
                std::fprintf(stderr, "isoforge: warning: %s: %s\n", w.loc.toString().c_str(), w.message.c_str());
        f = scene.root;
        if (sceneOut) *sceneOut = std::move(scene);
    } else {
        const auto tape = implicit::readVmFile(file);
        f = implicit::makeTapeField(tape, implicit::Box3::everything(),
                                    std::filesystem::path(file).filename().string());
        clip = {glm::vec3(-1.f), glm::vec3(1.f)};
    }
    if (!in.box.empty()) {
        clip = {glm::vec3(in.box[0], in.box[1], in.box[2]), glm::vec3(in.box[3], in.box[4], in.box[5])};
        if (clip.isEmpty()) throw CLI::ValidationError("--box", "expected x0,y0,z0,x1,y1,z1 with x0 <= x1 ...");
    }
    if (f->bounds().isEmpty() && !file.empty())
        throw ParseError(file + ": the scene is empty (it has no objects, or every object was ignored)");
    if (!volume::sampleDomain(*f, clip).isBounded()) {
        // From a file, that is what the file holds (exit 1); from --shape or --expr, the command line (2).
        const std::string why = f->describe() + " is unbounded: give --box x0,y0,z0,x1,y1,z1";
        if (!file.empty()) throw ParseError(file + ": " + why);
        throw CLI::ValidationError("--box", why);
    }
    return f;
}

volume::InsideSide insideSideOf(const std::string& word) {
    return word == "below" ? volume::InsideSide::Below
                           : (word == "above" ? volume::InsideSide::Above : volume::InsideSide::Auto);
}

float voxelSize(const implicit::Field& field, const implicit::Box3& clip, const FieldInput& in) {
    if (in.voxel > 0) return in.voxel;
    return volume::voxelSizeForResolution(volume::sampleDomain(field, clip), in.resolution > 0 ? in.resolution : 256);
}

}  // namespace isoforge::app
