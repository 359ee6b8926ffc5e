// The subcommands of `vlt`, one file each (cmd_<name>.cc); main.cc wires them into CLI11.
#pragma once

#include <string>
#include <vector>

#include <CLI/CLI.hpp>

namespace vlt::cli {

struct GlobalOptions {
  bool quiet = false;   // --quiet: no progress, no summary on stdout
  bool json = false;    // --json: machine-readable result on stdout where a command prints one
  bool strict = false;  // --strict: a warning (implausible but legal input) is an error
};

// Shortens quoted values in an error line (over 160 characters keep their first
// and last 60) and the whole line to 1000 characters; line breaks become blanks.
std::string ShortenMessage(const std::string& message);

// Prints each warning as "vlt: warning: <text>" on stderr (not with --quiet); with --strict the
// first one is an InputError instead (exit 2, nothing computed or written).
void EmitWarnings(const std::vector<std::string>& warnings, const GlobalOptions& global);

void AddModelCommand(CLI::App& app, GlobalOptions& global);      // vlt model list|show NAME
void AddSimulateCommand(CLI::App& app, GlobalOptions& global);   // vlt simulate ...
void AddRunCommand(CLI::App& app, GlobalOptions& global);        // vlt run JOB.toml [-o DIR]
void AddDemoCommand(CLI::App& app, GlobalOptions& global);       // vlt demo (also: bare `vlt`)
void AddMapCommand(CLI::App& app, GlobalOptions& global);        // vlt map JOB.toml ...
void AddPlanCommand(CLI::App& app, GlobalOptions& global);       // vlt plan JOB.toml [-o DIR]
void AddTestCommand(CLI::App& app, GlobalOptions& global);       // vlt test FILE.toml [-o DIR]
void AddCalibrateCommand(CLI::App& app, GlobalOptions& global);  // vlt calibrate FILE.toml [-o DIR]
void AddPriorCommand(CLI::App& app, GlobalOptions& global);      // vlt prior PROFILE.toml [-o DIR]
void AddNetworkCommand(CLI::App& app, GlobalOptions& global);    // vlt network FILE.toml [-o DIR]

// Runs the embedded default job into ./vlt-demo/ (what bare `vlt` does). Returns exit status.
int RunDemo(const GlobalOptions& global);

}  // namespace vlt::cli
