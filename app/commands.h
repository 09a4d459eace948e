#pragma once
/// @file The subcommands of the isoforge executable. Each returns the process exit code and throws
/// isoforge::IoError (exit 1) on bad input; usage errors are CLI11's (exit 2).

#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

namespace isoforge::app {

struct GlobalOptions {
    int threads = 0;  ///< 0: all cores
    bool quiet = false;
};

/// Registers each subcommand on `app`; the callbacks set `run` to the chosen command.
struct Commands {
    std::function<int()> run;
};

void addInfoCommand(CLI::App& app, const GlobalOptions& g, Commands& c);
void addMeshCommand(CLI::App& app, const GlobalOptions& g, Commands& c);
void addCheckCommand(CLI::App& app, const GlobalOptions& g, Commands& c);
void addCompareCommand(CLI::App& app, const GlobalOptions& g, Commands& c);
void addPrimitiveCommand(CLI::App& app, const GlobalOptions& g, Commands& c);
void addStripsCommand(CLI::App& app, const GlobalOptions& g, Commands& c);
void addSubdivideCommand(CLI::App& app, const GlobalOptions& g, Commands& c);
void addTessellateCommand(CLI::App& app, const GlobalOptions& g, Commands& c);
void addSampleCommand(CLI::App& app, const GlobalOptions& g, Commands& c);
void addVoxelizeCommand(CLI::App& app, const GlobalOptions& g, Commands& c);
void addConvertCommand(CLI::App& app, const GlobalOptions& g, Commands& c);
void addSliceCommand(CLI::App& app, const GlobalOptions& g, Commands& c);
void addShapesCommand(CLI::App& app, const GlobalOptions& g, Commands& c);
void addCheckSceneCommand(CLI::App& app, const GlobalOptions& g, Commands& c);
void addRenderCommand(CLI::App& app, const GlobalOptions& g, Commands& c);
void addViewCommand(CLI::App& app, const GlobalOptions& g, Commands& c);

/// "1,234,567"
std::string withCommas(unsigned long long n);

}  // namespace isoforge::app
