// isoforge info / mesh: commands on volume files.
#include <chrono>
#include <cstdio>
#include <iostream>
#include <optional>

#include "app/commands.h"
#include "app/mesh_slabs.h"

#include "app/field_input.h"
#include "app/volume_input.h"
#include "core/error.h"
#include "core/number_text.h"
#include "csg/scene.h"
#include "implicit/quadric.h"
#include "implicit/shape_spec.h"
#include "mesh/check.h"
#include "mesh/crease_normals.h"
#include "mesh/io.h"
#include "mesh/stream_writer.h"
#include "render/image.h"
#include "render/slice.h"
#include "render/volume_views.h"
#include "volume/dense_grid.h"
#include "volume/labels.h"
#include "volume/machine_memory.h"
#include "volume/marching_cubes.h"
#include "volume/sample.h"
#include "volume/surface.h"
#include "volume/vdb_io.h"
#include "volume/voxel_source.h"
#include "volume/voxelize.h"

namespace isoforge::app {

std::string withCommas(unsigned long long n) {
    return countText(n);
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
    auto vin = std::make_shared<VolumeInput>();
    cmd->add_option("files", *files,
                    "Volume files: .vdb, NIfTI (.nii .nii.gz), NRRD (.nrrd .nhdr), MetaImage (.mha .mhd), a DICOM "
                    "directory, or .raw with --dims and --type")
        ->required();
    addVolumeReadOptions(cmd, *vin);
    cmd->callback([&c, files, vin] {
        c.run = [files, vin] {
            for (const std::string& f : *files) {
                if (isDenseVolumeFile(f)) {
                    const volume::DenseVolume v = loadVolume(f, *vin, GlobalOptions{0, true});
                    std::cout << describeVolume(f, v);
                    continue;
                }
                requireVdb(f);
                openvdb::GridPtrVec grids = volume::readVdb(f);
                std::cout << f << ": " << grids.size() << (grids.size() == 1 ? " grid\n" : " grids\n");
                for (const auto& grid : grids) std::cout << volume::toString(volume::summarize(*grid));
            }
            return 0;
        };
    });
}

namespace {

openvdb::FloatGrid::Ptr sampleField(const implicit::FieldPtr& field, volume::SampleOptions so, const GlobalOptions& g,
                                    Progress* progress, bool printStats);

volume::SampleOptions sampleOptionsFor(const implicit::Field& field, const implicit::Box3& clip,
                                       const FieldInput& fin) {
    volume::SampleOptions so;
    so.voxelSize = voxelSize(field, clip, fin);
    so.halfWidth = fin.halfWidth;
    so.clip = clip;
    return so;
}

/// A grid from a volume file, or sampled from a field; prints what it did unless quiet.
openvdb::FloatGrid::Ptr loadOrSample(const std::string& input, const std::string& gridName, const FieldInput& fin,
                                     const GlobalOptions& g, Progress* progress, bool printStats,
                                     implicit::FieldPtr* fieldOut = nullptr, const VolumeInput* vin = nullptr,
                                     int smooth = 0) {
    if (!namesField(input, fin)) {
        if (input.empty()) throw CLI::ValidationError("input", "give a volume file, a .vm model, --shape or --expr");
        if (isDenseVolumeFile(input)) {
            const VolumeInput none;
            const volume::DenseVolume v = loadVolume(input, vin ? *vin : none, g);
            return volumeGrid(v, vin ? *vin : none, smooth, progress);
        }
        requireVdb(input);
        return volume::readFloatGrid(input, gridName.empty() ? std::nullopt : std::optional(gridName));
    }
    implicit::Box3 clip;
    const implicit::FieldPtr field = makeField(input, fin, clip);
    if (fieldOut) *fieldOut = field;
    return sampleField(field, sampleOptionsFor(*field, clip, fin), g, progress, printStats);
}

/// The field sampled as `so` says; prints what it did unless quiet.
openvdb::FloatGrid::Ptr sampleField(const implicit::FieldPtr& field, volume::SampleOptions so, const GlobalOptions& g,
                                    Progress* progress, bool printStats) {
    so.progress = progress;
    volume::SampleStats st;
    openvdb::FloatGrid::Ptr grid = volume::sample(field, so, &st);
    grid->setName("field");
    if (!g.quiet)
        std::printf("sampled %s at voxel %g (estimated %s MiB): %s leaves, %s inside tiles, %s points in %.3f s (%s)\n",
                    field->describe().c_str(), so.voxelSize, withCommas(st.estimatedBytes >> 20).c_str(),
                    withCommas(st.leaves).c_str(), withCommas(st.tiles).c_str(), withCommas(st.pointsEvaluated).c_str(),
                    st.seconds, st.distance ? "narrow-band level set" : "scalar field, inside below 0");
    if (printStats)
        std::printf("bounds evaluated %s, estimated memory %s bytes\n", withCommas(st.boundsEvaluated).c_str(),
                    withCommas(st.estimatedBytes).c_str());
    return grid;
}

}  // namespace

namespace {

/// `mesh VOLUME --memory`: a volume file read as it streams, keeping the blocks near the iso-value of a
/// run of slabs at a time; a DICOM series converted and meshed a slab at a time (the volume itself is
/// held); or a .vdb grid meshed a slab at a time (the grid is held, the mesh is not).
int meshVolumeFileBySlabs(const std::string& input, const std::string& gridName, const VolumeInput& vin, int smooth,
                          bool sharp, bool maxError, SlabMeshJob job, const GlobalOptions& g) {
    if (input.empty()) throw CLI::ValidationError("input", "give a volume file, a .vm model, --shape or --expr");
    if (sharp || maxError)
        throw CLI::ValidationError(sharp ? "--sharp" : "--max-error",
                                   "feature vertices and simplification work on the whole mesh: not with --memory");
    if (smooth > 0) throw CLI::ValidationError("--smooth", "smoothing looks across slabs: not with --memory");
    if (vin.tolerance > 0)
        throw CLI::ValidationError("--tolerance", "a tolerance prunes across slabs: not with --memory");
    if (!mesh::MeshStreamWriter::canStream(job.output))
        throw CLI::ValidationError("--memory", "a mesh written in slabs is .ply, .obj or .stl");
    job.what = input;
    volume::DenseVolume dense;
    std::optional<volume::VoxelSource> source;
    if (isDenseVolumeFile(input)) {
        // Streamed where the format allows it (never the whole volume), else read whole.
        source = volume::voxelSource(input, readOptions(vin));
        if (source) {
            job.source = &*source;
        } else {
            dense = loadVolume(input, vin, g);
            job.volume = &dense;
        }
    } else {
        requireVdb(input);
        job.grid = volume::readFloatGrid(input, gridName.empty() ? std::nullopt : std::optional(gridName));
    }
    return meshBySlabsToFile(job, g);
}

/// True when a volume file is meshed as it streams (volume/near_level.h), never held whole: a format
/// that streams, output that streams, nothing that looks across slabs or needs the whole mesh. The same
/// bytes as reading it whole and meshing its grid, in a fraction of the time and memory (docs/scaling.md),
/// so it is the default; says so when the volume's floats would not fit in half of this machine's memory.
bool volumeStreams(const std::string& input, const VolumeInput& vin, int smooth, bool sharp, bool maxError,
                   const std::string& output, const GlobalOptions& g) {
    if (!isDenseVolumeFile(input) || smooth > 0 || sharp || maxError || vin.tolerance > 0 ||
        !mesh::MeshStreamWriter::canStream(output))
        return false;
    double bytes = 0;  // the volume as floats
    std::error_code ec;
    if (std::filesystem::is_directory(input, ec)) {
        // A DICOM series of more than 32 MiB of files streams: the helper reads slices while the slabs are
        // meshed (960 slices of 512 x 512: 2.9-3.2 s instead of 4.6-6.1 s, 166 instead of 1,093 MiB;
        // bench/dicom_stream.py). A smaller one is read whole: streamed, the helper scans the files twice (for
        // the header, then for the slices), 0.1-0.15 s more on the 48-slice CT (24 MiB).
        std::uint64_t files = 0;
        for (const auto& e : std::filesystem::directory_iterator(input, ec))
            if (e.is_regular_file(ec)) files += e.file_size(ec);
        if (files <= (std::uint64_t(32) << 20)) return false;
        bytes = 2.0 * double(files);  // floats from 16-bit pixels
    } else {
        std::optional<volume::VoxelSource> source;
        try {
            source = volume::voxelSource(input, readOptions(vin));
        } catch (const std::exception&) {
            return false;  // the whole read reports it
        }
        if (!source) return false;
        bytes = double(source->header.voxelCount()) * 4.0;
    }
    if (!g.quiet && bytes > double(volume::physicalMemory() / 2))
        std::printf(
            "%s as floats would take about %s, more than half of this machine's memory: meshing it as it "
            "streams (as with --memory %s)\n",
            input.c_str(), bytesText(bytes).c_str(), bytesText(double(volume::physicalMemory() / 2)).c_str());
    return true;
}

/// `mesh --labels`: one closed, coloured surface per label of a label map.
int meshLabels(const std::string& input, const std::string& output, const std::string& colors, bool split,
               const std::string& method, const VolumeInput& vin, const GlobalOptions& g, bool ascii) {
    if (!mesh::isMeshPath(output))
        throw CLI::ValidationError("--output", output + ": expected a .ply, .obj, .stl or .glb file name");
    if (!isDenseVolumeFile(input)) throw CLI::ValidationError("--labels", "--labels needs a label volume file");
    volume::LabelTable table;
    if (!colors.empty()) table = volume::readLabelTable(colors);
    const volume::DenseVolume v = loadVolume(input, vin, g);
    TerminalProgress progress;
    const auto t0 = std::chrono::steady_clock::now();
    std::vector<volume::LabelSurface> surfaces =
        volume::labelSurfaces(v, g.quiet ? nullptr : &progress,
                              method == "mc" ? volume::LabelMethod::MarchingCubes : volume::LabelMethod::Shared);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    mesh::TriMesh all;
    std::size_t open = 0, inTable = 0;
    const std::filesystem::path out(output);
    for (volume::LabelSurface& s : surfaces) {
        auto it = table.find(s.label);
        const bool known = it != table.end();
        inTable += known;
        const std::array<float, 3> col =
            known && it->second.hasColor ? it->second.color : volume::defaultLabelColor(s.label);
        s.mesh.colors.assign(s.mesh.positions.size(), glm::vec3(col[0], col[1], col[2]));
        const mesh::MeshReport r = mesh::check(s.mesh);
        open += !r.isValidClosedSurface();
        if (split) {
            std::string name = known && !it->second.name.empty() ? it->second.name : "label";
            for (char& ch : name)
                if (!std::isalnum(static_cast<unsigned char>(ch)) && ch != '-' && ch != '_') ch = '_';
            const auto file = out.parent_path() / (out.stem().string() + "_" + std::to_string(s.label) + "_" + name +
                                                   out.extension().string());
            mesh::writeMesh(file, s.mesh, {ascii});
        }
        const auto base = static_cast<std::uint32_t>(all.positions.size());
        all.positions.insert(all.positions.end(), s.mesh.positions.begin(), s.mesh.positions.end());
        all.colors.insert(all.colors.end(), s.mesh.colors.begin(), s.mesh.colors.end());
        for (const glm::uvec3& t : s.mesh.triangles) all.triangles.push_back(t + glm::uvec3(base));
    }
    mesh::writeMesh(output, all, {ascii});
    if (!g.quiet) {
        std::printf(
            "meshed %zu labels (%zu named in %s) in %.3f s: %s vertices, %s triangles, %s -> %s\n", surfaces.size(),
            inTable, colors.empty() ? "no table" : colors.c_str(), seconds, withCommas(all.vertexCount()).c_str(),
            withCommas(all.triangleCount()).c_str(),
            open == 0 ? "every label closed and manifold" : (std::to_string(open) + " labels NOT closed").c_str(),
            output.c_str());
        if (split)
            std::printf("and one file per label: %s_LABEL_NAME%s\n", (out.parent_path() / out.stem()).c_str(),
                        out.extension().c_str());
    }
    return open == 0 ? 0 : 1;
}

}  // namespace

void addMeshCommand(CLI::App& app, const GlobalOptions& g, Commands& c) {
    struct Args {
        std::string input, output, grid, inside = "auto", colors, labelMethod = "shared", memory;
        float iso = 0.f;
        int smooth = 0;
        bool normals = false, indexSpace = false, ascii = false, stats = false, labels = false, split = false,
             sharp = false, noSharp = false, readWhole = false;
        double maxError = 0, creaseAngle = 30;
        FieldInput field;
        VolumeInput volume;
    };
    auto a = std::make_shared<Args>();
    auto* cmd =
        app.add_subcommand("mesh", "Extract an iso-surface from a volume or an implicit field as a triangle mesh");
    cmd->add_option("input", a->input,
                    "Volume (.vdb, .nii/.nii.gz, .nrrd/.nhdr, .mha/.mhd, a DICOM directory, .raw), scene (.isf, "
                    "OpenSCAD .csg) or implicit model (.vm); or --shape / --expr");
    addFieldOptions(cmd, a->field, true);
    addVolumeReadOptions(cmd, a->volume);
    cmd->add_option("--smooth", a->smooth,
                    "Volumes: Gaussian smoothing passes before meshing (OpenVDB filter, width 1), for noisy scans")
        ->check(CLI::Range(0, 20));
    cmd->add_option("--tolerance", a->volume.tolerance,
                    "Volumes: values within this of the minimum are left out of the sparse grid (default 0)");
    cmd->add_flag("--labels", a->labels,
                  "Label map: one closed surface per label (integer value), coloured from --colors");
    cmd->add_option("--colors", a->colors,
                    "Label colours/names: a .lut (768 bytes), an ITK-SNAP or Slicer table, or 'index name r g b' "
                    "lines");
    cmd->add_flag("--split", a->split, "With --labels: one file per label (NAME_LABEL.ext beside -o) as well");
    cmd->add_option("--label-method", a->labelMethod,
                    "With --labels: shared (default: touching labels share every boundary triangle, no gaps or "
                    "overlaps) or mc (marching cubes per label: smoother, 4x fewer triangles, gaps where labels "
                    "meet)")
        ->check(CLI::IsMember({"shared", "mc"}));
    cmd->add_option("-o,--output", a->output,
                    "Mesh file: .ply (binary; --ascii for text), .obj, .stl or .glb (glTF, with vertex colours)")
        ->required();
    cmd->add_option("--grid", a->grid, "Grid name (default: the first level set, else the first float grid)");
    cmd->add_option("--iso", a->iso, "Iso-value (default 0: the zero level set)");
    cmd->add_option("--inside", a->inside,
                    "Which side is solid: below (level sets), above (fog, density, CT) or auto (by grid class)")
        ->check(CLI::IsMember({"auto", "below", "above"}));
    cmd->add_flag("--normals", a->normals, "Write per-vertex normals from the grid gradient");
    cmd->add_option("--crease-angle", a->creaseAngle,
                    "With --normals and feature vertices: where faces meet at more than this many degrees, a vertex "
                    "is written once per side with that side's normal, so renders show crisp creases (default 30; "
                    "180: one normal per vertex)")
        ->check(CLI::Range(0.0, 180.0));
    auto* sharpFlag =
        cmd->add_flag("--sharp", a->sharp,
                      "Feature vertices on sharp edges and corners (Hermite data from the field, or the grid's "
                      "gradient); still closed, manifold, oriented and free of self-intersections. The default for "
                      "OpenSCAD models (.scad, .csg)");
    cmd->add_flag("--no-sharp", a->noSharp,
                  "Plain marching cubes for an OpenSCAD model too: about twice as fast, edges and corners cut by up "
                  "to a voxel")
        ->excludes(sharpFlag);
    cmd->add_option("--max-error", a->maxError,
                    "Simplify: collapse edges while every vertex of the full mesh stays within this distance (world "
                    "units) of the result; closed, manifold, oriented, no self-intersections")
        ->check(CLI::PositiveNumber);
    cmd->add_flag("--index-space", a->indexSpace, "Positions in voxel units instead of world units");
    cmd->add_flag("--ascii", a->ascii, "ASCII PLY instead of binary");
    cmd->add_flag("--stats", a->stats, "Print timings and a topology check of the result");
    auto* memoryOption = cmd->add_option(
        "--memory", a->memory,
        "Stay under this much memory (e.g. 4G, 512M) by meshing in slabs of 128 voxels, each sampled "
        "(or converted) and meshed, and written before the next; the same file as without it. Chosen by "
        "itself when a field's grid would not fit in half of this machine's memory. Volume files are meshed "
        "as they stream, keeping only the blocks near the iso-value, whenever the output is .ply, .obj or "
        ".stl and nothing needs the whole volume (--smooth, --tolerance, --sharp, --max-error); DICOM series "
        "of more than 32 MiB of files and with --memory (their slices come one at a time from the reading "
        "process). .ply, .obj or .stl output (docs/scaling.md)");
    cmd->add_flag("--read-whole", a->readWhole,
                  "Read a volume file whole where it would stream (the same mesh; for comparisons)")
        ->excludes(memoryOption);
    cmd->callback([&c, &g, a] {
        c.run = [&g, a] {
            if (!mesh::isMeshPath(a->output))
                throw CLI::ValidationError("--output", a->output + ": expected a .ply, .obj, .stl or .glb file name");
            using Clock = std::chrono::steady_clock;
            const auto t0 = Clock::now();
            TerminalProgress progress;
            if (a->labels)
                return meshLabels(a->input, a->output, a->colors, a->split, a->labelMethod, a->volume, g, a->ascii);
            if (!a->colors.empty() || a->split)
                throw CLI::ValidationError("--colors", "--colors and --split go with --labels");
            std::uint64_t memoryLimit = 0;
            if (!a->memory.empty()) {
                try {
                    memoryLimit = volume::parseByteSize(a->memory);
                } catch (const std::invalid_argument& e) {
                    throw CLI::ValidationError("--memory", e.what());
                }
            }
            const volume::InsideSide inside = insideSideOf(a->inside);
            // What meshing in slabs needs of the command line (--memory).
            const auto slabJob = [&] {
                SlabMeshJob job;
                job.isovalue = a->iso;
                job.inside = inside;
                job.normals = a->normals;
                job.indexSpace = a->indexSpace;
                job.ascii = a->ascii;
                job.stats = a->stats;
                job.output = a->output;
                job.memoryLimit = memoryLimit;
                job.memoryGiven = !a->memory.empty();
                return job;
            };
            implicit::FieldPtr field;
            openvdb::FloatGrid::Ptr grid;
            if (namesField(a->input, a->field)) {
                if (a->readWhole) throw CLI::ValidationError("--read-whole", "--read-whole takes a volume file");
                implicit::Box3 clip;
                field = makeField(a->input, a->field, clip);
                const volume::SampleOptions so = sampleOptionsFor(*field, clip, a->field);
                if (memoryLimit == 0 && !a->sharp && !(a->maxError > 0) &&
                    mesh::MeshStreamWriter::canStream(a->output) &&
                    volume::estimateSampleBytes(*field, so) > double(volume::physicalMemory() / 2)) {
                    memoryLimit = volume::physicalMemory() / 2;
                    if (!g.quiet)
                        std::printf(
                            "the whole grid would take about %s, more than half of this machine's memory: meshing "
                            "in slabs (as with --memory %s)\n",
                            bytesText(volume::estimateSampleBytes(*field, so)).c_str(),
                            bytesText(double(memoryLimit)).c_str());
                }
                if (memoryLimit > 0) {
                    if (a->sharp || a->maxError > 0)
                        throw CLI::ValidationError(a->sharp ? "--sharp" : "--max-error",
                                                   "feature vertices and simplification work on the whole mesh: not "
                                                   "with --memory");
                    if (!mesh::MeshStreamWriter::canStream(a->output))
                        throw CLI::ValidationError("--memory", "a mesh written in slabs is .ply, .obj or .stl");
                    if (!g.quiet && isOpenScadModel(a->input) && !a->noSharp)
                        std::printf("meshing in slabs: plain marching cubes (feature vertices need the whole mesh)\n");
                    SlabMeshJob job = slabJob();
                    job.field = field;
                    job.what = field->describe();
                    job.sample = so;
                    return meshBySlabsToFile(job, g);
                }
                grid = sampleField(field, so, g, g.quiet ? nullptr : &progress, a->stats);
            } else if (memoryLimit > 0 || (!a->readWhole && volumeStreams(a->input, a->volume, a->smooth, a->sharp,
                                                                          a->maxError > 0, a->output, g))) {
                if (memoryLimit == 0) memoryLimit = volume::physicalMemory() / 2;
                return meshVolumeFileBySlabs(a->input, a->grid, a->volume, a->smooth, a->sharp, a->maxError > 0,
                                             slabJob(), g);
            } else if (isDenseVolumeFile(a->input) && a->smooth == 0 && !(a->volume.tolerance > 0) && !a->sharp) {
                // Read whole (a DICOM series, .glb output, --max-error), but only the blocks near the
                // iso-value become a grid: the same mesh as the whole volume's grid.
                const volume::DenseVolume v = loadVolume(a->input, a->volume, g);
                grid = volumeGridNearLevel(v, a->iso, inside != volume::InsideSide::Below);
            } else {
                grid = loadOrSample(a->input, a->grid, a->field, g, g.quiet ? nullptr : &progress, a->stats, &field,
                                    &a->volume, a->smooth);
            }
            const double readSeconds = std::chrono::duration<double>(Clock::now() - t0).count();

            if (a->maxError > 0 && a->indexSpace)
                throw CLI::ValidationError("--max-error", "--max-error is in world units: not with --index-space");
            volume::SurfaceOptions opt;
            opt.isovalue = a->iso;
            opt.inside = inside;
            opt.normals = a->normals;
            opt.indexSpace = a->indexSpace;
            // OpenSCAD's solids are polyhedra, every edge sharp: feature vertices unless asked not to.
            const bool sharp = a->sharp || (!a->noSharp && field && isOpenScadModel(a->input));
            opt.sharp = sharp;
            opt.maxError = a->maxError;
            opt.progress = g.quiet ? nullptr : &progress;
            volume::SurfaceStats surface;
            const volume::MeshingStats& stats = surface.meshing;
            const volume::SharpenStats& sharpStats = surface.sharpen;
            const mesh::SimplifyStats& simplifyStats = surface.simplify;
            const auto t1 = Clock::now();
            mesh::TriMesh m = volume::meshSurface(*grid, field, opt, &surface);
            const std::size_t fullTriangles = surface.fullTriangles;
            const double meshSeconds = std::chrono::duration<double>(Clock::now() - t1).count();
            if (m.empty())
                std::cerr << "isoforge: warning: no surface at iso " << a->iso << " in grid '" << grid->getName()
                          << "' (values " << (volume::insideIsBelow(*grid, opt.inside) ? "below" : "above")
                          << " the iso are inside); writing an empty mesh\n";
            const auto t2 = Clock::now();
            // Feature vertices make creases: one normal per side there (the mesh stays closed by position).
            const std::size_t creaseCopies = sharp && a->normals ? mesh::splitNormalsAtCreases(m, a->creaseAngle) : 0;
            mesh::writeMesh(a->output, m, {a->ascii});
            const double writeSeconds = std::chrono::duration<double>(Clock::now() - t2).count();
            if (!g.quiet) {
                std::printf("meshed grid '%s' (%s, iso %g, inside %s): %s vertices, %s triangles in %.3f s -> %s\n",
                            grid->getName().c_str(), openvdb::GridBase::gridClassToString(grid->getGridClass()).c_str(),
                            a->iso, volume::insideIsBelow(*grid, opt.inside) ? "below" : "above",
                            withCommas(m.vertexCount()).c_str(), withCommas(m.triangleCount()).c_str(), meshSeconds,
                            a->output.c_str());
            }
            if (sharp && !g.quiet)
                std::printf(
                    "sharp: %s feature vertices (%s beyond their cells), %s crease flips (%s flat patches, %s kept "
                    "as marching cubes made them, %s cells with several patches; %s crossings on the field's zero)\n",
                    withCommas(sharpStats.features).c_str(), withCommas(sharpStats.reached).c_str(),
                    withCommas(sharpStats.flips).c_str(), withCommas(sharpStats.flat).c_str(),
                    withCommas(sharpStats.kept).c_str(), withCommas(sharpStats.sharedCells).c_str(),
                    withCommas(sharpStats.refinedVertices).c_str());
            if (creaseCopies > 0 && !g.quiet)
                std::printf(
                    "normals: %s copies of vertices on creases (faces more than %g degrees apart), one per "
                    "side\n",
                    withCommas(creaseCopies).c_str(), a->creaseAngle);
            if (a->maxError > 0 && !g.quiet)
                std::printf(
                    "simplified within %g: %s -> %s triangles (%s collapses; refused: %s topology, %s turned "
                    "triangles, %s too far, %s crossings)\n",
                    a->maxError, withCommas(fullTriangles).c_str(), withCommas(m.triangleCount()).c_str(),
                    withCommas(simplifyStats.collapses).c_str(), withCommas(simplifyStats.rejectedTopology).c_str(),
                    withCommas(simplifyStats.rejectedFlip).c_str(), withCommas(simplifyStats.rejectedError).c_str(),
                    withCommas(simplifyStats.rejectedCrossing).c_str());
            if (a->stats) {
                std::printf("read/sample %.3f s, mesh %.3f s (setup %.3f, count %.3f, write %.3f), save %.3f s\n",
                            readSeconds, meshSeconds, stats.secondsSetup, stats.secondsCount, stats.secondsWrite,
                            writeSeconds);
                std::printf("leaves %s, blocks visited %s, blocks with surface %s\n", withCommas(stats.leaves).c_str(),
                            withCommas(stats.blocks).c_str(), withCommas(stats.surfaceBlocks).c_str());
                std::cout << mesh::check(
                                 m, {.selfIntersections = sharp || a->maxError > 0, .weldByPosition = creaseCopies > 0})
                                 .toString();
            }
            return 0;
        };
    });
}

}  // namespace isoforge::app

namespace isoforge::app {

void addConvertCommand(CLI::App& app, const GlobalOptions& g, Commands& c) {
    struct Args {
        std::string input, output;
        std::optional<float> background;
        VolumeInput volume;
    };
    auto a = std::make_shared<Args>();
    auto* cmd = app.add_subcommand(
        "convert",
        "Convert a volume (NIfTI, NRRD, MetaImage, DICOM directory, raw, .vdb) to a sparse .vdb or to NIfTI");
    cmd->add_option("input", a->input, "Volume file or DICOM directory")->required();
    cmd->add_option("-o,--output", a->output, "Output: .vdb (sparse, background culled), .nii or .nii.gz")->required();
    cmd->add_option("--background", a->background, "Value left out of the sparse grid (default: the minimum)");
    cmd->add_option("--tolerance", a->volume.tolerance,
                    "Values within this of the background are culled too (default 0: exact)");
    addVolumeReadOptions(cmd, a->volume);
    cmd->callback([&c, &g, a] {
        c.run = [&g, a] {
            std::string out = a->output;
            for (char& ch : out) ch = char(std::tolower(static_cast<unsigned char>(ch)));
            const bool toVdb = out.size() > 4 && out.compare(out.size() - 4, 4, ".vdb") == 0;
            const bool toNifti = (out.size() > 4 && out.compare(out.size() - 4, 4, ".nii") == 0) ||
                                 (out.size() > 7 && out.compare(out.size() - 7, 7, ".nii.gz") == 0);
            if (!toVdb && !toNifti)
                throw CLI::ValidationError("--output", a->output + ": expected a .vdb, .nii or .nii.gz file name");
            std::string ext = std::filesystem::path(a->input).extension().string();
            const volume::DenseVolume v = ext == ".vdb" ? volume::toDense(*volume::readFloatGrid(a->input), a->input)
                                                        : loadVolume(a->input, a->volume, g);
            const auto t0 = std::chrono::steady_clock::now();
            if (toNifti) {
                volume::writeNifti(a->output, v);
                if (!g.quiet)
                    std::printf("wrote NIfTI-1 (float32, sform and qform in RAS) in %.3f s -> %s\n",
                                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
                                a->output.c_str());
                return 0;
            }
            TerminalProgress progress;
            volume::ToGridOptions o;
            o.background = a->background;
            o.tolerance = a->volume.tolerance;
            o.progress = g.quiet ? nullptr : &progress;
            openvdb::FloatGrid::Ptr grid = volume::toGrid(v, o);
            grid->setName("volume");
            volume::writeVdb(a->output, {grid});
            if (!g.quiet) {
                const double dense = double(v.voxelCount()) * 4.0;
                std::printf(
                    "converted %s voxels to a sparse grid: %s active (%.1f%%), %s in memory vs %s dense, "
                    "background %g, in %.3f s -> %s\n",
                    withCommas(v.voxelCount()).c_str(), withCommas(grid->activeVoxelCount()).c_str(),
                    100.0 * double(grid->activeVoxelCount()) / double(v.voxelCount()),
                    (withCommas(grid->memUsage() >> 20) + " MiB").c_str(),
                    (withCommas(std::uint64_t(dense) >> 20) + " MiB").c_str(), double(grid->background()),
                    std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), a->output.c_str());
            }
            return 0;
        };
    });
}

void addVoxelizeCommand(CLI::App& app, const GlobalOptions& g, Commands& c) {
    struct Args {
        std::string input, output;
        float voxel = 0.f, halfWidth = 3.f;
        int resolution = 0;
    };
    auto a = std::make_shared<Args>();
    auto* cmd = app.add_subcommand(
        "voxelize", "Turn a mesh into a narrow-band level set (.vdb): signed if the mesh is closed, unsigned if open");
    cmd->add_option("mesh", a->input, "Mesh file (.ply .obj .stl .off)")->required();
    cmd->add_option("-o,--output", a->output, "Output .vdb file")->required();
    cmd->add_option("--voxel", a->voxel, "Voxel size in world units")->check(CLI::PositiveNumber);
    cmd->add_option("--resolution", a->resolution, "Voxels along the longest side (default 256, if no --voxel)")
        ->check(CLI::PositiveNumber);
    cmd->add_option("--half-width", a->halfWidth, "Narrow band half-width in voxels (default 3)")
        ->check(CLI::Range(1.f, 64.f));
    cmd->callback([&c, &g, a] {
        c.run = [&g, a] {
            if (std::filesystem::path(a->output).extension() != ".vdb")
                throw CLI::ValidationError("--output", a->output + ": expected a .vdb file name");
            const auto t0 = std::chrono::steady_clock::now();
            const mesh::TriMesh m = mesh::readMesh(a->input);
            if (m.empty()) throw IoError(a->input + ": the mesh has no triangles");
            const mesh::Bounds b = mesh::bounds(m);
            volume::VoxelizeOptions vo;
            vo.voxelSize = a->voxel > 0 ? a->voxel
                                        : volume::voxelSizeForResolution(implicit::Box3{b.min, b.max},
                                                                         a->resolution > 0 ? a->resolution : 256);
            vo.halfWidth = a->halfWidth;
            const volume::VoxelizeResult r = volume::voxelize(m, vo);
            if (!r.isSigned)
                std::cerr << "isoforge: warning: " << a->input
                          << " is not closed (boundary or non-manifold edges): wrote an unsigned distance band, "
                             "which has no inside\n";
            volume::writeVdb(a->output, {r.grid});
            if (!g.quiet)
                std::printf("voxelized %s (%s triangles) at voxel %g: %s, %s active voxels in %.2f s -> %s\n",
                            a->input.c_str(), withCommas(m.triangleCount()).c_str(), vo.voxelSize,
                            r.isSigned ? "signed level set" : "unsigned distance",
                            withCommas(r.grid->activeVoxelCount()).c_str(),
                            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
                            a->output.c_str());
            return 0;
        };
    });
}

void addSampleCommand(CLI::App& app, const GlobalOptions& g, Commands& c) {
    struct Args {
        std::string input, output;
        bool stats = false;
        FieldInput field;
    };
    auto a = std::make_shared<Args>();
    auto* cmd = app.add_subcommand("sample", "Sample an implicit field into a sparse OpenVDB grid (.vdb)");
    cmd->add_option("input", a->input, "Scene (.isf, .csg) or implicit model (.vm); or use --shape / --expr");
    cmd->add_option("-o,--output", a->output, "Output .vdb file")->required();
    cmd->add_flag("--stats", a->stats, "Print bounds evaluated and the memory estimate");
    addFieldOptions(cmd, a->field, true);
    cmd->callback([&c, &g, a] {
        c.run = [&g, a] {
            if (std::filesystem::path(a->output).extension() != ".vdb")
                throw CLI::ValidationError("--output", a->output + ": expected a .vdb file name");
            if (!namesField(a->input, a->field))
                throw CLI::ValidationError("input",
                                           "expected a .vm model, --shape or --expr (use 'convert' for volumes)");
            TerminalProgress progress;
            openvdb::FloatGrid::Ptr grid =
                loadOrSample(a->input, "", a->field, g, g.quiet ? nullptr : &progress, a->stats);
            volume::writeVdb(a->output, {grid});
            if (!g.quiet)
                std::printf("wrote %s: %s active voxels -> %s\n", grid->getName().c_str(),
                            withCommas(grid->activeVoxelCount()).c_str(), a->output.c_str());
            return 0;
        };
    });
}

void addSliceCommand(CLI::App& app, const GlobalOptions& g, Commands& c) {
    struct Args {
        std::string input, output, plane = "z=0", axis, colormap = "grey", colors;
        std::vector<float> range{-1.f, 1.f};
        int size = 1024;
        std::int64_t index = -1;
        float window = 0.f, level = 0.f;
        bool sign = false;
        FieldInput field;
        VolumeInput volume;
    };
    auto a = std::make_shared<Args>();
    auto* cmd = app.add_subcommand(
        "slice", "Image a slice of a volume (axial, coronal, sagittal; window/level) or a planar slice of a field");
    cmd->add_option("input", a->input,
                    "Volume (.nii .nrrd .mha .vdb, a DICOM directory, .raw), scene (.isf, .csg) or implicit model "
                    "(.vm); or use --shape / --expr");
    auto* vol = cmd->add_option_group("Volumes");
    vol->add_option("--axis", a->axis, "axial, coronal or sagittal (radiological display: patient left on the right)")
        ->check(CLI::IsMember({"axial", "coronal", "sagittal"}));
    vol->add_option("--index", a->index, "Slice number along that axis (default: the middle one)");
    vol->add_option("--window", a->window, "Window width (e.g. 400 for CT soft tissue; default: the whole range)");
    vol->add_option("--level", a->level, "Window centre (e.g. 40 HU)");
    vol->add_option("--colormap", a->colormap, "grey (default), hot, bone, viridis, or labels (with --colors)")
        ->check(CLI::IsMember({"grey", "hot", "bone", "viridis", "labels"}));
    vol->add_option("--colors", a->colors, "Label colours for --colormap labels");
    addVolumeReadOptions(cmd, a->volume);
    cmd->add_option("-o,--output", a->output, "Image file (.png .jpg .tif .exr)")->required();
    cmd->add_option("--plane", a->plane, "The plane: x=V, y=V or z=V (default z=0)");
    cmd->add_option("--range", a->range, "In-plane range lo,hi of both axes (default -1,1)")
        ->delimiter(',')
        ->expected(2);
    cmd->add_option("--size", a->size, "Pixels per side (default 1024)")->check(CLI::Range(1, 32768));
    cmd->add_flag("--sign", a->sign, "Black inside, white outside (else colour-mapped values with the zero line)");
    addFieldOptions(cmd, a->field, false);
    cmd->callback([&c, &g, a] {
        c.run = [&g, a] {
            std::string vext = std::filesystem::path(a->input).extension().string();
            if (isDenseVolumeFile(a->input) || (!a->axis.empty() && vext == ".vdb")) {
                const volume::DenseVolume v = vext == ".vdb"
                                                  ? volume::toDense(*volume::readFloatGrid(a->input), a->input)
                                                  : loadVolume(a->input, a->volume, g);
                const render::Anatomical view = render::parseAnatomical(a->axis.empty() ? "axial" : a->axis);
                const render::ViewAxes va = render::viewAxes(v, view);
                const std::int64_t n = v.dims[std::size_t(va.slice)];
                const std::int64_t index = a->index >= 0 ? a->index : n / 2;
                if (index >= n)
                    throw CLI::ValidationError("--index", "slice " + std::to_string(index) + " of a volume with " +
                                                              std::to_string(n) + " " +
                                                              (a->axis.empty() ? "axial" : a->axis) + " slices (0.." +
                                                              std::to_string(n - 1) + ")");
                volume::LabelTable table;
                if (!a->colors.empty()) table = volume::readLabelTable(a->colors);
                render::SliceLook look;
                look.wl = {a->window, a->level};
                look.colormap = a->colors.empty() ? a->colormap : "labels";
                look.labels = &table;
                const render::Image img = render::sliceVolume(v, view, index, look);
                render::writeImage(a->output, img);
                if (!g.quiet)
                    std::printf("%s slice %lld of %lld (index axis %c) at %dx%d pixels of %.3g mm -> %s\n",
                                a->axis.empty() ? "axial" : a->axis.c_str(), (long long)index, (long long)n,
                                "ijk"[va.slice], img.width, img.height,
                                std::min(v.spacing()[va.right], v.spacing()[va.down]), a->output.c_str());
                return 0;
            }
            if (!a->axis.empty()) throw CLI::ValidationError("--axis", "--axis slices volume files");
            render::SliceOptions so;
            const std::string& p = a->plane;
            if (p.size() < 3 || (p[0] != 'x' && p[0] != 'y' && p[0] != 'z') || p[1] != '=')
                throw CLI::ValidationError("--plane", "expected x=V, y=V or z=V, found '" + p + "'");
            so.axis = p[0] - 'x';
            try {
                std::size_t used = 0;
                so.offset = std::stof(p.substr(2), &used);
                if (used != p.size() - 2) throw std::invalid_argument(p);
            } catch (const std::exception&) {
                throw CLI::ValidationError("--plane", "expected a number after '" + p.substr(0, 2) + "'");
            }
            so.lo = a->range[0];
            so.hi = a->range[1];
            if (!(so.hi > so.lo)) throw CLI::ValidationError("--range", "expected lo,hi with lo < hi");
            so.size = a->size;
            so.sign = a->sign;
            implicit::Box3 clip;
            FieldInput fin = a->field;
            if (fin.box.empty()) fin.box = {-1e30f, -1e30f, -1e30f, 1e30f, 1e30f, 1e30f};  // a slice needs no bounds
            const implicit::FieldPtr field = makeField(a->input, fin, clip);
            render::SliceStats st;
            const render::Image img = render::sliceField(field, so, &st);
            render::writeImage(a->output, img);
            if (!g.quiet)
                std::printf("sliced %s at %s: %dx%d, %s points evaluated, %s tiles filled by bounds, %.3f s -> %s\n",
                            field->describe().c_str(), p.c_str(), so.size, so.size,
                            withCommas(st.pointsEvaluated).c_str(), withCommas(st.tilesFilled).c_str(), st.seconds,
                            a->output.c_str());
            return 0;
        };
    });
}

void addShapesCommand(CLI::App& app, const GlobalOptions&, Commands& c) {
    auto* cmd = app.add_subcommand("shapes", "List the shapes --shape accepts, with their parameters and defaults");
    cmd->callback([&c] {
        c.run = [] {
            std::printf(
                "Shapes for --shape (named or positional parameters; round shapes have their axis along z):\n%s",
                implicit::shapeHelp().c_str());
            std::printf("Quadric types: ");
            for (const auto& t : implicit::quadricTypes()) std::printf("%s ", t.c_str());
            std::printf("\n");
            return 0;
        };
    });
}

}  // namespace isoforge::app

namespace isoforge::app {

void addCheckSceneCommand(CLI::App& app, const GlobalOptions& g, Commands& c) {
    auto file = std::make_shared<std::string>();
    auto* cmd = app.add_subcommand(
        "check-scene", "Parse a scene (.isf, OpenSCAD .csg or .scad) and report its tree, bounds and warnings");
    auto defines = std::make_shared<std::vector<std::string>>();
    cmd->add_option("scene", *file, "Scene file (.isf, .csg, or .scad through openscad)")->required();
    addDefineOption(cmd, *defines);
    cmd->callback([&c, file, defines] {
        c.run = [file, defines] {
            csg::Scene s = csg::readScene(*file, *defines);
            std::printf("%s: %zu primitives\n%s", file->c_str(), s.primitives, s.tree.c_str());
            const implicit::Box3 b = s.root->bounds();
            if (b.isEmpty())
                std::printf("bounds          empty\n");
            else if (!b.isBounded())
                std::printf("bounds          unbounded\n");
            else
                std::printf("bounds          [%g, %g, %g] .. [%g, %g, %g]\n", b.min.x, b.min.y, b.min.z, b.max.x,
                            b.max.y, b.max.z);
            std::printf("camera          %s\nlights          %zu\n", s.camera.given ? "given" : "automatic",
                        s.lights.size());
            for (const auto& w : s.warnings)
                std::printf("warning: %s: %s\n", w.loc.toString().c_str(), w.message.c_str());
            if (s.warnings.empty()) std::printf("no warnings\n");
            return 0;
        };
    });
}

}  // namespace isoforge::app
