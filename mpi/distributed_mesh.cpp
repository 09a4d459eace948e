#include "mpi/distributed_mesh.h"

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
/// Meshes the rank's run of slabs into piece.mesh; returns the number of vertices it owns.
std::uint64_t meshRun(const implicit::FieldPtr& field, const volume::SlabOptions& options,
                      const std::vector<std::int64_t>& origins, RankPiece& piece) {
    mesh::TriMesh& all = piece.mesh;
    mesh::TriMesh slab;
    std::uint64_t local = 0;
    for (std::size_t s = piece.firstSlab; s < piece.firstSlab + piece.slabs; ++s) {
        const std::int64_t x0 = origins[s], x1 = x0 + options.slabWidth;
        const std::size_t owned =
            volume::meshSlab(field, options, x0, x1, s == 0, s + 1 == origins.size(), local, slab, &piece.stats);
        ++piece.stats.slabs;
        const bool lastOfRun = s + 1 == piece.firstSlab + piece.slabs;
        const std::size_t keep = lastOfRun ? slab.positions.size() : owned;
        all.positions.insert(all.positions.end(), slab.positions.begin(), slab.positions.begin() + keep);
        if (options.normals) all.normals.insert(all.normals.end(), slab.normals.begin(), slab.normals.begin() + keep);
        all.colors.insert(all.colors.end(), slab.colors.begin(), slab.colors.end());
        all.triangles.insert(all.triangles.end(), slab.triangles.begin(), slab.triangles.end());
        local += owned;
    }
    return local;
}

}  // namespace

RankPiece meshRankSlabs(const implicit::FieldPtr& field, const volume::SlabOptions& options, MPI_Comm comm) {
    int rank = 0, ranks = 1;
    MPI_Comm_rank(comm, &rank);
    MPI_Comm_size(comm, &ranks);
    RankPiece piece;
    // Every rank computes the same partition from the same field: nothing to send.
    const std::vector<std::int64_t> origins = volume::slabOrigins(*field, options.sample, options.slabWidth);
    const std::vector<std::size_t> begin = volume::partitionSlabs(*field, options.sample, options.slabWidth, ranks);
    piece.firstSlab = begin[static_cast<std::size_t>(rank)];
    piece.slabs = begin[static_cast<std::size_t>(rank) + 1] - piece.firstSlab;

    // The run's slabs, numbered from 0 here; the ghosts of the last are the next rank's first vertices.
    mesh::TriMesh& all = piece.mesh;
    std::uint64_t local = 0;
    std::string error;
    try {
        local = meshRun(field, options, origins, piece);
    } catch (const std::exception& e) {  // bad input, out of memory: the job stops together
        error = e.what();
        all = {};
    }
    agree(error, 1, comm);
    piece.owned = static_cast<std::size_t>(local);

    // The only exchange: where each rank's vertices and triangles start, and the totals.
    const auto t0 = Clock::now();
    std::uint64_t counts[2] = {local, all.triangles.size()}, before[2] = {0, 0}, totals[2] = {0, 0};
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
    const auto base = static_cast<std::uint32_t>(piece.vertexBase);
    for (glm::uvec3& t : all.triangles) t += glm::uvec3(base);
    return piece;
}

}  // namespace isoforge::mpi
