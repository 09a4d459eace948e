#include "mpi/agree.h"

#include <limits>

namespace isoforge::mpi {

void agree(const std::string& error, int status, MPI_Comm comm) {
    int rank = 0;
    MPI_Comm_rank(comm, &rank);
    const int mine[2] = {error.empty() ? std::numeric_limits<int>::max() : rank, error.empty() ? 0 : status};
    int first = 0, worst = 0;
    MPI_Allreduce(&mine[0], &first, 1, MPI_INT, MPI_MIN, comm);
    MPI_Allreduce(&mine[1], &worst, 1, MPI_INT, MPI_MAX, comm);
    if (first == std::numeric_limits<int>::max()) return;
    if (rank == first) throw RankFailure(error, worst, true);
    throw RankFailure("rank " + std::to_string(first) + " failed", worst, false);
}

}  // namespace isoforge::mpi
