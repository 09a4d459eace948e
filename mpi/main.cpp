// isoforge-mpi: meshing across the ranks of an MPI job (OpenMPI). Only argument parsing, the job's
// stages and messages live here; the work is volume/bricked.h's, the output mpi/collective_writer.h's.
#include <chrono>
#include <cstdio>
#include <iostream>

#include <mpi.h>
#include <tbb/global_control.h>
#include <tbb/info.h>

#include "app/field_input.h"
#include "app/malloc_tunables.h"
#include "core/error.h"
#include "core/number_text.h"
#include "mpi/agree.h"
#include "mpi/collective_writer.h"
#include "mpi/distributed_mesh.h"
#include "mpi/pvtp_writer.h"
#include "volume/dense_volume.h"
#include "volume/machine_memory.h"
#include "volume/vdb_io.h"
#include "volume/voxel_source.h"

namespace {

using namespace isoforge;
using Clock = std::chrono::steady_clock;

struct Args {
    std::string input, output, inside = "auto";
    app::FieldInput field;
    float iso = 0.f;
    bool normals = false, indexSpace = false, ascii = false, quiet = false;
    int threads = 0;
};

int runMesh(const Args& a, MPI_Comm comm) {
    int rank = 0, ranks = 1;
    MPI_Comm_rank(comm, &rank);
    MPI_Comm_size(comm, &ranks);
    const auto t0 = Clock::now();
    const bool pvtp = std::filesystem::path(a.output).extension() == ".pvtp";

    // Stage 1: every rank reads the input itself (the same field, or the same volume, on each).
    mpi::SlabSource source;
    volume::DenseVolume dense;
    std::optional<volume::VoxelSource> file;
    std::string what;
    volume::SlabOptions so;
    std::string error;
    int status = 1;
    try {
        if (!pvtp && !mpi::canWriteCollective(a.output)) {
            status = 2;
            throw std::invalid_argument("-o: " + a.output + ": expected a .ply, .obj, .stl or .pvtp file name");
        }
        const std::string ext = std::filesystem::path(a.input).extension().string();
        if (app::namesField(a.input, a.field)) {
            implicit::Box3 clip;
            source.field = app::makeField(a.input, a.field, clip, nullptr, rank == 0);
            what = source.field->describe();
            so.sample.voxelSize = app::voxelSize(*source.field, clip, a.field);
            so.sample.halfWidth = a.field.halfWidth;
            so.sample.clip = clip;
        } else if (!a.input.empty() && volume::isVolumePath(a.input) && ext != ".vdb" && ext != ".raw") {
            // Each rank reads its own slabs' x range in one pass over the file (a DICOM series' slices
            // from a reading helper of its own).
            file = volume::voxelSource(a.input);
            if (file) {
                source.file = &*file;
            } else {
                dense = volume::readVolume(a.input);
                source.volume = &dense;
            }
            what = a.input;
        } else {
            status = 2;
            throw std::invalid_argument(
                "input: give a scene (.isf .csg .scad), a .vm model, --shape, --expr, or a "
                "volume file (NIfTI, NRRD, MetaImage, a DICOM directory)");
        }
        so.isovalue = a.iso;
        so.inside = app::insideSideOf(a.inside);
        so.normals = a.normals;
        so.indexSpace = a.indexSpace;
        so.colors = source.field && !a.indexSpace && !pvtp;
    } catch (const CLI::ValidationError& e) {
        error = e.what();
        status = 2;
    } catch (const std::exception& e) {
        error = e.what();
    }
    mpi::agree(error, status, comm);

    // Stage 2: this rank's slabs (collective at its end).
    const mpi::RankPiece piece = mpi::meshRankSlabs(source, so, comm);
    const double meshSeconds = std::chrono::duration<double>(Clock::now() - t0).count();

    // Stage 3: one file, or one piece per rank and an index.
    const auto t1 = Clock::now();
    if (pvtp) {
        mpi::writePieces(a.output, piece, a.normals, comm);
    } else {
        const std::string temporary = mpi::writeCollective(a.output, piece, {a.ascii, so.colors}, comm);
        mpi::finishCollective(temporary, a.output, true, comm);
    }
    const double writeSeconds = std::chrono::duration<double>(Clock::now() - t1).count();

    // The summary: totals from rank 0's view, the slowest and largest rank.
    double mpiSeconds = piece.secondsMpi, maxMpi = 0;
    unsigned long long peak = volume::peakResidentMemory(), maxPeak = 0, bytes = piece.bytesExchanged, allBytes = 0;
    unsigned long long leaves = piece.stats.leaves, allLeaves = 0;
    MPI_Reduce(&mpiSeconds, &maxMpi, 1, MPI_DOUBLE, MPI_MAX, 0, comm);
    MPI_Reduce(&peak, &maxPeak, 1, MPI_UNSIGNED_LONG_LONG, MPI_MAX, 0, comm);
    MPI_Reduce(&bytes, &allBytes, 1, MPI_UNSIGNED_LONG_LONG, MPI_SUM, 0, comm);
    MPI_Reduce(&leaves, &allLeaves, 1, MPI_UNSIGNED_LONG_LONG, MPI_SUM, 0, comm);
    unsigned long long read = piece.bytesRead, maxRead = 0;
    MPI_Reduce(&read, &maxRead, 1, MPI_UNSIGNED_LONG_LONG, MPI_MAX, 0, comm);
    const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    if (rank == 0 && !a.quiet) {
        std::printf(
            "meshed %s on %d ranks (%d threads each): %s vertices, %s triangles in %.3f s -> %s\n", what.c_str(), ranks,
            static_cast<int>(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism)),
            countText(piece.totalVertices).c_str(), countText(piece.totalTriangles).c_str(), seconds, a.output.c_str());
        std::printf(
            "slabs of %d voxels: %s leaves sampled; mesh %.3f s, write %.3f s; MPI %.3f s, %s bytes exchanged; "
            "peak memory of a rank %s MiB\n",
            so.slabWidth, countText(allLeaves).c_str(), meshSeconds, writeSeconds, maxMpi, countText(allBytes).c_str(),
            countText(maxPeak >> 20).c_str());
        if (source.file)
            std::printf(
                "each rank read the file once, keeping the blocks near the iso-value of its slabs: at most %s MiB "
                "of slices and grid on a rank\n",
                countText(maxRead >> 20).c_str());
    }
    return 0;
}

/// --version: ours, the MPI library's first line, and what malloc was told (the launcher's huge pages).
std::string versionText() {
    char library[MPI_MAX_LIBRARY_VERSION_STRING] = {};
    int length = 0;
    MPI_Get_library_version(library, &length);
    std::string mpi(library, static_cast<std::size_t>(length));
    mpi = mpi.substr(0, mpi.find_first_of(",\n"));
    return "isoforge-mpi " ISOFORGE_VERSION "\n  " + mpi + "\n  malloc: " + app::mallocTunablesText();
}

}  // namespace

int main(int argc, char** argv) {
    MPI_Init(&argc, &argv);
    int rank = 0;
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    CLI::App app{
        "isoforge-mpi: isoforge's meshing across the ranks of an MPI job (mpirun -np N isoforge-mpi mesh ...).\n"
        "The output is the same bytes as 'isoforge mesh' writes, whatever the number of ranks.",
        "isoforge-mpi"};
    app.require_subcommand(1);
    app.fallthrough();
    app.get_formatter()->column_width(36);
    Args a;
    app.set_version_flag("--version", versionText(),
                         "Print the version of isoforge-mpi, its MPI library and malloc's tunables, then exit");
    app.add_flag("-q,--quiet", a.quiet, "No summary; errors only");
    app.add_option("--threads", a.threads, "Worker threads per rank (default: all cores)")->check(CLI::PositiveNumber);
    app.footer("Exit status: 0 success, 1 bad input or a failed rank (message on stderr), 2 usage error.");
    auto* mesh = app.add_subcommand("mesh", "Sample a field in slabs spread over the ranks and mesh it");
    mesh->add_option(
        "input", a.input,
        "Scene (.isf, OpenSCAD .csg or .scad), implicit model (.vm), or volume (.nii/.nii.gz, .nrrd/.nhdr, "
        ".mha/.mhd, a DICOM directory: every rank reads it); or --shape / --expr");
    app::addFieldOptions(mesh, a.field, true);
    mesh->add_option("-o,--output", a.output,
                     "One mesh file (.ply, .obj, .stl), the same bytes as isoforge mesh's; or .pvtp: one .vtp piece "
                     "per rank beside it and a ParaView index")
        ->required();
    mesh->add_option("--iso", a.iso, "Iso-value (default 0)");
    mesh->add_option("--inside", a.inside, "Which side is solid: below, above or auto")
        ->check(CLI::IsMember({"auto", "below", "above"}));
    mesh->add_flag("--normals", a.normals, "Write per-vertex normals from the grid gradient");
    mesh->add_flag("--index-space", a.indexSpace, "Positions in voxel units instead of world units");
    mesh->add_flag("--ascii", a.ascii, "ASCII PLY instead of binary");
    bool noSharp = false;
    mesh->add_flag("--no-sharp", noSharp,
                   "Accepted as isoforge mesh takes it: isoforge-mpi always meshes plain marching cubes (feature "
                   "vertices need the whole mesh), OpenSCAD models too");

    int status = 0;
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        if (rank == 0) {
            if (e.get_exit_code() == 0) {
                app.exit(e);
            } else {
                std::cerr << "isoforge-mpi: " << e.what() << "\nRun 'isoforge-mpi --help' for usage.\n";
            }
        }
        status = e.get_exit_code() == 0 ? 0 : 2;
        MPI_Finalize();
        return status;
    }
    std::optional<tbb::global_control> threadLimit;
    if (a.threads > 0) threadLimit.emplace(tbb::global_control::max_allowed_parallelism, a.threads);
    volume::initializeOpenVdb();
    try {
        status = runMesh(a, MPI_COMM_WORLD);
    } catch (const mpi::RankFailure& e) {
        if (e.onThisRank) std::cerr << "isoforge-mpi: rank " << rank << ": " << e.what() << "\n";
        status = e.exitStatus;
    } catch (const std::exception& e) {  // the same on every rank (a count too large for 32 bits)
        if (rank == 0) std::cerr << "isoforge-mpi: " << e.what() << "\n";
        status = 1;
    }
    MPI_Finalize();
    return status;
}
