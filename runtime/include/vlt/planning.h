// vlt/planning.h — where to put the tracker (`vlt plan`, docs/planning.md).
//
// A [plan] job with an [optimize] section (vlt/job.h OptimizeSettings) gives the region where the
// station may stand (a floor polygon, a height range), the constraints of a real station (keep-out
// boxes that may not hold it nor lie under it and that block lines of sight, minimum and maximum range, the
// reflector's acceptance angle against the targets' normals) and an objective: a weighted sum of
// expanded uncertainties [m] — the largest |U| of the points and/or U of task quantities — each
// computed exactly as `vlt run` computes it with the station at the candidate position (the pose
// translation t of [station]; its rotation and every uncertainty stay those of the job).
//
// The search (deterministic for a given seed): NLopt's controlled random search (GN_CRS2_LM,
// its generator seeded) finds the basin over the whole region; NLopt's Subplex (LN_SBPLX) refines
// from the best point found; the station map (the objective on a grid over the floor at the best
// height) shows the landscape, and a node better than both searches would be taken. Feasible
// positions score m / (1 + m) < 1, m their objective over the sum of the weights; infeasible
// positions kInfeasibleObjective + their violation, which draws both searches back into the
// feasible set; they are never recommended.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "vlt/job.h"
#include "vlt/results.h"

namespace vlt {

// The search's score of an infeasible position (plus its violation): above every feasible one's,
// m / (1 + m) < 1 (m: the objective over the sum of the weights, m).
inline constexpr double kInfeasibleObjective = 1.0;

// The objective at one station position.
struct StationEvaluation {
  Eigen::Vector3d station = Eigen::Vector3d::Zero();  // origin in the part frame [m]
  bool feasible = false;
  std::string reason;         // why not feasible ("" when feasible), e.g. "point 'P3': range
                              // 0.4 m below min_range 1 m"
  std::vector<std::string> failed;  // every constraint that failed, once each: "floor", "height",
                                    // "keep-out 'table'", "min_range", "max_range",
                                    // "line of sight", "acceptance angle" (and "the readings",
                                    // "a finite objective" where the model cannot be evaluated)
  double violation = 0.0;     // how far from feasible (m, rad and counts summed; 0 if feasible)
  double objective = 0.0;     // sum of weight * term [m] (feasible only)
  std::vector<double> terms;  // per OptimizeSettings::objective term, unweighted [m]
};

// The objective and the constraints at `station` for `job` (which must have [optimize]).
StationEvaluation EvaluateStation(const Job& job, const Eigen::Vector3d& station);

struct StationPlan {
  const Job* job = nullptr;
  OptimizeSettings settings;
  StationEvaluation recommended;  // rounded to 1 um where that stays feasible; written to the planned job exactly
  StationEvaluation job_station;  // at the job's own [station] (tx, ty, tz)
  std::int64_t global_evaluations = 0;
  std::int64_t local_evaluations = 0;
  std::int64_t map_evaluations = 0;
  std::string global_algorithm = "GN_CRS2_LM";
  std::string local_algorithm = "LN_SBPLX";
  std::string nlopt_version;
  double seconds = 0.0;
  MapResult map;  // the objective over the floor at the recommended height
};

// Plans the station. InputError (the job's file and optimize key) when the job has no
// [optimize] section or no position in the region is feasible.
StationPlan PlanStation(const Job& job, int threads = 0);

// Files of a plan: plan.json ("schema": "vlt-plan/1"), station_map.csv, station_map.html and
// planned_job.toml (the job with the recommended station; docs/planning.md).
std::vector<std::pair<std::string, std::string>> PlanFiles(const StationPlan& plan);
std::string PlanSummary(const StationPlan& plan);

}  // namespace vlt
