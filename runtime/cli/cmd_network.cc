// `vlt network FILE.toml [-o DIR]`: several stations of one instrument tied by common targets —
// the bundle adjustment of station poses and target coordinates with the full covariance
// (online: the stations' readings; offline: the predicted uncertainty of a planned network).
// docs/network.md.
#include <cstdint>
#include <cstdio>
#include <optional>

#include "run_job.h"
#include "vlt/error.h"
#include "vlt/network.h"
#include "vlt/results.h"

namespace vlt::cli {

void AddNetworkCommand(CLI::App& app, GlobalOptions& global) {
  auto* command =
      app.add_subcommand("network",
                         "Adjust a network of stations (bundle adjustment of station poses and "
                         "targets, optionally self-calibrating the tracker), or plan one offline");
  auto file = std::make_shared<std::string>();
  auto output_arg = std::make_shared<std::string>();
  auto simulate = std::make_shared<std::int64_t>(-1);
  auto threads = std::make_shared<int>(0);
  auto no_robust = std::make_shared<bool>(false);
  command
      ->add_option("file", *file,
                   "Network file (TOML: [tracker], [[station]], [datum], [[reference]], docs/network.md)")
      ->required();
  command->add_option("-o,--output", *output_arg,
                      "Output directory (default: [output] directory of the file, else ./vlt-out/<name>)");
  command
      ->add_option(
          "--simulate", *simulate,
          "Offline networks: also write a simulated measurement with this seed (simulated_network.toml "
          "and one readings CSV per station)")
      ->check(CLI::NonNegativeNumber);
  command
      ->add_option("--threads", *threads,
                   "Threads of the Monte Carlo validation ([network.monte_carlo]; 0: all; results do not "
                   "depend on it)")
      ->check(CLI::Range(0, 1024));
  command->add_flag("--no-robust", *no_robust,
                    "Keep every observation: no iterative data snooping ([network] robust = false)");
  command->footer(
      "Exit status: 0 success, 2 bad input or no solution (one line on stderr; no output file is written).\n"
      "Outputs: targets.csv, stations.csv, residuals.csv, covariance.csv, tasks.csv ([[task]]),\n"
      "parameters.csv (self-calibration), mcm.csv ([network.monte_carlo]), distances.csv ([[scale_bar]],\n"
      "[[distance]]), rejected.csv (observations the robust adjustment removed), results.json.");
  command->callback([file, output_arg, simulate, threads, no_robust, &global] {
    NetworkJob job = LoadNetworkJob(*file);
    if (*no_robust) job.network.robust = false;
    if (*simulate >= 0 && !job.offline) {
      throw InputError(*file +
                       ": station: --simulate needs an offline network (stations that see [targets])");
    }
    EmitWarnings(job.warnings, global);
    RunCliOptions where;
    where.output_dir = *output_arg;
    OutputDirectory output(OutputPath(OutputSettings{job.output_directory},
                                      std::filesystem::path(*file).parent_path(), where,
                                      std::filesystem::path("vlt-out") / SafeFileName(job.name)));
    const NetworkResult result = AdjustNetwork(job.network);
    std::vector<std::string> warnings;
    for (const std::string& w : result.warnings) warnings.push_back(*file + ": network: " + w);
    EmitWarnings(warnings, global);
    std::optional<NetworkMonteCarlo> mc;
    if (job.monte_carlo_trials > 0) {
      mc = ValidateNetworkByMonteCarlo(job.network, result, job.monte_carlo_trials, job.monte_carlo_seed,
                                       *threads);
    }
    const std::vector<NetworkTaskResult> tasks = NetworkTasks(job.tasks, result, job.file);
    auto files = network_outputs::NetworkFiles(job, result, tasks, RunCreatedTime(), mc ? &*mc : nullptr);
    if (*simulate >= 0) {
      const Network simulated =
          SimulateNetwork(job.network, job.nominal, static_cast<std::uint64_t>(*simulate));
      for (auto& f :
           network_outputs::SimulatedNetworkFiles(job, simulated, static_cast<std::uint64_t>(*simulate))) {
        files.push_back(std::move(f));
      }
    }
    output.Commit(AsOutputFiles(files));
    PrintWritten(files, network_outputs::NetworkSummary(job, result, mc ? &*mc : nullptr), output.path(),
                 global);
  });
}

}  // namespace vlt::cli
