// `vlt prior PROFILE.toml [-o DIR]`: error-parameter uncertainties from a datasheet's MPE
// statements — the widest independent prior under which the simulated standard tests meet every
// statement with the stated conformance probability; writes a prior file that a job loads like a
// calibration ([tracker] calibration = "...", or `vlt run --calibration`). docs/profiles.md.
#include <cstdio>

#include "run_job.h"
#include "vlt/calibration.h"
#include "vlt/results.h"

namespace vlt::cli {

void AddPriorCommand(CLI::App& app, GlobalOptions& global) {
  auto* command = app.add_subcommand(
      "prior",
      "Derive error-parameter uncertainties from a datasheet's MPE statements (a profile); writes a prior "
      "file that jobs load like a calibration");
  auto file = std::make_shared<std::string>();
  auto output_arg = std::make_shared<std::string>();
  command->add_option("file", *file, "Profile (TOML: [tracker], [tests] layout and mpe, [prior], docs/profiles.md)")
      ->required();
  command->add_option("-o,--output", *output_arg, "Output directory (default: ./vlt-out/<name>-prior)")
      ->check(NonEmptyPath());
  command->footer(
      "Exit status: 0 success, 2 bad input or a statement no prior can meet (one line on stderr; no output\n"
      "file is written). Outputs: prior.toml (load it: vlt run JOB.toml --calibration prior.toml),\n"
      "parameters.csv, tests.csv, shares.csv, results.json, report.html.");
  command->callback([file, output_arg, &global] {
    const PriorJob job = LoadPriorJob(*file);
    EmitWarnings(job.warnings, global);
    OutputDirectory output(output_arg->empty() ? std::filesystem::path("vlt-out") / SafeFileName(job.name + "-prior")
                                               : std::filesystem::path(*output_arg));
    const std::filesystem::path& dir = output.path();
    const PriorResult result = DerivePrior(job);
    CalibrationProvenance provenance;
    provenance.instrument = job.instrument;
    provenance.created = RunCreatedTime();  // SOURCE_DATE_EPOCH when set
    provenance.vlt_version = VLT_VERSION;
    provenance.data_files.emplace_back(std::filesystem::path(*file).filename().string(), Sha256File(*file));
    const auto files = calibration_outputs::PriorFiles(job, result, provenance);
    output.Commit(AsOutputFiles(files));
    PrintWritten(files, calibration_outputs::PriorSummary(job, result), dir, global);
    if (!global.json && !global.quiet)
      std::printf("Use it: vlt run JOB.toml --calibration %s\n", (dir / "prior.toml").string().c_str());
  });
}

}  // namespace vlt::cli
