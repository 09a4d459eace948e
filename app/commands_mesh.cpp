// isoforge check: commands on mesh files.
#include <iostream>

#include "app/commands.h"
#include "mesh/check.h"
#include "mesh/io.h"

namespace isoforge::app {

void addCheckCommand(CLI::App& app, const GlobalOptions& g, Commands& c) {
    auto files = std::make_shared<std::vector<std::string>>();
    auto strict = std::make_shared<bool>(false);
    auto* cmd = app.add_subcommand(
        "check", "Report whether meshes are watertight, manifold and oriented; genus, components, area, volume");
    cmd->add_option("meshes", *files, "Mesh files (.ply .obj .stl, from any tool)")->required();
    cmd->add_flag("--strict", *strict, "Exit with status 1 unless every mesh is a valid closed, oriented 2-manifold");
    cmd->callback([&c, files, strict] {
        c.run = [files, strict] {
            bool allValid = true;
            for (const std::string& f : *files) {
                mesh::TriMesh m = mesh::readMesh(f);
                mesh::MeshReport r = mesh::check(m);
                std::cout << f << "\n" << r.toString();
                allValid = allValid && r.isValidClosedSurface();
            }
            return (*strict && !allValid) ? 1 : 0;
        };
    });
}

}  // namespace isoforge::app
