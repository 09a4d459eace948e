#pragma once
/// @file Optional parts of isoforge built as modules (shared objects loaded with dlopen on first use),
/// so that commands that do not need their heavy libraries do not load them at start-up.

#include <filesystem>
#include <string>

namespace isoforge {

/// Loads lib/isoforge/`file` (looked for beside the executable or the library holding this code, then
/// in the build tree and the install prefix) and returns the address of its C entry point `symbol`.
/// Modules stay loaded for the process's life. @throw IoError naming every place tried.
void* moduleEntry(const std::string& file, const char* symbol, const std::string& what);

/// The helper program lib/isoforge/`file` (an executable isoforge runs, such as the DICOM reader), looked
/// for where modules are. @throw IoError naming every place tried.
std::filesystem::path helperProgram(const std::string& file, const std::string& what);

}  // namespace isoforge
