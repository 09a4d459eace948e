// isoforge: the command-line front end. Only argument parsing, progress and messages live here.
#include <cstdio>
#include <cstdlib>
#include <iostream>

#include <openvdb/version.h>
#include <tbb/global_control.h>
#include <tbb/version.h>
#include <glm/detail/setup.hpp>

#include "app/commands.h"
#include "app/malloc_tunables.h"
#include "core/error.h"
#include "render/embree_device.h"
#include "render/image.h"

namespace {

std::string imageLibrary() {
    try {
        return isoforge::render::imageLibraryVersion();
    } catch (const isoforge::IoError&) {
        return "OpenImageIO (its module cannot be loaded: images cannot be read or written)";
    }
}

std::string versionText() {
    std::string v = "isoforge " ISOFORGE_VERSION "\n";
    v += "  OpenVDB " + std::to_string(OPENVDB_LIBRARY_MAJOR_VERSION_NUMBER) + "." +
         std::to_string(OPENVDB_LIBRARY_MINOR_VERSION_NUMBER) + "." +
         std::to_string(OPENVDB_LIBRARY_PATCH_VERSION_NUMBER) + ", oneTBB " + std::to_string(TBB_VERSION_MAJOR) + "." +
         std::to_string(TBB_VERSION_MINOR) + ", " + isoforge::render::embreeVersion() + ", " + imageLibrary() +
         ", GLM " + std::to_string(GLM_VERSION_MAJOR) + "." + std::to_string(GLM_VERSION_MINOR) + "." +
         std::to_string(GLM_VERSION_PATCH);
    // What the launcher (app/launcher.c) asked of glibc's malloc, or what the user set instead.
    v += "\n  malloc: " + isoforge::app::mallocTunablesText();
    return v;
}

}  // namespace

int main(int argc, char** argv) {
    using namespace isoforge;
    CLI::App app{
        "isoforge: iso-surfaces from sparse volumes, implicit surfaces and CSG scenes.\n"
        "Meshes are watertight, manifold and outward-oriented; output is the same whatever the thread count.",
        "isoforge"};
    app.require_subcommand(1);
    app.fallthrough();
    app.get_formatter()->column_width(36);
    app::GlobalOptions global;
    app.add_option("--threads", global.threads, "Worker threads (default: all cores)")->check(CLI::PositiveNumber);
    app.add_flag("-q,--quiet", global.quiet, "No progress and no summary; errors only");
    bool showVersion = false;
    app.add_flag("--version", showVersion, "Print the version of isoforge and its libraries, then exit");
    app.footer(
        "Run 'isoforge COMMAND --help' for a command's options.\n"
        "Exit status: 0 success, 1 bad input (message on stderr), 2 usage error.");

    app::Commands commands;
    app::addInfoCommand(app, global, commands);
    app::addMeshCommand(app, global, commands);
    app::addCheckCommand(app, global, commands);
    app::addCompareCommand(app, global, commands);
    app::addPrimitiveCommand(app, global, commands);
    app::addStripsCommand(app, global, commands);
    app::addSubdivideCommand(app, global, commands);
    app::addTessellateCommand(app, global, commands);
    app::addSampleCommand(app, global, commands);
    app::addVoxelizeCommand(app, global, commands);
    app::addConvertCommand(app, global, commands);
    app::addRenderCommand(app, global, commands);
    app::addSliceCommand(app, global, commands);
    app::addShapesCommand(app, global, commands);
    app::addCheckSceneCommand(app, global, commands);
    app::addViewCommand(app, global, commands);

    // --version works without a subcommand.
    for (int i = 1; i < argc; ++i)
        if (std::string(argv[i]) == "--version") {
            std::cout << versionText() << "\n";
            return 0;
        }
    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        std::cerr << "isoforge: " << e.what() << "\nRun 'isoforge --help' for usage.\n";
        return 2;
    }

    std::optional<tbb::global_control> threadLimit;
    if (global.threads > 0) threadLimit.emplace(tbb::global_control::max_allowed_parallelism, global.threads);
    try {
        return commands.run ? commands.run() : 2;
    } catch (const IoError& e) {
        std::cerr << "isoforge: " << e.what() << "\n";
        return 1;
    } catch (const ResourceError& e) {
        std::cerr << "isoforge: " << e.what() << "\n";
        return 1;
    } catch (const CLI::ValidationError& e) {
        std::cerr << "isoforge: " << e.what() << "\n";
        return 2;
    } catch (const std::invalid_argument& e) {
        std::cerr << "isoforge: " << e.what() << "\n";
        return 1;
    } catch (const std::exception& e) {
        std::cerr << "isoforge: internal error: " << e.what() << "\n";
        return 1;
    }
}
