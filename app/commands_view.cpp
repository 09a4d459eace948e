// isoforge view: the live preview (view/live.h). Parses the command line, prints the address, and runs
// until Ctrl-C.
#include <atomic>
#include <csignal>
#include <cstdio>
#include <iostream>

#include "app/commands.h"
#include "app/field_input.h"
#include "app/volume_input.h"
#include "view/live.h"

namespace isoforge::app {

namespace {

std::atomic<bool> stopRequested{false};

extern "C" void onStopSignal(int) {
    stopRequested = true;
}

}  // namespace

void addViewCommand(CLI::App& app, const GlobalOptions& g, Commands& c) {
    struct Args {
        view::ModelRequest model;
        view::LiveOptions live;
        bool sharp = false, noSharp = false;
    };
    auto a = std::make_shared<Args>();
    auto* cmd = app.add_subcommand(
        "view", "Live preview in a web browser: the model is rebuilt whenever its file, or a file it reads, is saved");
    cmd->add_option("input", a->model.input,
                    "Scene (.isf, OpenSCAD .csg or .scad), implicit model (.vm), volume (.vdb, .nii, .nrrd, .mha, "
                    "DICOM directory, .raw) or mesh (.ply .obj .stl .off); or --shape / --expr");
    addFieldOptions(cmd, a->model.field, true);
    addVolumeReadOptions(cmd, a->model.volume);
    cmd->add_option("--iso", a->model.iso, "Volumes: the iso-value (default 0)");
    cmd->add_option("--inside", a->model.inside, "Volumes: which side is solid: below, above or auto")
        ->check(CLI::IsMember({"auto", "below", "above"}));
    auto* sharpFlag =
        cmd->add_flag("--sharp", a->sharp, "Feature vertices on sharp edges (default for OpenSCAD models)");
    cmd->add_flag("--no-sharp", a->noSharp, "Plain marching cubes for OpenSCAD models too")->excludes(sharpFlag);
    cmd->add_option("--coarse", a->model.coarseResolution,
                    "Voxels along the longest side of the first, coarse look shown while the full model is made "
                    "(default 48; 0: none)")
        ->check(CLI::Range(0, 4096));
    cmd->add_option("--port", a->live.port, "TCP port (default 0: any free port; the address is printed)")
        ->check(CLI::Range(0, 65535));
    cmd->add_option("--host", a->live.host,
                    "Address to listen on (default 127.0.0.1: this machine only; 0.0.0.0 shares the preview with "
                    "the network, without any authentication)");
    cmd->footer(
        "Open the printed address in a browser. Drag to orbit, right-drag to pan, scroll to zoom; the camera "
        "stays where you leave it across reloads. Stop with Ctrl-C. See docs/view.md.");
    cmd->callback([&c, &g, a] {
        c.run = [&g, a] {
            if (a->model.input.empty() && a->model.field.shape.empty() && a->model.field.expr.empty())
                throw CLI::ValidationError("input", "give a file to view, or --shape / --expr");
            a->model.sharp = a->sharp;
            a->model.noSharp = a->noSharp;
            view::LiveView live(a->model, a->live);
            std::signal(SIGINT, onStopSignal);
            std::signal(SIGTERM, onStopSignal);
            // The address first and alone on its line, flushed: scripts and tests read it.
            std::printf("isoforge view: http://%s:%d/\n",
                        a->live.host == "0.0.0.0" ? "127.0.0.1" : a->live.host.c_str(), live.port());
            if (!g.quiet)
                std::printf("watching %s; Ctrl-C to stop\n",
                            a->model.input.empty() ? "nothing (a --shape or --expr)" : a->model.input.c_str());
            std::fflush(stdout);
            live.run(stopRequested, [&g](const std::string& line) {
                if (g.quiet && line.rfind("error: ", 0) != 0) return;
                std::printf("%s\n", line.c_str());
                std::fflush(stdout);
            });
            if (!g.quiet) std::printf("stopped\n");
            return 0;
        };
    });
}

}  // namespace isoforge::app
