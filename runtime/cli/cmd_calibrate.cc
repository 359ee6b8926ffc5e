// `vlt calibrate FILE.toml [-o DIR]`: identify the tracker's error parameters from measured test
// data (readings of targets, calibrated bars, reference distances) with honest covariance; writes
// the calibration file a job loads with `[tracker] calibration = "..."`. docs/calibration.md.
#include <algorithm>
#include <cstdio>
#include <filesystem>

#include "run_job.h"
#include "vlt/calibration.h"
#include "vlt/results.h"

namespace vlt::cli {

void AddCalibrateCommand(CLI::App& app, GlobalOptions& global) {
  auto* command =
      app.add_subcommand("calibrate",
                         "Identify a tracker's error parameters from measured test data "
                         "(least squares with identifiability analysis); writes a calibration file");
  auto file = std::make_shared<std::string>();
  auto output_arg = std::make_shared<std::string>();
  command
      ->add_option(
          "file", *file,
          "Calibration job (TOML: [tracker], [readings], [[bar]], [[reference]], docs/calibration.md)")
      ->required();
  command->add_option("-o,--output", *output_arg,
                      "Output directory (default: [output] directory of the file, else ./vlt-out/<name>)")
      ->check(NonEmptyPath());
  command->footer(
      "Exit status: 0 success, 2 bad input or no solution (one line on stderr; no output file is written).\n"
      "Outputs: calibration.toml (load it in a job: [tracker] calibration = \"...\"), parameters.csv,\n"
      "correlation.csv, identifiability.csv, targets.csv, residuals.csv, results.json, report.html.");
  command->callback([file, output_arg, &global] {
    const CalibrationJob job = LoadCalibrationJob(*file);
    EmitWarnings(job.warnings, global);
    RunCliOptions where;
    where.output_dir = *output_arg;
    OutputDirectory output(OutputPath(OutputSettings{job.output_directory},
                                      std::filesystem::path(*file).parent_path(), where,
                                      std::filesystem::path("vlt-out") / SafeFileName(job.name)));
    const std::filesystem::path& dir = output.path();
    const CalibrationResult result = Calibrate(job.data, job.options);
    // A calibration that does not fit its data is not used silently (docs/calibration.md "Fit").
    const std::string problem = CalibrationFitProblem(result);
    if (!problem.empty())
      EmitWarnings({*file + ": calibration: " + problem + "; calibration.toml says so"}, global);
    CalibrationProvenance provenance;
    provenance.instrument = job.instrument;
    provenance.created = RunCreatedTime();  // SOURCE_DATE_EPOCH when set
    provenance.vlt_version = VLT_VERSION;
    for (const std::string& f : job.data_files) provenance.data_files.emplace_back(f, Sha256File(f));
    const auto files = calibration_outputs::CalibrationFiles(job, result, provenance);
    output.Commit(AsOutputFiles(files));
    PrintWritten(files, calibration_outputs::CalibrationSummary(job, result), dir, global);
    if (!global.json && !global.quiet) {
      // Absolute: a job resolves its [tracker] calibration against the job file's directory, so a
      // path relative to this shell would name another file there (issue 34).
      const std::string path =
          std::filesystem::absolute(dir / "calibration.toml").lexically_normal().string();
      std::printf("Use it: vlt run JOB.toml --calibration %s\n", (dir / "calibration.toml").string().c_str());
      // As a TOML basic string when nothing in it needs an escape (else the option above only).
      const bool plain = std::none_of(path.begin(), path.end(), [](char c) {
        return c == '"' || c == '\\' || static_cast<unsigned char>(c) < 0x20 || c == 0x7f;
      });
      if (plain) std::printf("   or in the job: [tracker] calibration = \"%s\"\n", path.c_str());
    }
  });
}

}  // namespace vlt::cli
