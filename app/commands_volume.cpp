// isoforge info / mesh: commands on volume files.
#include <chrono>
#include <cstdio>
#include <iostream>

#include "app/commands.h"
#include "core/error.h"
#include "mesh/check.h"
#include "mesh/io.h"
#include "volume/marching_cubes.h"
#include "volume/vdb_io.h"

namespace isoforge::app {

std::string withCommas(unsigned long long n) {
    const std::string digits = std::to_string(n);
    std::string s;
    for (std::size_t i = 0; i < digits.size(); ++i) {
        if (i > 0 && (digits.size() - i) % 3 == 0) s.push_back(',');
        s.push_back(digits[i]);
    }
    return s;
}

namespace {

void requireVdb(const std::string& path) {
    std::filesystem::path p(path);
    std::string ext = p.extension().string();
    for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (ext != ".vdb")
        throw IoError(path + ": unsupported volume format '" + ext + "' (this version reads .vdb files)");
}

}  // namespace

void addInfoCommand(CLI::App& app, const GlobalOptions& g, Commands& c) {
    auto* cmd =
        app.add_subcommand("info", "Describe the grids of volume files: types, voxel size, active voxels, bounds");
    auto files = std::make_shared<std::vector<std::string>>();
    cmd->add_option("files", *files, "Volume files (.vdb)")->required();
    cmd->callback([&c, files] {
        c.run = [files] {
            for (const std::string& f : *files) {
                requireVdb(f);
                openvdb::GridPtrVec grids = volume::readVdb(f);
                std::cout << f << ": " << grids.size() << (grids.size() == 1 ? " grid\n" : " grids\n");
                for (const auto& grid : grids) std::cout << volume::toString(volume::summarize(*grid));
            }
            return 0;
        };
    });
}

void addMeshCommand(CLI::App& app, const GlobalOptions& g, Commands& c) {
    struct Args {
        std::string input, output, grid, inside = "auto";
        float iso = 0.f;
        bool normals = false, indexSpace = false, ascii = false, stats = false;
    };
    auto a = std::make_shared<Args>();
    auto* cmd = app.add_subcommand("mesh", "Extract an iso-surface from a volume as a triangle mesh");
    cmd->add_option("input", a->input, "Volume file (.vdb)")->required();
    cmd->add_option("-o,--output", a->output, "Mesh file: .ply (binary; --ascii for text), .obj or .stl")->required();
    cmd->add_option("--grid", a->grid, "Grid name (default: the first level set, else the first float grid)");
    cmd->add_option("--iso", a->iso, "Iso-value (default 0: the zero level set)");
    cmd->add_option("--inside", a->inside,
                    "Which side is solid: below (level sets), above (fog, density, CT) or auto (by grid class)")
        ->check(CLI::IsMember({"auto", "below", "above"}));
    cmd->add_flag("--normals", a->normals, "Write per-vertex normals from the grid gradient");
    cmd->add_flag("--index-space", a->indexSpace, "Positions in voxel units instead of world units");
    cmd->add_flag("--ascii", a->ascii, "ASCII PLY instead of binary");
    cmd->add_flag("--stats", a->stats, "Print timings and a topology check of the result");
    cmd->callback([&c, &g, a] {
        c.run = [&g, a] {
            if (!mesh::isMeshPath(a->output))
                throw CLI::ValidationError("--output", a->output + ": expected a .ply, .obj or .stl file name");
            requireVdb(a->input);
            using Clock = std::chrono::steady_clock;
            const auto t0 = Clock::now();
            openvdb::FloatGrid::Ptr grid =
                volume::readFloatGrid(a->input, a->grid.empty() ? std::nullopt : std::optional(a->grid));
            const double readSeconds = std::chrono::duration<double>(Clock::now() - t0).count();

            TerminalProgress progress;
            volume::MeshingOptions opt;
            opt.isovalue = a->iso;
            opt.inside = a->inside == "below"   ? volume::InsideSide::Below
                         : a->inside == "above" ? volume::InsideSide::Above
                                                : volume::InsideSide::Auto;
            opt.normals = a->normals;
            opt.worldSpace = !a->indexSpace;
            opt.progress = g.quiet ? nullptr : &progress;
            volume::MeshingStats stats;
            const auto t1 = Clock::now();
            mesh::TriMesh m = volume::extractIsosurface(*grid, opt, &stats);
            const double meshSeconds = std::chrono::duration<double>(Clock::now() - t1).count();
            if (m.empty())
                std::cerr << "isoforge: warning: no surface at iso " << a->iso << " in grid '" << grid->getName()
                          << "' (values " << (volume::insideIsBelow(*grid, opt.inside) ? "below" : "above")
                          << " the iso are inside); writing an empty mesh\n";
            const auto t2 = Clock::now();
            mesh::writeMesh(a->output, m, {a->ascii});
            const double writeSeconds = std::chrono::duration<double>(Clock::now() - t2).count();
            if (!g.quiet) {
                std::printf("meshed grid '%s' (%s, iso %g, inside %s): %s vertices, %s triangles in %.3f s -> %s\n",
                            grid->getName().c_str(), openvdb::GridBase::gridClassToString(grid->getGridClass()).c_str(),
                            a->iso, volume::insideIsBelow(*grid, opt.inside) ? "below" : "above",
                            withCommas(m.vertexCount()).c_str(), withCommas(m.triangleCount()).c_str(), meshSeconds,
                            a->output.c_str());
            }
            if (a->stats) {
                std::printf("read %.3f s, mesh %.3f s (setup %.3f, count %.3f, write %.3f), save %.3f s\n", readSeconds,
                            meshSeconds, stats.secondsSetup, stats.secondsCount, stats.secondsWrite, writeSeconds);
                std::printf("leaves %s, blocks visited %s, blocks with surface %s\n", withCommas(stats.leaves).c_str(),
                            withCommas(stats.blocks).c_str(), withCommas(stats.surfaceBlocks).c_str());
                std::cout << mesh::check(m).toString();
            }
            return 0;
        };
    });
}

}  // namespace isoforge::app
