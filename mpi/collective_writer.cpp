#include "mpi/collective_writer.h"

#include <unistd.h>
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <limits>
#include <span>
#include <vector>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/temporary_files.h"
#include "mesh/records.h"
#include "mesh/stream_writer.h"
#include "mpi/agree.h"

namespace isoforge::mpi {

namespace {

int temporarySlot = -1;  ///< the collective file being written, removed on SIGTERM

std::string lowerExtension(const std::string& path) {
    std::string e = std::filesystem::path(path).extension().string();
    for (char& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return e;
}

/// Writes the file's sections: in each, every rank's bytes follow those of the ranks before it.
class Sections {
public:
    Sections(MPI_File file, MPI_Comm comm, std::string path) : file_(file), comm_(comm), path_(std::move(path)) {
        MPI_Comm_rank(comm_, &rank_);
    }
    using Emit = std::function<void(const std::string&)>;

    /// `mine`: this rank's bytes in the section; `produce(emit)` emits exactly them, in order.
    void section(std::uint64_t mine, const std::function<void(const Emit&)>& produce) {
        std::uint64_t before = 0, total = 0;
        MPI_Exscan(&mine, &before, 1, MPI_UINT64_T, MPI_SUM, comm_);
        if (rank_ == 0) before = 0;
        MPI_Allreduce(&mine, &total, 1, MPI_UINT64_T, MPI_SUM, comm_);
        std::uint64_t done = 0;
        try {
            produce([&](const std::string& bytes) {
                write(offset_ + static_cast<MPI_Offset>(before + done), bytes);
                done += bytes.size();
            });
        } catch (const std::exception& e) {  // out of memory: the rank still takes part in what follows
            if (error_.empty()) error_ = path_ + ": rank " + std::to_string(rank_) + ": " + e.what();
        }
        if (done != mine && error_.empty())
            error_ = path_ + ": rank " + std::to_string(rank_) + " wrote " + std::to_string(done) + " bytes of " +
                     std::to_string(mine) + " (internal error)";
        offset_ += static_cast<MPI_Offset>(total);
    }
    /// A section whose length is known only once formatted (ASCII): formatted whole, then written.
    void formatted(const std::function<void(std::string&)>& fill) {
        std::string bytes;
        try {
            fill(bytes);
        } catch (const std::exception& e) {
            if (error_.empty()) error_ = path_ + ": rank " + std::to_string(rank_) + ": " + e.what();
            bytes.clear();
        }
        section(bytes.size(), [&](const Emit& emit) { emit(bytes); });
    }
    const std::string& error() const { return error_; }

private:
    void write(MPI_Offset at, const std::string& bytes) {
        constexpr std::size_t kMaxWrite = std::size_t{1} << 30;  // MPI counts are int
        for (std::size_t done = 0; done < bytes.size() && error_.empty();) {
            const std::size_t n = std::min(kMaxWrite, bytes.size() - done);
            MPI_Status status;
            if (MPI_File_write_at(file_, at + static_cast<MPI_Offset>(done), bytes.data() + done, static_cast<int>(n),
                                  MPI_BYTE, &status) != MPI_SUCCESS)
                error_ = path_ + ": write failed on rank " + std::to_string(rank_) + " (disk full?)";
            done += n;
        }
    }
    MPI_File file_;
    MPI_Comm comm_;
    std::string path_, error_;
    int rank_ = 0;
    MPI_Offset offset_ = 0;
};

std::span<const glm::vec3> ownedOf(const std::vector<glm::vec3>& v, std::size_t owned) {
    return v.empty() ? std::span<const glm::vec3>() : std::span(v).first(owned);
}

}  // namespace

bool canWriteCollective(const std::string& path) {
    return mesh::MeshStreamWriter::canStream(path);  // the same formats: records written in order
}

std::string writeCollective(const std::string& path, const RankPiece& piece, const CollectiveWriteOptions& options,
                            MPI_Comm comm) {
    int rank = 0;
    MPI_Comm_rank(comm, &rank);
    const std::string ext = lowerExtension(path);
    const bool normals = !piece.slabs.empty() && !piece.slabs.front().mesh.normals.empty();
    int anyNormals = normals, hasNormals = 0;
    MPI_Allreduce(&anyNormals, &hasNormals, 1, MPI_INT, MPI_LOR, comm);  // a rank without slabs cannot tell

    // Colours are kept only if some vertex of the whole mesh is not white.
    int anyColor = 0, anyColorAll = 0;
    if (options.colors)
        for (const SlabPart& s : piece.slabs)
            anyColor = anyColor || std::any_of(s.mesh.colors.begin(), s.mesh.colors.end(),
                                               [](const glm::vec3& c) { return c != glm::vec3(1.f); });
    MPI_Allreduce(&anyColor, &anyColorAll, 1, MPI_INT, MPI_LOR, comm);
    const bool colors = options.colors && anyColorAll;

    // A temporary name beside the target, from rank 0's process id.
    const std::filesystem::path target(path);
    long pid = rank == 0 ? static_cast<long>(::getpid()) : 0;
    MPI_Bcast(&pid, 1, MPI_LONG, 0, comm);
    const std::string temporary =
        (target.parent_path() / ("." + target.filename().string() + ".mpi-" + std::to_string(pid) + ".tmp")).string();
    if (!canWriteCollective(path) || (ext == ".stl" && piece.totalTriangles > 0xFFFFFFFFull))
        throw IoError(path + (canWriteCollective(path) ? ": binary STL holds at most 4,294,967,295 triangles"
                                                       : ": isoforge-mpi writes .ply, .obj, .stl or .pvtp"));
    MPI_File file;
    if (MPI_File_open(comm, temporary.c_str(), MPI_MODE_CREATE | MPI_MODE_WRONLY, MPI_INFO_NULL, &file) != MPI_SUCCESS)
        throw IoError(path + ": cannot create '" + temporary + "'");  // collective: every rank sees it
    // Every rank removes it if mpirun ends the job with SIGTERM (as it does when another rank dies).
    temporarySlot = removeOnSignal(temporary);
    MPI_File_set_size(file, 0);

    Sections out(file, comm, path);
    using Emit = Sections::Emit;
    const auto header = [&](const std::string& text) {
        const std::string mine = rank == 0 ? text : std::string();
        out.section(mine.size(), [&](const Emit& emit) { emit(mine); });
    };
    // Each slab's records formatted and written in turn (binary: the length is known up front).
    const auto perSlab = [&](std::uint64_t bytes, const std::function<void(const SlabPart&, std::string&)>& format) {
        out.section(bytes, [&](const Emit& emit) {
            std::string buf;
            for (const SlabPart& s : piece.slabs) {
                buf.clear();
                format(s, buf);
                emit(buf);
            }
        });
    };
    const auto formattedPerSlab = [&](const std::function<void(const SlabPart&, std::string&)>& format) {
        out.formatted([&](std::string& all) {
            for (const SlabPart& s : piece.slabs) format(s, all);
        });
    };
    const auto plyVertices = [&](const SlabPart& s, std::string& b) {
        mesh::records::appendPlyVertices(
            b, ownedOf(s.mesh.positions, s.owned),
            hasNormals ? ownedOf(s.mesh.normals, s.owned) : std::span<const glm::vec3>(),
            colors ? std::span<const glm::vec3>(s.mesh.colors) : std::span<const glm::vec3>(), options.ascii);
    };
    const auto plyFaces = [&](const SlabPart& s, std::string& b) {
        mesh::records::appendPlyFaces(b, s.mesh.triangles, options.ascii);
    };
    if (ext == ".ply") {
        header(mesh::records::plyHeader(piece.totalVertices, piece.totalTriangles, hasNormals, colors, options.ascii));
        if (options.ascii) {
            formattedPerSlab(plyVertices);
            formattedPerSlab(plyFaces);
        } else {
            perSlab(piece.vertices * (12 + 12 * (hasNormals != 0) + 3 * colors), plyVertices);
            perSlab(piece.triangles * 13, plyFaces);
        }
    } else if (ext == ".obj") {
        header(mesh::records::kObjHeader);
        formattedPerSlab([&](const SlabPart& s, std::string& b) {
            mesh::records::appendObjPositions(b, ownedOf(s.mesh.positions, s.owned));
        });
        if (hasNormals)
            formattedPerSlab([&](const SlabPart& s, std::string& b) {
                mesh::records::appendObjNormals(b, ownedOf(s.mesh.normals, s.owned));
            });
        formattedPerSlab(
            [&](const SlabPart& s, std::string& b) { mesh::records::appendObjFaces(b, s.mesh.triangles, hasNormals); });
    } else {
        header(mesh::records::stlHeader(static_cast<std::uint32_t>(piece.totalTriangles)));
        perSlab(piece.triangles * 50, [&](const SlabPart& s, std::string& b) {
            mesh::records::appendStlTriangles(b, s.mesh.triangles, [&](std::uint32_t v) -> const glm::vec3& {
                return s.mesh.positions[v - s.vertexBase];
            });
        });
    }
    MPI_File_close(&file);
    try {
        agree(out.error(), 1, comm);
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
    forgetTemporary(temporarySlot);
    temporarySlot = -1;
}

}  // namespace isoforge::mpi
