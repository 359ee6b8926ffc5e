// `vlt map JOB.toml --plane z=0 --extent xmin,xmax,ymin,ymax --step 0.25m [-o DIR]`
// `vlt map JOB.toml --box xmin,xmax,ymin,ymax,zmin,zmax --step 0.5m`
// The GUM expanded uncertainty |U| = sqrt(Ux^2 + Uy^2 + Uz^2) over a grid of part-frame points
// (MapResult in vlt/results.h), written as map.csv and map.html (and printed as JSON with --json).
// Without --plane/--box the job's [map] section is used.
#include <algorithm>
#include <cstdio>

#include "run_job.h"
#include "vlt/error.h"

namespace vlt::cli {

void AddMapCommand(CLI::App& app, GlobalOptions& global) {
  auto* command = app.add_subcommand("map",
                                     "Map the GUM expanded uncertainty of the job's tracker over a plane or "
                                     "a box of part-frame points (map.csv, map.html)");
  struct MapOptions {
    std::string job, plane, extent, box, step = "0.25 m", output_dir, seed;
    int threads = -1;
    bool mcm = false;
    std::int64_t trials = -1;
  };
  auto o = std::make_shared<MapOptions>();
  command->add_option("job", o->job, "Job file (TOML): tracker, environment, station, part")->required();
  command->add_option("--plane", o->plane, "Plane of the grid: x=<v>, y=<v> or z=<v> (e.g. z=0, z=1.2m)");
  command->add_option(
      "--extent", o->extent,
      "Ranges of the plane's two free axes: amin,amax,bmin,bmax (e.g. 0,4,-1,1 or 0m,4m,-1m,1m)");
  command->add_option("--box", o->box, "A 3-D grid: xmin,xmax,ymin,ymax,zmin,zmax");
  command->add_option("--step", o->step, "Grid spacing (default 0.25 m; e.g. 0.1m, 250mm)");
  command->add_option("-o,--output", o->output_dir,
                      "Output directory (default: [output] directory of the job, else ./vlt-out/<job name>)")
      ->check(NonEmptyPath());
  command->add_option("--threads", o->threads, "Threads (0 = all hardware threads)")
      ->check(IntegerIn(0, 1024));
  command->add_flag(
      "--mcm", o->mcm,
      "Also the Monte Carlo map: every node through the job's Monte Carlo engine, with the GUM-vs-MCM "
      "verdict per node (as [map] monte_carlo = true)");
  command
      ->add_option("--trials", o->trials,
                   "Monte Carlo trials per node (default: the job's [monte_carlo] trials)")
      ->check(IntegerIn(1, 1000000000));
  command->add_option("--seed", o->seed, "Monte Carlo seed (default: the job's)")->check(UnsignedInteger64());
  command->footer(
      "Map value: |U| = sqrt(Ux^2 + Uy^2 + Uz^2), U_i = k u_i (part frame, k from the job's coverage\n"
      "probability). Nodes within 1 mm of the tracker's vertical axis or beyond 10 km are skipped and reported.\n"
      "Per source: U_s = k sqrt(trace of the source's part of U_y), adding up in quadrature to |U|\n"
      "(map.csv columns U_group_*, U_*; map.html 'Show').");
  command->callback([o, &global] {
    Job job = LoadJob(o->job);
    EmitWarnings(job.warnings, global);
    MapSettings settings;
    if (!o->plane.empty() || !o->box.empty()) {
      if (!o->plane.empty() && !o->box.empty())
        throw InputError("command line: --plane and --box exclude each other");
      if (!o->plane.empty()) {
        if (o->extent.empty()) throw InputError("command line: --extent: required with --plane");
        settings = ParseMapPlane(o->plane, o->extent, o->step, "command line");
      } else {
        if (!o->extent.empty()) throw InputError("command line: --extent goes with --plane, not with --box");
        settings = ParseMapBox(o->box, o->step, "command line");
      }
    } else if (job.map) {
      settings = *job.map;
    } else {
      throw InputError("command line: give --plane and --extent, or --box (the job has no [map] section)");
    }
    RunCliOptions ro;
    ro.output_dir = o->output_dir;
    OutputDirectory output(
        OutputPath(job.output, job.base_dir, ro, std::filesystem::path("vlt-out") / SafeFileName(job.name)));
    MeasurementModel model(job.setup);
    int threads = o->threads >= 0 ? o->threads : job.monte_carlo.threads;
    MapResult map = ComputeMap(model, settings, job.monte_carlo.coverage_probability, threads);
    MarkJobOnMap(job, model, map);
    if (o->mcm || settings.monte_carlo) {
      RunCliOptions run;
      run.trials = o->trials;
      run.seed = o->seed;
      run.threads = threads;
      AddMonteCarloToMap(job, RunOptionsFrom(run, job.monte_carlo, global), map);
    }
    std::vector<std::pair<std::string, std::string>> files = {
        {"map.csv", MapCsv(map)}, {"map.html", MapHtml(map, job.name + ": " + settings.description)}};
    output.Commit(AsOutputFiles(files));
    if (global.json) {  // the same object as "map" in results.json (docs/results.md)
      std::printf("%s\n", MapJson(map).c_str());
      return;
    }
    if (global.quiet) return;
    double lo = 1e300, hi = 0.0;
    std::size_t n = 0;
    for (std::size_t i = 0; i < map.nodes.size(); ++i) {
      if (!map.computed[i]) continue;
      lo = std::min(lo, map.U_norm[i]);
      hi = std::max(hi, map.U_norm[i]);
      ++n;
    }
    std::printf("Map of job '%s' (model %s): %s\n", job.name.c_str(), job.setup.model->name,
                settings.description.c_str());
    std::printf("|U| = sqrt(Ux^2+Uy^2+Uz^2), k = %.3f (p = %g): %.1f .. %.1f µm over %zu nodes\n", map.k,
                map.coverage_probability, n ? lo * 1e6 : 0.0, hi * 1e6, n);
    if (!map.sources.empty() && n > 0) {
      // Where each source dominates: the number of nodes per dominant source, largest first.
      std::vector<std::size_t> count(map.sources.size(), 0);
      for (std::size_t i = 0; i < map.nodes.size(); ++i) {
        if (map.computed[i]) ++count[static_cast<std::size_t>(map.dominant[i])];
      }
      std::vector<std::size_t> order(count.size());
      for (std::size_t s = 0; s < order.size(); ++s) order[s] = s;
      std::stable_sort(order.begin(), order.end(),
                       [&](std::size_t a, std::size_t b) { return count[a] > count[b]; });
      std::printf("Dominant source:");
      for (std::size_t s : order) {
        if (count[s] > 0) std::printf(" %s at %zu node(s);", map.sources[s].name.c_str(), count[s]);
      }
      std::printf("\n");
    }
    if (map.has_mcm) {
      std::size_t validated = 0, inconclusive = 0, failed = 0;
      for (std::size_t i = 0; i < map.nodes.size(); ++i) {
        if (!map.computed[i]) continue;
        validated += map.verdict[i] == "validated";
        inconclusive += map.verdict[i] == "inconclusive";
        failed += map.verdict[i] == "not validated";
      }
      std::printf(
          "Monte Carlo (%lld trials, seed %llu): GUM validated at %zu node(s), not validated at %zu, "
          "inconclusive at %zu (JCGM 101 8)\n",
          static_cast<long long>(map.mcm_trials), static_cast<unsigned long long>(map.mcm_seed), validated,
          failed, inconclusive);
    }
    if (!map.skipped.empty()) {
      std::printf("Skipped %zu node(s):\n", map.skipped.size());
      for (std::size_t i = 0; i < map.skipped.size() && i < 10; ++i)
        std::printf("  %s\n", map.skipped[i].c_str());
      if (map.skipped.size() > 10) std::printf("  ... (all in map.csv)\n");
    }
    std::printf("Wrote %s/: map.csv, map.html\n", output.path().string().c_str());
  });
}

}  // namespace vlt::cli
