// run_job.h — what `vlt run`, `vlt demo` and `vlt map` share (runtime/cli/cmd_run.cc).
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include <CLI/CLI.hpp>

#include "commands.h"
#include "vlt/job.h"
#include "vlt/results.h"

namespace vlt::cli {

struct RunCliOptions {
  std::string output_dir;  // -o; "" = the default
  bool no_mcm = false;
  std::int64_t trials = -1;  // -1: from the job
  bool adaptive = false;
  std::string seed;  // "": from the job; else an integer 0 .. 2^64-1
  int threads = -1;
  std::string device;  // --device: "": from the job; else "auto", "cpu" or "gpu"
};

// CLI11 validators that read the whole text as one integer and refuse anything else with a
// short message (no silent clamping of 99999999999999999999, no 309-digit ranges).
CLI::Validator IntegerIn(std::int64_t lo, std::int64_t hi);
CLI::Validator UnsignedInteger64();
// A path that is not empty (`-o ""` would otherwise fall back to the default directory unsaid).
CLI::Validator NonEmptyPath();

// After a command committed its files: --json prints results.json, else (unless --quiet) the
// summary and "Wrote DIR/: a, b, ..." (one place for run, test, calibrate).
void PrintWritten(const std::vector<OutputFile>& files, const std::string& summary,
                  const std::filesystem::path& dir, const GlobalOptions& global);
void PrintWritten(const std::vector<std::pair<std::string, std::string>>& files, const std::string& summary,
                  const std::filesystem::path& dir, const GlobalOptions& global);

// Adds -o, --no-mcm, --trials, --adaptive, --seed, --threads to a subcommand.
void AddRunOptions(
    CLI::App& command, RunCliOptions& options,
    const std::string& default_output = "[output] directory of the job, else ./vlt-out/<job name>");

// Where the outputs of `job` go: -o, else [output] directory (relative to the job file), else
// `fallback` (e.g. ./vlt-out/<job name>).
std::filesystem::path OutputPath(const OutputSettings& job_output, const std::filesystem::path& base_dir,
                                 const RunCliOptions& options, const std::filesystem::path& fallback);

// The run options of the command line (--no-mcm, --trials, --adaptive, --seed, --threads) over
// the job's [monte_carlo]; --trials below JCGM 101 7.2.2's minimum is an InputError.
RunOptions RunOptionsFrom(const RunCliOptions& options, const MonteCarloSettings& monte_carlo,
                          const GlobalOptions& global);

// Runs the job, writes every output file (all or none), prints the summary / JSON. Returns 0.
// Leaves `object` to be freed by the process's exit, not by its destructor: a scan's job and
// results (10^6 points: 0.17 s to free, on one thread, after the files are written) end with the
// command, as compilers leave their syntax trees to the exit (clang's -disable-free). Still
// reachable (from a static list), so leak checkers do not count it as lost.
void LeaveToExit(std::shared_ptr<const void> object);

int RunAndWrite(const Job& job, const RunCliOptions& options, const GlobalOptions& global,
                const std::filesystem::path& fallback_dir);

}  // namespace vlt::cli
