// `vlt run JOB.toml [-o DIR] [--no-mcm] [--trials N | --adaptive] [--seed S] [--threads T]`:
// GUM + Monte Carlo + validation for every point and task of a job; writes points.csv,
// budget.csv, tasks.csv, results.json, report.html (+ map.csv, map.html with a [map] section).
#include <charconv>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <utility>
#include <vector>

#include "run_job.h"
#include "vlt/custom_job.h"
#include "vlt/error.h"

namespace vlt::cli {

namespace {

std::string Quoted(const std::string& s) {
  return "'" + (s.size() > 40 ? s.substr(0, 40) + "...(" + std::to_string(s.size()) + " characters)" : s) +
         "'";
}

}  // namespace

CLI::Validator IntegerIn(std::int64_t lo, std::int64_t hi) {
  const std::string range = std::to_string(lo) + " .. " + std::to_string(hi);
  return CLI::Validator(
      [lo, hi, range](std::string& text) -> std::string {
        std::int64_t v = 0;
        const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
        if (ec != std::errc() || end != text.data() + text.size() || v < lo || v > hi) {
          return Quoted(text) + " is not an integer in " + range;
        }
        return {};
      },
      "INT in " + range);
}

CLI::Validator NonEmptyPath() {
  return CLI::Validator([](std::string& text) -> std::string { return text.empty() ? "an empty path" : ""; },
                        "PATH");
}

CLI::Validator UnsignedInteger64() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        std::uint64_t v = 0;
        const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
        if (ec != std::errc() || end != text.data() + text.size()) {
          return Quoted(text) + " is not an integer in 0 .. 18446744073709551615";
        }
        return {};
      },
      "INT in 0 .. 2^64-1");
}

void PrintWritten(const std::vector<OutputFile>& files, const std::string& summary,
                  const std::filesystem::path& dir, const GlobalOptions& global) {
  if (global.json) {
    for (const OutputFile& file : files) {
      if (file.name != "results.json") continue;
      StringText text;
      file.write(text);
      std::fwrite(text.text().data(), 1, text.text().size(), stdout);
    }
    return;
  }
  if (global.quiet) return;
  std::fwrite(summary.data(), 1, summary.size(), stdout);
  std::printf("Wrote %s/: ", dir.string().c_str());
  for (std::size_t i = 0; i < files.size(); ++i) std::printf("%s%s", i ? ", " : "", files[i].name.c_str());
  std::printf("\n");
}

void PrintWritten(const std::vector<std::pair<std::string, std::string>>& files, const std::string& summary,
                  const std::filesystem::path& dir, const GlobalOptions& global) {
  PrintWritten(AsOutputFiles(files), summary, dir, global);
}

void AddRunOptions(CLI::App& command, RunCliOptions& options, const std::string& default_output) {
  command.add_option("-o,--output", options.output_dir, "Output directory (default: " + default_output + ")")
      ->check(NonEmptyPath());
  command.add_flag("--no-mcm", options.no_mcm, "GUM only: skip the Monte Carlo method and the validation");
  command.add_option("--trials", options.trials, "Monte Carlo trials M (overrides [monte_carlo] trials)")
      ->check(IntegerIn(1, 1000000000));
  command.add_flag("--adaptive", options.adaptive, "Adaptive Monte Carlo procedure (JCGM 101 7.9.4)");
  command.add_option("--seed", options.seed, "Monte Carlo seed (overrides [monte_carlo] seed)")
      ->check(UnsignedInteger64());
  command.add_option("--threads", options.threads, "Threads (0 = all hardware threads)")
      ->check(IntegerIn(0, 1024));
  command.add_option("--device", options.device,
                     "Where the Monte Carlo trials run: auto, cpu or gpu (overrides [monte_carlo] device; docs/gpu.md)");
}

std::filesystem::path OutputPath(const OutputSettings& job_output, const std::filesystem::path& base_dir,
                                 const RunCliOptions& options, const std::filesystem::path& fallback) {
  if (!options.output_dir.empty()) return options.output_dir;
  if (!job_output.directory.empty()) {
    std::filesystem::path d = job_output.directory;
    return d.is_absolute() ? d : base_dir / d;
  }
  return fallback;
}

namespace {

// What a command leaves to the process's exit (LeaveToExit): reachable from here, never freed.
std::vector<std::shared_ptr<const void>>& LeftToExit() {
  static auto* left = new std::vector<std::shared_ptr<const void>>();
  return *left;
}

}  // namespace

void LeaveToExit(std::shared_ptr<const void> object) { LeftToExit().push_back(std::move(object)); }

int RunAndWrite(const Job& job, const RunCliOptions& options, const GlobalOptions& global,
                const std::filesystem::path& fallback_dir) {
  if (options.adaptive && options.trials > 0) {
    throw InputError("command line: --trials and --adaptive exclude each other");
  }
  EmitWarnings(job.warnings, global);
  RunOptions run = RunOptionsFrom(options, job.monte_carlo, global);
  // The output location is checked before anything is computed (docs/cli.md "Outputs").
  OutputDirectory output(OutputPath(job.output, job.base_dir, options, fallback_dir));
  const std::filesystem::path& dir = output.path();

  auto results = std::make_shared<const Results>(RunJob(job, run));
  auto files = ResultFiles(*results);
  output.Commit(files);

  PrintWritten(files, SummaryText(*results), dir, global);
  if (!global.json && !global.quiet) {
    std::printf("Open %s in a browser for the report.\n", (dir / "report.html").string().c_str());
  }
  LeaveToExit(std::move(results));
  return 0;
}

RunOptions RunOptionsFrom(const RunCliOptions& options, const MonteCarloSettings& monte_carlo,
                          const GlobalOptions& global) {
  RunOptions run;
  run.monte_carlo = !options.no_mcm;
  if (options.adaptive) run.trials = 0;
  if (options.trials > 0) {
    // JCGM 101 7.2.2: M at least 100/(1-p) (the job's coverage probability).
    double minimum = std::ceil(100.0 / (1.0 - monte_carlo.coverage_probability));
    if (static_cast<double>(options.trials) < minimum) {
      throw InputError("command line: --trials: at least " + std::to_string(static_cast<long long>(minimum)) +
                       " trials for coverage probability " +
                       std::to_string(monte_carlo.coverage_probability) + " (JCGM 101 7.2.2)");
    }
    run.trials = options.trials;
  }
  if (!options.seed.empty()) {
    std::uint64_t seed = 0;
    std::from_chars(options.seed.data(), options.seed.data() + options.seed.size(), seed);  // validated
    run.seed = seed;
  }
  if (options.threads >= 0) run.threads = options.threads;
  if (!options.device.empty()) run.device = McmDeviceNamed(options.device, "command line: --device");
  run.progress = !global.quiet && !global.json;
  return run;
}

// A custom-model job (vlt/custom_job.h): GUM with effective degrees of freedom, Monte Carlo,
// validation, conformity; outputs.csv, budget.csv, results.json, report.html.
int RunCustomAndWrite(const CustomJob& job, const RunCliOptions& options, const GlobalOptions& global) {
  if (options.adaptive && options.trials > 0) {
    throw InputError("command line: --trials and --adaptive exclude each other");
  }
  EmitWarnings(job.warnings, global);
  RunOptions run = RunOptionsFrom(options, job.monte_carlo, global);
  OutputDirectory output(OutputPath(job.output, job.base_dir, options,
                                    std::filesystem::path("vlt-out") / SafeFileName(job.name)));
  CustomResults results = RunCustomJob(job, run);
  auto files = ResultFiles(results);
  output.Commit(AsOutputFiles(files));
  PrintWritten(files, SummaryText(results), output.path(), global);
  if (!global.json && !global.quiet) {
    std::printf("Open %s in a browser for the report.\n", (output.path() / "report.html").string().c_str());
  }
  return 0;
}

void AddRunCommand(CLI::App& app, GlobalOptions& global) {
  auto* command = app.add_subcommand("run",
                                     "Run a job file: GUM and Monte Carlo uncertainty of every point and "
                                     "task, written as CSV, JSON and an HTML report");
  auto job_file = std::make_shared<std::string>();
  auto options = std::make_shared<RunCliOptions>();
  command->add_option("job", *job_file, "Job file (TOML, docs/job-file.md)")->required();
  AddRunOptions(*command, *options);
  auto calibration = std::make_shared<std::string>();
  command->add_option("--calibration", *calibration,
                      "A calibration file (vlt calibrate) in place of the job's [tracker] calibration; "
                      "relative to the working directory");
  command->footer(
      "Exit status: 0 success, 2 bad input or a result that cannot be computed (one line on stderr;\n"
      "no output file is written). Outputs: docs/results.md.");
  command->callback([job_file, options, calibration, &global] {
    if (IsCustomModelJobFile(*job_file)) {
      if (!calibration->empty()) {
        throw InputError("--calibration: '" + *job_file +
                         "' is a custom-model job: it has no tracker to calibrate");
      }
      RunCustomAndWrite(LoadCustomJob(*job_file), *options, global);
      return;
    }
    JobOverrides overrides;
    if (!calibration->empty()) overrides.calibration = *calibration;
    if (options->threads >= 0) overrides.threads = options->threads;
    auto job = std::make_shared<const Job>(LoadJob(*job_file, overrides));
    std::filesystem::path fallback = std::filesystem::path("vlt-out") / SafeFileName(job->name);
    RunAndWrite(*job, *options, global, fallback);
    LeaveToExit(std::move(job));
  });
}

}  // namespace vlt::cli
