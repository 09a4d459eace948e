// isoforge check (and --repair), primitive, strips: commands on mesh files.
#include <cmath>
#include <cstdio>
#include <iostream>

#include "app/commands.h"
#include "core/error.h"
#include "mesh/check.h"
#include "mesh/io.h"
#include "mesh/parametric.h"
#include "mesh/primitives.h"
#include "mesh/repair.h"
#include "mesh/strips.h"
#include "mesh/subdivide.h"

namespace isoforge::app {

void addCheckCommand(CLI::App& app, const GlobalOptions& g, Commands& c) {
    struct Args {
        std::vector<std::string> files;
        bool strict = false, repair = false, selfIntersections = false;
        std::string output;
    };
    auto a = std::make_shared<Args>();
    auto* cmd = app.add_subcommand(
        "check", "Report whether meshes are watertight, manifold and oriented; genus, components, area, volume");
    cmd->add_option("meshes", a->files,
                    "Mesh files (.ply .obj .stl, from any tool); with per-vertex normals, vertices that share a "
                    "position (split for crisp creases) count as one")
        ->required();
    cmd->add_flag("--strict", a->strict, "Exit with status 1 unless every mesh is a valid closed, oriented 2-manifold");
    cmd->add_flag("--repair", a->repair,
                  "Drop degenerate and duplicate triangles, orient consistently and outward (cavities inward); "
                  "write the result with -o");
    cmd->add_option("-o,--output", a->output, "With --repair: the repaired mesh (.ply .obj .stl .glb)");
    cmd->add_flag("--self-intersections", a->selfIntersections,
                  "Also count pairs of triangles that intersect (other than along a shared edge or vertex; exact "
                  "predicates) and name the first; with --strict, any makes the exit status 1");
    cmd->callback([&c, &g, a] {
        c.run = [&g, a] {
            if (a->repair && (a->output.empty() || a->files.size() != 1))
                throw CLI::ValidationError("--repair", "give one mesh and -o for the repaired one");
            if (!a->output.empty() && !a->repair) throw CLI::ValidationError("-o", "-o goes with --repair");
            if (a->repair && !mesh::isMeshPath(a->output))
                throw CLI::ValidationError("-o", a->output + ": expected a .ply, .obj, .stl or .glb file name");
            bool allValid = true;
            for (const std::string& f : a->files) {
                mesh::TriMesh m = mesh::readMesh(f);
                if (a->repair) {
                    const mesh::RepairReport r = mesh::repair(m);
                    if (!g.quiet) std::cout << f << ": repair\n" << r.toString();
                    mesh::writeMesh(a->output, m);
                }
                // With per-vertex normals, vertices may be split for crisp creases: checked by position.
                mesh::MeshReport r =
                    mesh::check(m, {.selfIntersections = a->selfIntersections, .weldByPosition = !m.normals.empty()});
                if (!g.quiet || !a->repair) std::cout << (a->repair ? a->output : f) << "\n" << r.toString();
                allValid = allValid && r.isValidClosedSurface();
            }
            return (a->strict && !allValid) ? 1 : 0;
        };
    });
}

void addPrimitiveCommand(CLI::App& app, const GlobalOptions& g, Commands& c) {
    struct Args {
        std::string name, output;
        int resolution = 32;
        bool ascii = false;
    };
    auto a = std::make_shared<Args>();
    auto* cmd = app.add_subcommand(
        "primitive",
        "Write a closed, outward-oriented polygonal primitive: cube, cylinder, cone, sphere, icosphere, torus");
    cmd->add_option("name", a->name, "cube, cylinder, cone, sphere (UV), icosphere, torus")
        ->required()
        ->check(CLI::IsMember(mesh::primitiveNames()));
    cmd->add_option("--resolution", a->resolution,
                    "Sides around the axis (cube: cells per edge; icosphere: subdivision levels 0-8); default 32");
    cmd->add_option("-o,--output", a->output, "Mesh file: .ply, .obj, .stl or .glb")->required();
    cmd->add_flag("--ascii", a->ascii, "ASCII PLY instead of binary");
    cmd->callback([&c, &g, a] {
        c.run = [&g, a] {
            if (!mesh::isMeshPath(a->output))
                throw CLI::ValidationError("--output", a->output + ": expected a .ply, .obj, .stl or .glb file name");
            const mesh::TriMesh m = mesh::makePrimitive(a->name, a->resolution);
            mesh::writeMesh(a->output, m, {a->ascii});
            if (!g.quiet)
                std::cout << a->name << " at resolution " << a->resolution << ": " << withCommas(m.vertexCount())
                          << " vertices, " << withCommas(m.triangleCount()) << " triangles -> " << a->output << "\n";
            return 0;
        };
    });
}

void addStripsCommand(CLI::App& app, const GlobalOptions& g, Commands& c) {
    struct Args {
        std::string input, output;
    };
    auto a = std::make_shared<Args>();
    auto* cmd = app.add_subcommand(
        "strips",
        "Turn a mesh into triangle strips: vertices sent per triangle before and after, checked by expanding back");
    cmd->add_option("mesh", a->input, "Mesh file (.ply .obj .stl .off)")->required();
    cmd->add_option("-o,--output", a->output, "Write positions and strips as text (.strips)");
    cmd->callback([&c, &g, a] {
        c.run = [&g, a] {
            const mesh::TriMesh m = mesh::readMesh(a->input);
            const mesh::Strips s = mesh::makeStrips(m);
            const bool same = mesh::sameTriangles(mesh::expandStrips(s), m.triangles);
            if (!a->output.empty()) mesh::writeStrips(a->output, m, s);
            if (!g.quiet) {
                char line[256];
                std::snprintf(line, sizeof line,
                              "%s triangles: 3.00 vertices per triangle as a list, %.3f in %s strips "
                              "(%.1f triangles per strip); expanded back: %s",
                              withCommas(m.triangleCount()).c_str(), s.verticesPerTriangle(),
                              withCommas(s.stripCount).c_str(),
                              s.stripCount ? double(m.triangleCount()) / double(s.stripCount) : 0.0,
                              same ? "the same triangles" : "DIFFERENT");
                std::cout << line << (a->output.empty() ? "" : " -> " + a->output) << "\n";
            }
            return same ? 0 : 1;
        };
    });
}

void addSubdivideCommand(CLI::App& app, const GlobalOptions& g, Commands& c) {
    struct Args {
        std::string input, output, scheme = "loop";
        int levels = 1;
        double crease = 0.0;
    };
    auto a = std::make_shared<Args>();
    auto* cmd = app.add_subcommand(
        "subdivide", "Subdivide a triangle mesh: Loop (approximating) or modified butterfly (interpolating)");
    cmd->add_option("mesh", a->input, "Mesh file (.ply .obj .stl .off); must be manifold")->required();
    cmd->add_option("--scheme", a->scheme, "loop (approximating, default) or butterfly (interpolating)")
        ->check(CLI::IsMember({"loop", "butterfly"}));
    cmd->add_option("--levels", a->levels, "Levels (each multiplies the triangles by 4; default 1)")
        ->check(CLI::Range(1, 8));
    cmd->add_option("--crease-angle", a->crease,
                    "Loop only: edges whose faces meet at more than this many degrees stay sharp creases "
                    "(e.g. 30 keeps a cube's edges and corners); default 0, no creases")
        ->check(CLI::Range(0.0, 180.0));
    cmd->add_option("-o,--output", a->output, "Mesh file: .ply, .obj, .stl or .glb")->required();
    cmd->callback([&c, &g, a] {
        c.run = [&g, a] {
            if (!mesh::isMeshPath(a->output))
                throw CLI::ValidationError("--output", a->output + ": expected a .ply, .obj, .stl or .glb file name");
            if (a->crease > 0 && a->scheme != "loop")
                throw CLI::ValidationError("--crease-angle", "creases are a rule of the Loop scheme");
            mesh::TriMesh m = mesh::readMesh(a->input);
            const std::size_t before = m.triangleCount();
            const double estimate = double(before) * std::pow(4.0, a->levels) * 40.0;  // bytes, roughly
            if (estimate > 8e9)
                throw ResourceError("subdividing " + withCommas(before) + " triangles " + std::to_string(a->levels) +
                                    " times would need about " +
                                    withCommas(static_cast<unsigned long long>(estimate / (1 << 20))) +
                                    " MiB: use fewer --levels");
            if (a->scheme == "loop")
                m = mesh::loopSubdivide(m, a->levels, a->crease);
            else
                for (int i = 0; i < a->levels; ++i) m = mesh::butterflySubdivide(m);
            mesh::writeMesh(a->output, m);
            if (!g.quiet)
                std::cout << "subdivided " << a->input << " (" << a->scheme << ", " << a->levels
                          << " levels): " << withCommas(before) << " -> " << withCommas(m.triangleCount())
                          << " triangles -> " << a->output << "\n";
            return 0;
        };
    });
}

void addTessellateCommand(CLI::App& app, const GlobalOptions& g, Commands& c) {
    struct Args {
        std::string input, output;
        int resolution = 16;
    };
    auto a = std::make_shared<Args>();
    auto* cmd = app.add_subcommand(
        "tessellate", "Tessellate Bézier patches (.bpt, e.g. Newell's teapot) into a welded triangle mesh");
    cmd->add_option("patches", a->input, "Bézier patch file (.bpt): a count, then degrees and points per patch")
        ->required();
    cmd->add_option("--resolution", a->resolution, "Quads along each side of every patch (default 16)")
        ->check(CLI::Range(1, 4096));
    cmd->add_option("-o,--output", a->output, "Mesh file: .ply, .obj, .stl or .glb")->required();
    cmd->callback([&c, &g, a] {
        c.run = [&g, a] {
            if (!mesh::isMeshPath(a->output))
                throw CLI::ValidationError("--output", a->output + ": expected a .ply, .obj, .stl or .glb file name");
            const auto patches = mesh::readBezierPatches(a->input);
            const mesh::TriMesh m = mesh::tessellate(patches, a->resolution);
            mesh::writeMesh(a->output, m);
            if (!g.quiet) {
                const mesh::MeshReport r = mesh::check(m);
                std::cout << a->input << ": " << patches.size() << " patches at resolution " << a->resolution << ": "
                          << withCommas(m.vertexCount()) << " vertices, " << withCommas(m.triangleCount())
                          << " triangles, "
                          << (r.isValidClosedSurface() ? std::string("closed")
                                                       : withCommas(r.boundaryEdges) + " boundary edges")
                          << " -> " << a->output << "\n";
            }
            return 0;
        };
    });
}

}  // namespace isoforge::app
