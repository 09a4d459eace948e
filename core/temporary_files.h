#pragma once
/// @file Temporary files removed when the process is stopped by a signal.
/// An atomic output is written beside its target under a hidden name and renamed at the end; a process
/// stopped on the way (Ctrl-C, `kill`, or `mpirun` ending a job whose other rank died) would leave that
/// hidden file behind. While registered, a temporary file is unlinked by a handler of SIGINT, SIGTERM
/// and SIGHUP where the signal's action was the default one (ending the process), which then ends the
/// process by the signal as before. Where the program had its own handler (Python's, the viewer's), that
/// handler is called instead and nothing is removed: the program goes on, and unwinding removes the files.
/// SIGKILL cannot be caught; nothing can clean up after it.

#include <string>

namespace isoforge {

/// Registers `path` for removal on SIGINT, SIGTERM and SIGHUP (the handlers are installed on the first
/// call). Returns a slot to pass to forgetTemporary, or -1 when all 32 slots are taken or the path is
/// too long (it is then not removed on a signal).
int removeOnSignal(const std::string& path);
/// Forgets a slot once its file is renamed or removed (a slot of -1 is ignored).
void forgetTemporary(int slot);

}  // namespace isoforge
