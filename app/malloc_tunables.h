#pragma once
/// @file What glibc's malloc was told when the process started: the launcher's (app/launcher.c) huge-page
/// tunable, or what the user set instead. For `--version` of isoforge and isoforge-mpi.

#include <string>

namespace isoforge::app {

/// "GLIBC_TUNABLES=..." as the process has it, or a sentence saying glibc's defaults are in effect.
std::string mallocTunablesText();

}  // namespace isoforge::app
