// `vlt plan JOB.toml [-o DIR] [--threads T]`: the best station for a [plan] job inside the region
// of its [optimize] section (vlt/planning.h, docs/planning.md).
#include <cstdio>

#include "run_job.h"
#include "vlt/error.h"
#include "vlt/planning.h"

namespace vlt::cli {

void AddPlanCommand(CLI::App& app, GlobalOptions& global) {
  auto* command = app.add_subcommand(
      "plan",
      "Find the station position that minimises the job's [optimize] objective inside its region "
      "(plan.json, station_map.csv, station_map.html, planned_job.toml)");
  struct PlanOptions {
    std::string job, output_dir;
    int threads = -1;
  };
  auto o = std::make_shared<PlanOptions>();
  command->add_option("job", o->job, "Job file (TOML) with [plan] points and an [optimize] section")
      ->required();
  command->add_option("-o,--output", o->output_dir, "Output directory (default ./vlt-out/<job name>-plan)")
      ->check(NonEmptyPath());
  command->add_option("--threads", o->threads, "Threads for the station map (0 = all hardware threads)")
      ->check(IntegerIn(0, 1024));
  command->footer(
      "Objective: sum of weight * term, each term an expanded uncertainty [m] as `vlt run` computes it\n"
      "with the station there. Search: NLopt GN_CRS2_LM (seeded) then LN_SBPLX; the station map shows\n"
      "the objective over the floor at the recommended height. `vlt run planned_job.toml` reproduces it.");
  command->callback([o, &global] {
    Job job = LoadJob(o->job);
    EmitWarnings(job.warnings, global);
    if (!job.optimize)
      throw InputError(job.file + ": optimize: the job has no [optimize] section (docs/planning.md)");
    RunCliOptions ro;
    ro.output_dir = o->output_dir;
    OutputDirectory output(OutputPath(OutputSettings{}, job.base_dir, ro,
                                      std::filesystem::path("vlt-out") / (SafeFileName(job.name) + "-plan")));
    const int threads = o->threads >= 0 ? o->threads : job.monte_carlo.threads;
    const StationPlan plan = PlanStation(job, threads);
    const auto files = PlanFiles(plan);
    output.Commit(AsOutputFiles(files));
    if (global.json) {
      std::printf("%s\n", files.front().second.c_str());  // plan.json
      return;
    }
    PrintWritten(files, PlanSummary(plan), output.path(), global);
  });
}

}  // namespace vlt::cli
