#include "app/mesh_slabs.h"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include "app/volume_input.h"
#include "core/error.h"
#include "core/number_text.h"
#include "core/progress.h"
#include "mesh/stream_writer.h"
#include "volume/bricked.h"
#include "volume/dense_grid.h"
#include "volume/machine_memory.h"
#include "volume/near_level.h"

namespace isoforge::app {

namespace {
std::string mebibytes(std::uint64_t bytes) {
    return withCommas((bytes + (1u << 19)) >> 20) + " MiB";
}
}  // namespace

int meshBySlabsToFile(const SlabMeshJob& job, const GlobalOptions& g) {
    using Clock = std::chrono::steady_clock;
    const auto t0 = Clock::now();
    // What the process holds already (code, libraries, the scene) is not the slabs' to spend; of the
    // rest, half goes to a slab's grid and the other half to its mesh, the mesher's scratch and the
    // writer's buffers.
    const std::uint64_t base = volume::residentMemory();
    constexpr std::uint64_t kMinimum = std::uint64_t{64} << 20;
    if (job.memoryLimit < base + kMinimum)
        throw ResourceError("--memory " + mebibytes(job.memoryLimit) + " leaves nothing to mesh with: isoforge holds " +
                            mebibytes(base) + " before it starts; give at least " + mebibytes(base + kMinimum));
    // A volume file: thirteen of its slices are held while it streams past, and of the rest a third goes to
    // the grid of a run of slabs (the blocks near the iso-value); the rest is a slab's mesh, the mesher's
    // scratch and the writer's buffers, which for CT come to about twice the slab's grid.
    const std::uint64_t window = job.source ? volume::nearLevelWindowBytes(*job.source) : 0;
    if (job.source && base + window + kMinimum > job.memoryLimit) {
        const auto& d = job.source->header.dims;
        throw ResourceError(job.what + ": reading it holds 13 slices of " + std::to_string(d[0]) + " x " +
                            std::to_string(d[1]) + " voxels (" + mebibytes(window) + "), and --memory " +
                            mebibytes(job.memoryLimit) + " leaves " + mebibytes(job.memoryLimit - base) +
                            " beyond what isoforge holds already: raise --memory to at least " +
                            mebibytes(base + window + kMinimum));
    }
    const std::uint64_t gridBudget = (job.memoryLimit - base - window) / 3;
    // The mesh goes to disk, twice over (scratch files, then the file): refuse what the disk cannot take.
    const double perVertex = 12.0 * (1 + job.normals) + 3 + 2 * 13.0;  // PLY: a vertex, two faces
    const double diskBytes = job.field ? 2 * volume::estimateSurfaceVoxels(*job.field, job.sample) * perVertex : 0;
    std::filesystem::path dir = std::filesystem::absolute(job.output).parent_path();
    std::error_code ec;
    const std::filesystem::space_info space = std::filesystem::space(dir, ec);
    if (!ec && diskBytes > static_cast<double>(space.available))
        throw ResourceError("meshing " + job.what + " at voxel size " + std::to_string(job.sample.voxelSize) +
                            " in slabs would need about " + bytesText(diskBytes) +
                            " of disk for the mesh and its scratch files; " + dir.string() + " has " +
                            bytesText(static_cast<double>(space.available)) +
                            " free. Use a larger voxel size or a lower resolution.");
    volume::SlabOptions so;
    so.sample = job.sample;
    so.sample.memoryLimit = (job.memoryLimit - base) / 2;
    so.isovalue = job.isovalue;
    so.inside = job.inside;
    so.normals = job.normals;
    so.indexSpace = job.indexSpace;
    so.colors = job.field && !job.indexSpace;
    TerminalProgress progress;
    so.progress = g.quiet ? nullptr : &progress;

    mesh::StreamOptions wo;
    wo.ascii = job.ascii;
    wo.normals = job.normals;
    wo.colors = so.colors;
    mesh::MeshStreamWriter writer(job.output, wo);
    volume::SlabStats st;
    volume::SourceSlabStats read;
    const auto sink = [&](const volume::SlabPiece& p) {
        const std::span<const glm::vec3> pos(p.mesh.positions);
        writer.addVertices(
            pos.first(p.owned),
            so.normals ? std::span<const glm::vec3>(p.mesh.normals).first(p.owned) : std::span<const glm::vec3>(),
            p.mesh.colors);
        writer.addTriangles(p.mesh.triangles,
                            [&](std::uint32_t v) -> const glm::vec3& { return p.mesh.positions[v - p.vertexBase]; });
    };
    try {
        if (job.field) {
            volume::meshBySlabs(job.field, so, sink, &st);
        } else if (job.source) {
            volume::meshVolumeSourceBySlabs(*job.source, so, gridBudget, sink, &st, &read);
        } else if (job.volume) {
            volume::ToGridOptions go;
            go.background = job.volume->range().first;  // as the whole volume's grid has it
            volume::meshVolumeBySlabs(volume::VolumeView{job.volume->values.data(), job.volume->dims,
                                                         job.volume->indexToWorld, job.volume->format},
                                      go, so, sink, &st);
        } else {
            volume::meshGridBySlabs(*job.grid, so, sink, &st);
        }
    } catch (const ResourceError& e) {
        if (std::string(e.what()).find("outgrew") == std::string::npos) throw;
        const bool file = job.source != nullptr;
        throw ResourceError("a slab of " + job.what + " (" + std::to_string(so.slabWidth) +
                            " voxels thick) holds more surface than --memory " + mebibytes(job.memoryLimit) +
                            " allows (its grid" + (file ? " near the iso-value" : "") + " outgrew its share, " +
                            bytesText(double(file ? gridBudget : so.sample.memoryLimit)) + "): raise --memory" +
                            (file ? "" : " or the voxel size"));
    }
    const auto t1 = Clock::now();
    writer.commit();
    const double writeSeconds = std::chrono::duration<double>(Clock::now() - t1).count();
    const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    if (writer.triangleCount() == 0)
        std::cerr << "isoforge: warning: no surface in " << job.what << "; writing an empty mesh\n";
    if (!g.quiet && job.source) {
        std::printf(
            "%s, in %s pass%s over the file%s (%s of slices and a grid of %s near the iso-value held) in %.3f s\n",
            readSummary(job.what, job.source->header, read.range).c_str(), withCommas(read.passes).c_str(),
            read.passes == 1 ? "" : "es", job.source->header.files > 1 ? "s" : "", mebibytes(read.windowBytes).c_str(),
            mebibytes(read.gridBytes).c_str(), read.secondsRead);
    }
    if (!g.quiet) {
        std::printf("meshed %s in %s slab%s of %d voxels: %s vertices, %s triangles in %.3f s -> %s\n",
                    job.what.c_str(), withCommas(st.slabs).c_str(), st.slabs == 1 ? "" : "s", so.slabWidth,
                    withCommas(writer.vertexCount()).c_str(), withCommas(writer.triangleCount()).c_str(), seconds,
                    job.output.c_str());
        const std::string limit = job.memoryGiven
                                      ? "limit " + mebibytes(job.memoryLimit)
                                      : "within half of this machine's memory, " + mebibytes(job.memoryLimit);
        std::printf("peak memory %s (%s; the largest slab %s)\n", mebibytes(volume::peakResidentMemory()).c_str(),
                    limit.c_str(), mebibytes(st.maxSlabBytes).c_str());
    }
    if (job.stats)
        std::printf("sample %.3f s, mesh %.3f s, hand on %.3f s, write %.3f s; %s leaves\n", st.secondsSample,
                    st.secondsMesh, st.secondsSink, writeSeconds, withCommas(st.leaves).c_str());
    return 0;
}

}  // namespace isoforge::app
