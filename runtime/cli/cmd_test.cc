// `vlt test FILE.toml [-o DIR]`: the standard tests (ASME B89.4.19 pattern: length, ranging,
// two-face) of a layout on a virtual tracker: each test's error, its uncertainty, pass/fail against
// the MPE, and the sensitivity table; with [tests.simulate], simulated measured data for
// `vlt calibrate`. docs/calibration.md.
#include <cstdio>

#include "run_job.h"
#include "vlt/calibration.h"

namespace vlt::cli {

void AddTestCommand(CLI::App& app, GlobalOptions& global) {
  auto* command =
      app.add_subcommand("test",
                         "Simulate the standard tracker tests (B89.4.19 pattern) of a layout on a "
                         "virtual tracker: errors, uncertainties, MPE verdicts, sensitivity table");
  auto file = std::make_shared<std::string>();
  auto output_arg = std::make_shared<std::string>();
  command->add_option("file", *file, "Test file (TOML: [tracker] + [tests], docs/calibration.md)")
      ->required();
  command->add_option("-o,--output", *output_arg, "Output directory (default: ./vlt-out/<name>-tests)")
      ->check(NonEmptyPath());
  command->footer(
      "Exit status: 0 success, 2 bad input (one line on stderr; no output file is written).\n"
      "Outputs: tests.csv, sensitivity.csv, results.json, report.html (+ simulated_readings.csv,\n"
      "simulated_calibration.toml with [tests.simulate]).");
  command->callback([file, output_arg, &global] {
    const TestJob job = LoadTestJob(*file);
    EmitWarnings(job.warnings, global);
    OutputDirectory output(output_arg->empty()
                               ? std::filesystem::path("vlt-out") / SafeFileName(job.name + "-tests")
                               : std::filesystem::path(*output_arg));
    const std::filesystem::path& dir = output.path();
    const std::vector<TestResult> results = SimulateTests(job.tracker, job.layout, job.settings);
    CalibrationData simulated;
    if (job.simulate) simulated = SimulateCalibrationData(job.tracker, job.layout, job.seed);
    const auto files = calibration_outputs::TestFiles(job, results, job.simulate ? &simulated : nullptr);
    output.Commit(AsOutputFiles(files));
    PrintWritten(files, calibration_outputs::TestSummary(job, results), dir, global);
  });
}

}  // namespace vlt::cli
