#include "mpi/collective_writer.h"

#include <unistd.h>
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <span>
#include <vector>

#include "core/atomic_file.h"
#include "core/error.h"
#include "mesh/records.h"
#include "mpi/agree.h"

namespace isoforge::mpi {

namespace {

std::string lowerExtension(const std::string& path) {
    std::string e = std::filesystem::path(path).extension().string();
    for (char& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return e;
}

/// Writes each rank's `bytes` after those of the ranks before it, from `offset`; returns the
/// offset after the whole section (the same on every rank). A failed write is noted in `error`.
MPI_Offset writeSection(MPI_File file, MPI_Offset offset, const std::string& bytes, MPI_Comm comm,
                        const std::string& path, std::string& error) {
    std::uint64_t mine = bytes.size(), before = 0, total = 0;
    int rank = 0;
    MPI_Comm_rank(comm, &rank);
    MPI_Exscan(&mine, &before, 1, MPI_UINT64_T, MPI_SUM, comm);
    if (rank == 0) before = 0;
    MPI_Allreduce(&mine, &total, 1, MPI_UINT64_T, MPI_SUM, comm);
    constexpr std::size_t kMaxWrite = std::size_t{1} << 30;  // MPI counts are int
    for (std::size_t done = 0; done < bytes.size();) {
        const std::size_t n = std::min(kMaxWrite, bytes.size() - done);
        MPI_Status status;
        if (error.empty() &&
            MPI_File_write_at(file, offset + static_cast<MPI_Offset>(before + done), bytes.data() + done,
                              static_cast<int>(n), MPI_BYTE, &status) != MPI_SUCCESS)
            error = path + ": write failed on rank " + std::to_string(rank) + " (disk full?)";
        done += n;
    }
    return offset + static_cast<MPI_Offset>(total);
}

}  // namespace

bool canWriteCollective(const std::string& path) {
    const std::string e = lowerExtension(path);
    return e == ".ply" || e == ".obj" || e == ".stl";
}

std::string writeCollective(const std::string& path, const RankPiece& piece, const CollectiveWriteOptions& options,
                            MPI_Comm comm) {
    int rank = 0;
    MPI_Comm_rank(comm, &rank);
    const std::string ext = lowerExtension(path);
    const mesh::TriMesh& m = piece.mesh;
    const std::span<const glm::vec3> positions = std::span(m.positions).first(piece.owned);
    const std::span<const glm::vec3> normals =
        m.normals.empty() ? std::span<const glm::vec3>() : std::span(m.normals).first(piece.owned);

    // Colours are kept only if some vertex of the whole mesh is not white.
    int anyColor = 0, anyColorAll = 0;
    if (options.colors)
        anyColor =
            std::any_of(m.colors.begin(), m.colors.end(), [](const glm::vec3& c) { return c != glm::vec3(1.f); });
    MPI_Allreduce(&anyColor, &anyColorAll, 1, MPI_INT, MPI_LOR, comm);
    const bool colors = options.colors && anyColorAll;

    // A temporary name beside the target, from rank 0's process id.
    const std::filesystem::path target(path);
    long pid = rank == 0 ? static_cast<long>(::getpid()) : 0;
    MPI_Bcast(&pid, 1, MPI_LONG, 0, comm);
    const std::string temporary =
        (target.parent_path() / ("." + target.filename().string() + ".mpi-" + std::to_string(pid) + ".tmp")).string();
    MPI_File file;
    if (MPI_File_open(comm, temporary.c_str(), MPI_MODE_CREATE | MPI_MODE_WRONLY, MPI_INFO_NULL, &file) != MPI_SUCCESS)
        throw IoError(path + ": cannot create '" + temporary + "'");  // collective: every rank sees it
    MPI_File_set_size(file, 0);

    std::string bytes, error;
    MPI_Offset offset = 0;
    auto section = [&](auto&& fill) {
        bytes.clear();
        try {
            fill(bytes);
        } catch (const std::exception& e) {  // out of memory: the rank still takes part, with nothing
            if (error.empty()) error = path + ": rank " + std::to_string(rank) + ": " + e.what();
            bytes.clear();
        }
        offset = writeSection(file, offset, bytes, comm, path, error);
    };
    {
        if (ext == ".ply") {
            section([&](std::string& b) {
                if (rank == 0)
                    b = mesh::records::plyHeader(piece.totalVertices, piece.totalTriangles, !normals.empty(), colors,
                                                 options.ascii);
            });
            section([&](std::string& b) {
                mesh::records::appendPlyVertices(
                    b, positions, normals, colors ? std::span<const glm::vec3>(m.colors) : std::span<const glm::vec3>(),
                    options.ascii);
            });
            section([&](std::string& b) { mesh::records::appendPlyFaces(b, m.triangles, options.ascii); });
        } else if (ext == ".obj") {
            section([&](std::string& b) {
                if (rank == 0) b = mesh::records::kObjHeader;
            });
            section([&](std::string& b) { mesh::records::appendObjPositions(b, positions); });
            if (!normals.empty()) section([&](std::string& b) { mesh::records::appendObjNormals(b, normals); });
            section([&](std::string& b) { mesh::records::appendObjFaces(b, m.triangles, !normals.empty()); });
        } else if (ext == ".stl") {
            if (piece.totalTriangles > 0xFFFFFFFFull) {  // the same on every rank
                MPI_File_close(&file);
                throw IoError(path + ": binary STL holds at most 4,294,967,295 triangles");
            }
            section([&](std::string& b) {
                if (rank == 0) b = mesh::records::stlHeader(static_cast<std::uint32_t>(piece.totalTriangles));
            });
            section([&](std::string& b) {
                mesh::records::appendStlTriangles(b, m.triangles, [&](std::uint32_t v) -> const glm::vec3& {
                    return m.positions[v - piece.vertexBase];
                });
            });
        } else {
            MPI_File_close(&file);
            throw IoError(path + ": isoforge-mpi writes .ply, .obj, .stl or .pvtp");  // the same on every rank
        }
    }
    MPI_File_close(&file);
    try {
        agree(error, 1, comm);
    } catch (...) {
        finishCollective(temporary, path, false, comm);
        throw;
    }
    return temporary;
}

void finishCollective(const std::string& temporary, const std::string& path, bool success, MPI_Comm comm) {
    int rank = 0;
    MPI_Comm_rank(comm, &rank);
    MPI_Barrier(comm);
    if (rank == 0) {
        std::error_code ec;
        if (success)
            std::filesystem::rename(temporary, path, ec);
        else
            std::filesystem::remove(temporary, ec);
    }
    MPI_Barrier(comm);
}

void writePieces(const std::string& pvtpPath, const RankPiece& piece, bool normals, MPI_Comm comm) {
    int rank = 0, ranks = 1;
    MPI_Comm_rank(comm, &rank);
    MPI_Comm_size(comm, &ranks);
    const std::filesystem::path index(pvtpPath);
    auto pieceName = [&](int r) { return index.stem().string() + "_" + std::to_string(r) + ".vtp"; };
    // This rank's piece: its vertices and ghosts, its triangles numbered from 0.
    const mesh::TriMesh& m = piece.mesh;
    std::string x =
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"0.1\" byte_order=\"LittleEndian\">\n"
        "  <PolyData>\n    <Piece NumberOfPoints=\"" +
        std::to_string(m.positions.size()) +
        "\" NumberOfVerts=\"0\" NumberOfLines=\"0\" NumberOfStrips=\"0\" NumberOfPolys=\"" +
        std::to_string(m.triangles.size()) + "\">\n";
    char buf[128];
    auto floats = [&](const std::vector<glm::vec3>& v, const char* name) {
        x += std::string("        <DataArray type=\"Float32\"") + (name ? " Name=\"" + std::string(name) + "\"" : "") +
             " NumberOfComponents=\"3\" format=\"ascii\">\n";
        for (const glm::vec3& p : v) x.append(buf, std::snprintf(buf, sizeof buf, "%.9g %.9g %.9g\n", p.x, p.y, p.z));
        x += "        </DataArray>\n";
    };
    if (normals) {
        x += "      <PointData Normals=\"Normals\">\n";
        floats(m.normals, "Normals");
        x += "      </PointData>\n";
    }
    x += "      <Points>\n";
    floats(m.positions, nullptr);
    x += "      </Points>\n      <Polys>\n        <DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n";
    for (const glm::uvec3& t : m.triangles)
        x.append(buf, std::snprintf(buf, sizeof buf, "%llu %llu %llu\n",
                                    static_cast<unsigned long long>(t.x - piece.vertexBase),
                                    static_cast<unsigned long long>(t.y - piece.vertexBase),
                                    static_cast<unsigned long long>(t.z - piece.vertexBase)));
    x += "        </DataArray>\n        <DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n";
    for (std::size_t i = 0; i < m.triangles.size(); ++i)
        x.append(buf, std::snprintf(buf, sizeof buf, "%zu\n", 3 * (i + 1)));
    x += "        </DataArray>\n      </Polys>\n    </Piece>\n  </PolyData>\n</VTKFile>\n";
    std::string error;
    try {
        AtomicFile out(index.parent_path() / pieceName(rank));
        out.write(x);
        out.commit();
    } catch (const std::exception& e) {
        error = e.what();
    }
    agree(error, 1, comm);
    if (rank != 0) return;
    std::string p =
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"PPolyData\" version=\"0.1\" byte_order=\"LittleEndian\">\n"
        "  <PPolyData GhostLevel=\"0\">\n";
    if (normals)
        p += "    <PPointData Normals=\"Normals\">\n      <PDataArray type=\"Float32\" Name=\"Normals\" "
             "NumberOfComponents=\"3\"/>\n    </PPointData>\n";
    p += "    <PPoints>\n      <PDataArray type=\"Float32\" NumberOfComponents=\"3\"/>\n    </PPoints>\n";
    for (int r = 0; r < ranks; ++r) p += "    <Piece Source=\"" + pieceName(r) + "\"/>\n";
    p += "  </PPolyData>\n</VTKFile>\n";
    AtomicFile out2(index);
    out2.write(p);
    out2.commit();
}

}  // namespace isoforge::mpi
