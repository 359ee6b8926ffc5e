// `vlt network FILE.toml [-o DIR]`: several stations of one instrument tied by common targets —
// the bundle adjustment of station poses and target coordinates with the full covariance
// (online: the stations' readings; offline: the predicted uncertainty of a planned network).
// docs/network.md.
#include <charconv>
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
  // The seed as given ("": no simulation), checked whole as 0 .. 2^64-1: an integer option would
  // clamp 18446744073709551616 to 2^63-1 without a word.
  auto simulate = std::make_shared<std::string>();
  auto threads = std::make_shared<int>(0);
  auto no_robust = std::make_shared<bool>(false);
  command
      ->add_option("file", *file,
                   "Network file (TOML: [tracker], [[station]], [datum], [[reference]], docs/network.md)")
      ->required();
  command->add_option("-o,--output", *output_arg,
                      "Output directory (default: [output] directory of the file, else ./vlt-out/<name>)")
      ->check(NonEmptyPath());
  command
      ->add_option(
          "--simulate", *simulate,
          "Offline networks: also write a simulated measurement with this seed (simulated_network.toml "
          "and one readings CSV per station)")
      ->check(UnsignedInteger64());
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
  command->callback([file, output_arg, simulate_text = simulate, threads, no_robust, &global] {
    std::optional<std::uint64_t> simulate;
    if (!simulate_text->empty()) {
      std::uint64_t seed = 0;
      std::from_chars(simulate_text->data(), simulate_text->data() + simulate_text->size(), seed);
      simulate = seed;  // UnsignedInteger64 accepted the whole text
    }
    NetworkJob job = LoadNetworkJob(*file);
    if (*no_robust) job.network.robust = false;
    if (simulate && !job.offline) {
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
    if (simulate) {
      const Network simulated = SimulateNetwork(job.network, job.nominal, *simulate);
      for (auto& f : network_outputs::SimulatedNetworkFiles(job, simulated, *simulate)) {
        files.push_back(std::move(f));
      }
    }
    output.Commit(AsOutputFiles(files));
    PrintWritten(files, network_outputs::NetworkSummary(job, result, mc ? &*mc : nullptr), output.path(),
                 global);
  });
}

}  // namespace vlt::cli
