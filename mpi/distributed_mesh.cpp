#include "mpi/distributed_mesh.h"

#include <algorithm>
#include <chrono>
#include <limits>

#include "core/error.h"
#include "mpi/agree.h"

namespace isoforge::mpi {

namespace {

using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point t) {
    return std::chrono::duration<double>(Clock::now() - t).count();
}

/// Meshes the rank's run of slabs, numbered from 0 within the rank.
void meshRun(const SlabSource& source, const volume::SlabOptions& options, const std::vector<std::int64_t>& origins,
             std::size_t count, RankPiece& piece) {
    volume::VolumeView view = source.volume ? volume::VolumeView{source.volume->values.data(), source.volume->dims,
                                                                 source.volume->indexToWorld, source.volume->format}
                                            : volume::VolumeView{};
    volume::ToGridOptions grid;
    if (source.volume) grid.background = source.volume->range().first;  // the whole volume's, on every rank
    openvdb::FloatGrid::Ptr near;
    if (source.file && count > 0) {
        // One pass over the file: the grid of the blocks near the iso-value over the run's x range with
        // its halo (a block column below, two above), and the whole volume's range.
        const std::int64_t x0 = origins[piece.firstSlab] - 8,
                           x1 = origins[piece.firstSlab + count - 1] + options.slabWidth + 16;
        volume::NearLevelOptions no;
        no.level = options.isovalue;
        no.insideAbove = options.inside != volume::InsideSide::Below;  // Auto: a volume's grid says above
        no.xBegin = x0;
        no.xEnd = x1;
        const volume::NearLevelGrid g = volume::nearLevelGrid(*source.file, no);
        near = g.grid;
        piece.secondsRead = g.seconds;
        piece.bytesRead = g.windowBytes + g.gridBytes;
    }
    std::uint64_t local = 0;
    piece.slabs.resize(count);
    for (std::size_t i = 0; i < count; ++i) {
        const std::size_t s = piece.firstSlab + i;
        const std::int64_t x0 = origins[s], x1 = x0 + options.slabWidth;
        SlabPart& part = piece.slabs[i];
        part.vertexBase = local;
        const bool first = s == 0, last = s + 1 == origins.size();
        part.owned =
            source.file ? volume::meshGridSlab(near, options, x0, x1, first, last, local, part.mesh, &piece.stats)
            : source.volume
                ? volume::meshVolumeSlab(view, grid, options, x0, x1, first, last, local, part.mesh, &piece.stats)
                : volume::meshSlab(source.field, options, x0, x1, first, last, local, part.mesh, &piece.stats);
        ++piece.stats.slabs;
        local += part.owned;
        piece.triangles += part.mesh.triangles.size();
    }
    piece.vertices = local;
}

}  // namespace

RankPiece meshRankSlabs(const SlabSource& source, const volume::SlabOptions& options, MPI_Comm comm) {
    int rank = 0, ranks = 1;
    MPI_Comm_rank(comm, &rank);
    MPI_Comm_size(comm, &ranks);
    RankPiece piece;
    // Every rank computes the same partition from the same field: nothing to send.
    std::string error;
    try {
        std::vector<std::int64_t> origins;
        std::vector<std::size_t> begin;
        if (source.volume || source.file) {
            const volume::DenseVolume& h = source.volume ? *source.volume : source.file->header;
            origins = volume::volumeSlabOrigins(volume::VolumeView{nullptr, h.dims, h.indexToWorld, h.format},
                                                options.slabWidth);
            for (int r = 0; r <= ranks; ++r) begin.push_back(origins.size() * static_cast<std::size_t>(r) / ranks);
        } else {
            origins = volume::slabOrigins(*source.field, options.sample, options.slabWidth);
            begin = volume::partitionSlabs(*source.field, options.sample, options.slabWidth, ranks);
        }
        piece.firstSlab = begin[static_cast<std::size_t>(rank)];
        meshRun(source, options, origins, begin[static_cast<std::size_t>(rank) + 1] - piece.firstSlab, piece);
    } catch (const std::exception& e) {  // bad input, out of memory: the job stops together
        error = e.what();
        piece.slabs.clear();
    }
    agree(error, 1, comm);

    // The only exchange: where each rank's vertices and triangles start, and the totals.
    const auto t0 = Clock::now();
    std::uint64_t counts[2] = {piece.vertices, piece.triangles}, before[2] = {0, 0}, totals[2] = {0, 0};
    MPI_Exscan(counts, before, 2, MPI_UINT64_T, MPI_SUM, comm);
    if (rank == 0) before[0] = before[1] = 0;  // MPI_Exscan leaves rank 0's result undefined
    MPI_Allreduce(counts, totals, 2, MPI_UINT64_T, MPI_SUM, comm);
    piece.secondsMpi += secondsSince(t0);
    piece.bytesExchanged += 2 * sizeof counts;
    piece.vertexBase = before[0];
    piece.triangleBase = before[1];
    piece.totalVertices = totals[0];
    piece.totalTriangles = totals[1];
    if (totals[0] > std::numeric_limits<std::uint32_t>::max())
        throw ResourceError("the surface has " + std::to_string(totals[0]) +
                            " vertices, more than 32-bit indices can address");
    // The ghosts of the rank's last slab are the next rank's first vertices: the same numbers on both sides.
    const auto base = static_cast<std::uint32_t>(piece.vertexBase);
    for (SlabPart& part : piece.slabs) {
        part.vertexBase += piece.vertexBase;
        for (glm::uvec3& t : part.mesh.triangles) t += glm::uvec3(base);
    }
    return piece;
}

}  // namespace isoforge::mpi
