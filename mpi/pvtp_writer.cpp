#include "mpi/pvtp_writer.h"

#include <cstdint>
#include <filesystem>
#include <vector>

#include "core/atomic_file.h"
#include "mpi/agree.h"

namespace isoforge::mpi {

namespace {

/// The vertices of the piece: every slab's own, and the ghosts of the rank's last slab.
std::size_t pieceVertices(const RankPiece& piece, std::size_t i) {
    const SlabPart& s = piece.slabs[i];
    return i + 1 == piece.slabs.size() ? s.mesh.positions.size() : s.owned;
}

void writePiece(const std::filesystem::path& path, const RankPiece& piece, bool normals) {
    std::uint64_t points = 0;
    for (std::size_t i = 0; i < piece.slabs.size(); ++i) points += pieceVertices(piece, i);
    const std::uint64_t polys = piece.triangles;
    // Appended blocks, each a UInt64 length and the bytes; offsets count from the first block.
    const std::uint64_t pointBytes = 12 * points, connectivityBytes = 24 * polys, offsetBytes = 8 * polys;
    std::uint64_t at = 0;
    auto block = [&](std::uint64_t bytes) {
        const std::uint64_t o = at;
        at += 8 + bytes;
        return std::to_string(o);
    };
    std::string xml =
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" "
        "header_type=\"UInt64\">\n  <PolyData>\n    <Piece NumberOfPoints=\"" +
        std::to_string(points) + "\" NumberOfVerts=\"0\" NumberOfLines=\"0\" NumberOfStrips=\"0\" NumberOfPolys=\"" +
        std::to_string(polys) + "\">\n";
    if (normals)
        xml +=
            "      <PointData Normals=\"Normals\">\n        <DataArray type=\"Float32\" Name=\"Normals\" "
            "NumberOfComponents=\"3\" format=\"appended\" offset=\"" +
            block(pointBytes) + "\"/>\n      </PointData>\n";
    xml +=
        "      <Points>\n        <DataArray type=\"Float32\" NumberOfComponents=\"3\" format=\"appended\" offset=\"" +
        block(pointBytes) + "\"/>\n      </Points>\n      <Polys>\n";
    xml += "        <DataArray type=\"Int64\" Name=\"connectivity\" format=\"appended\" offset=\"" +
           block(connectivityBytes) + "\"/>\n";
    xml += "        <DataArray type=\"Int64\" Name=\"offsets\" format=\"appended\" offset=\"" + block(offsetBytes) +
           "\"/>\n      </Polys>\n    </Piece>\n  </PolyData>\n  <AppendedData encoding=\"raw\">\n   _";

    AtomicFile out(path);
    out.write(xml);
    auto length = [&](std::uint64_t bytes) { out.write(&bytes, 8); };
    auto vectors = [&](bool ofNormals) {
        length(pointBytes);
        for (std::size_t i = 0; i < piece.slabs.size(); ++i) {
            const std::vector<glm::vec3>& v = ofNormals ? piece.slabs[i].mesh.normals : piece.slabs[i].mesh.positions;
            out.write(v.data(), 12 * pieceVertices(piece, i));
        }
    };
    if (normals) vectors(true);
    vectors(false);
    length(connectivityBytes);
    std::vector<std::int64_t> buf;
    for (const SlabPart& s : piece.slabs) {
        buf.clear();
        for (const glm::uvec3& t : s.mesh.triangles)
            for (int k = 0; k < 3; ++k) buf.push_back(std::int64_t{t[k]} - std::int64_t(piece.vertexBase));
        out.write(buf.data(), 8 * buf.size());
    }
    length(offsetBytes);
    std::int64_t offset = 0;
    for (const SlabPart& s : piece.slabs) {
        buf.clear();
        for (std::size_t i = 0; i < s.mesh.triangles.size(); ++i) buf.push_back(offset += 3);
        out.write(buf.data(), 8 * buf.size());
    }
    out.write("\n  </AppendedData>\n</VTKFile>\n");
    out.commit();
}

}  // namespace

void writePieces(const std::string& pvtpPath, const RankPiece& piece, bool normals, MPI_Comm comm) {
    int rank = 0, ranks = 1;
    MPI_Comm_rank(comm, &rank);
    MPI_Comm_size(comm, &ranks);
    const std::filesystem::path index(pvtpPath);
    auto pieceName = [&](int r) { return index.stem().string() + "_" + std::to_string(r) + ".vtp"; };
    std::string error;
    try {
        writePiece(index.parent_path() / pieceName(rank), piece, normals);
    } catch (const std::exception& e) {
        error = e.what();
    }
    agree(error, 1, comm);
    if (rank != 0) return;
    std::string p =
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"PPolyData\" version=\"1.0\" byte_order=\"LittleEndian\" "
        "header_type=\"UInt64\">\n  <PPolyData GhostLevel=\"0\">\n";
    if (normals)
        p += "    <PPointData Normals=\"Normals\">\n      <PDataArray type=\"Float32\" Name=\"Normals\" "
             "NumberOfComponents=\"3\"/>\n    </PPointData>\n";
    p += "    <PPoints>\n      <PDataArray type=\"Float32\" NumberOfComponents=\"3\"/>\n    </PPoints>\n";
    for (int r = 0; r < ranks; ++r) p += "    <Piece Source=\"" + pieceName(r) + "\"/>\n";
    p += "  </PPolyData>\n</VTKFile>\n";
    AtomicFile out(index);
    out.write(p);
    out.commit();
}

}  // namespace isoforge::mpi
