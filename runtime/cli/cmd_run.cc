// `vlt run JOB.toml [-o DIR] [--no-mcm] [--trials N | --adaptive] [--seed S] [--threads T]`:
// GUM + Monte Carlo + validation for every point and task of a job; writes points.csv,
// budget.csv, tasks.csv, results.json, report.html (+ map.csv, map.html with a [map] section).
#include <cmath>
#include <cstdio>
#include <iostream>

#include "results/internal.h"
#include "run_job.h"
#include "vlt/error.h"

namespace vlt::cli {

void AddRunOptions(CLI::App& command, RunCliOptions& options) {
  command.add_option("-o,--output", options.output_dir,
                     "Output directory (default: [output] directory of the job, else ./vlt-out/<job name>)");
  command.add_flag("--no-mcm", options.no_mcm, "GUM only: skip the Monte Carlo method and the validation");
  command.add_option("--trials", options.trials, "Monte Carlo trials M (overrides [monte_carlo] trials)")
      ->check(CLI::Range(std::int64_t{1}, std::int64_t{1000000000}));
  command.add_flag("--adaptive", options.adaptive, "Adaptive Monte Carlo procedure (JCGM 101 7.9.4)");
  command.add_option("--seed", options.seed, "Monte Carlo seed (overrides [monte_carlo] seed)")
      ->check(CLI::NonNegativeNumber);
  command.add_option("--threads", options.threads, "Threads (0 = all hardware threads)")
      ->check(CLI::Range(0, 1024));
}

std::filesystem::path OutputDirectory(const Job& job, const RunCliOptions& options,
                                      const std::filesystem::path& fallback) {
  if (!options.output_dir.empty()) return options.output_dir;
  if (!job.output.directory.empty()) {
    std::filesystem::path d = job.output.directory;
    return d.is_absolute() ? d : job.base_dir / d;
  }
  return fallback;
}

int RunAndWrite(const Job& job, const RunCliOptions& options, const GlobalOptions& global,
                const std::filesystem::path& fallback_dir) {
  if (options.adaptive && options.trials > 0) {
    throw InputError("command line: --trials and --adaptive exclude each other");
  }
  RunOptions run;
  run.monte_carlo = !options.no_mcm;
  if (options.adaptive) run.trials = 0;
  if (options.trials > 0) {
    // JCGM 101 7.2.2: M at least 100/(1-p) (the job's coverage probability).
    double minimum = std::ceil(100.0 / (1.0 - job.monte_carlo.coverage_probability));
    if (static_cast<double>(options.trials) < minimum) {
      throw InputError("command line: --trials: at least " + std::to_string(static_cast<long long>(minimum)) +
                       " trials for coverage probability " + std::to_string(job.monte_carlo.coverage_probability) +
                       " (JCGM 101 7.2.2)");
    }
    run.trials = options.trials;
  }
  if (options.seed >= 0) run.seed = static_cast<std::uint64_t>(options.seed);
  if (options.threads >= 0) run.threads = options.threads;
  run.progress = !global.quiet && !global.json;
  std::filesystem::path dir = OutputDirectory(job, options, fallback_dir);

  Results results = RunJob(job, run);
  auto files = ResultFiles(results);
  WriteFilesAtomically(dir, files);

  if (global.json) {
    for (const auto& [name, content] : files) {
      if (name == "results.json") std::fwrite(content.data(), 1, content.size(), stdout);
    }
  } else if (!global.quiet) {
    std::string text = SummaryText(results);
    std::fwrite(text.data(), 1, text.size(), stdout);
    std::printf("Wrote %s/: ", dir.string().c_str());
    for (std::size_t i = 0; i < files.size(); ++i) std::printf("%s%s", i ? ", " : "", files[i].first.c_str());
    std::printf("\nOpen %s in a browser for the report.\n", (dir / "report.html").string().c_str());
  }
  return 0;
}

void AddRunCommand(CLI::App& app, GlobalOptions& global) {
  auto* command = app.add_subcommand("run", "Run a job file: GUM and Monte Carlo uncertainty of every point and "
                                            "task, written as CSV, JSON and an HTML report");
  auto job_file = std::make_shared<std::string>();
  auto options = std::make_shared<RunCliOptions>();
  command->add_option("job", *job_file, "Job file (TOML, docs/job-file.md)")->required();
  AddRunOptions(*command, *options);
  command->footer("Exit status: 0 success, 2 bad input or a result that cannot be computed (one line on stderr;\n"
                  "no output file is written). Outputs: docs/results.md.");
  command->callback([job_file, options, &global] {
    Job job = LoadJob(*job_file);
    std::filesystem::path fallback = std::filesystem::path("vlt-out") / vlt::internal::SafeFileName(job.name);
    RunAndWrite(job, *options, global, fallback);
  });
}

}  // namespace vlt::cli
