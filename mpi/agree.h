#pragma once
/// @file How the ranks of a job stop together: after each stage that can fail on one rank (bad input,
/// out of memory, a failed write), every rank learns whether any failed before the next collective
/// call, so that none waits forever on a rank that gave up.

#include <stdexcept>
#include <string>

#include <mpi.h>

namespace isoforge::mpi {

/// A rank's failure: its message, and the exit status it calls for (1 bad input, 2 usage).
struct RankFailure : std::runtime_error {
    RankFailure(const std::string& message, int status, bool here)
        : std::runtime_error(message), exitStatus(status), onThisRank(here) {}
    int exitStatus;
    bool onThisRank;  ///< false: another rank failed, and printed why
};

/// Collective. When any rank passes a non-empty `error`, every rank throws RankFailure: the first
/// failing rank's with its message, the others with one naming it. `status` is the exit status
/// the error calls for.
void agree(const std::string& error, int status, MPI_Comm comm);

}  // namespace isoforge::mpi
