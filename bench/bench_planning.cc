// Station planning (vlt/planning.h PlanStation), one core:
//   planning/station/<evaluations>   examples/station_plan.toml: one station over a 4 m x 4 m x 1 m
//                                    region for a 100-point plate with a plane task (objective: the
//                                    largest |U| + U of the plane's centroid_z), keep-out boxes,
//                                    minimum range and acceptance angle; the global search with
//                                    the given number of evaluations, Subplex, the 41 x 41 station
//                                    map — what `vlt plan --threads 1` computes
//   planning/evaluate                one objective evaluation (100 points + the plane task)
// Target (docs/performance.md, issue: planning): the whole plan <= 10 s on one core.
#include <string>

#include <benchmark/benchmark.h>

#include "vlt/planning.h"

namespace vlt::bench {
namespace {

const Job& PlanJob() {
  static const Job job = LoadJob(std::string(VLT_SOURCE_DIR) + "/examples/station_plan.toml");
  return job;
}

void BM_PlanStation(benchmark::State& state) {
  Job job = PlanJob();
  job.optimize->evaluations = state.range(0);
  StationPlan plan;
  for (auto _ : state) {
    plan = PlanStation(job, 1);
    benchmark::DoNotOptimize(plan.map.U_norm.data());
  }
  state.counters["evaluations"] =
      static_cast<double>(plan.global_evaluations + plan.local_evaluations + plan.map_evaluations);
  state.counters["objective_um"] = plan.recommended.objective * 1e6;
}

void BM_EvaluateStation(benchmark::State& state) {
  const Job& job = PlanJob();
  const Eigen::Vector3d station(1.0, 1.6, 1.0);
  for (auto _ : state) {
    StationEvaluation e = EvaluateStation(job, station);
    benchmark::DoNotOptimize(e.terms.data());
  }
}

BENCHMARK(BM_PlanStation)->Name("planning/station")->Arg(1500)->Arg(4000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_EvaluateStation)->Name("planning/evaluate")->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace vlt::bench
