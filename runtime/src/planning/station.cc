// planning/station.cc — the objective and constraints at a station position, and the search for
// the best one (vlt/planning.h, docs/planning.md): station map, NLopt GN_CRS2_LM, then LN_SBPLX.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>

#include <nlopt.hpp>

#include "base/format.h"
#include "parallel/pool.h"
#include "vlt/error.h"
#include "vlt/gum.h"
#include "vlt/planning.h"

namespace vlt {
namespace {

// Even-odd rule (the boundary counts as inside within rounding).
bool InsidePolygon(const std::vector<Eigen::Vector2d>& poly, const Eigen::Vector2d& p) {
  bool inside = false;
  for (std::size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const Eigen::Vector2d& a = poly[i];
    const Eigen::Vector2d& b = poly[j];
    if ((a.y() > p.y()) != (b.y() > p.y()) &&
        p.x() < (b.x() - a.x()) * (p.y() - a.y()) / (b.y() - a.y()) + a.x()) {
      inside = !inside;
    }
  }
  return inside;
}

double DistanceToSegment(const Eigen::Vector2d& p, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const Eigen::Vector2d ab = b - a;
  const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  return (a + t * ab - p).norm();
}

// 0 inside the polygon, else the distance to it [m].
double OutsidePolygon(const std::vector<Eigen::Vector2d>& poly, const Eigen::Vector2d& p) {
  double d = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++)
    d = std::min(d, DistanceToSegment(p, poly[j], poly[i]));
  if (d < 1e-12 || InsidePolygon(poly, p)) return 0.0;
  return d;
}

// How far the station stands inside the box or above it [m] (0 when clear). The tracker stands
// on the floor: its stand goes down from the origin, so the space above a box (a table, a jig) is
// as closed to it as the box; below a box (a crane beam) it may stand.
double DepthInside(const KeepOutBox& box, const Eigen::Vector3d& p) {
  if (!(p.z() > box.min.z())) return 0.0;
  const double depth =
      std::min((p.head<2>() - box.min.head<2>()).minCoeff(), (box.max.head<2>() - p.head<2>()).minCoeff());
  return depth > 0.0 ? depth : 0.0;
}

// Does the open segment a -> b pass through the interior of the box? (slab method; a segment that
// only touches a face or an edge does not.)
bool Blocks(const KeepOutBox& box, const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  double t0 = 0.0, t1 = 1.0;
  const Eigen::Vector3d d = b - a;
  for (int k = 0; k < 3; ++k) {
    if (std::abs(d[k]) < 1e-15) {
      if (a[k] <= box.min[k] || a[k] >= box.max[k]) return false;
      continue;
    }
    double lo = (box.min[k] - a[k]) / d[k], hi = (box.max[k] - a[k]) / d[k];
    if (lo > hi) std::swap(lo, hi);
    t0 = std::max(t0, lo);
    t1 = std::min(t1, hi);
  }
  return t1 - t0 > 1e-9;
}

std::string Fmt(const char* format, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

UncertainInput PoseInput(const char* name, const char* unit) {
  UncertainInput in;
  in.name = name;
  in.unit = unit;
  in.group = "pose";
  return in;
}

// The job's setup with the station origin at `station` (a zero pose with u = 0 when the job has
// none, which leaves every uncertainty as it is).
MeasurementSetup SetupAt(const Job& job, const Eigen::Vector3d& station) {
  MeasurementSetup setup = job.setup;
  if (!setup.pose) {
    setup.pose =
        StationPose{PoseInput("pose.rx", "rad"), PoseInput("pose.ry", "rad"), PoseInput("pose.rz", "rad"),
                    PoseInput("pose.tx", "m"),   PoseInput("pose.ty", "m"),   PoseInput("pose.tz", "m")};
  }
  setup.pose->tx.estimate = station.x();
  setup.pose->ty.estimate = station.y();
  setup.pose->tz.estimate = station.z();
  return setup;
}

Eigen::Vector3d NormalOf(const OptimizeSettings& o, const std::string& point) {
  for (const auto& [name, normal] : o.normals) {
    if (name == point) return normal;
  }
  return o.target_normal;
}

}  // namespace

StationEvaluation EvaluateStation(const Job& job, const Eigen::Vector3d& station) {
  if (!job.optimize)
    throw InputError(job.file + ": optimize: the job has no [optimize] section (docs/planning.md)");
  const OptimizeSettings& o = *job.optimize;
  StationEvaluation e;
  e.station = station;
  auto fail = [&](const std::string& constraint, const std::string& why, double amount) {
    if (e.reason.empty()) e.reason = why;
    if (std::find(e.failed.begin(), e.failed.end(), constraint) == e.failed.end()) e.failed.push_back(constraint);
    e.violation += amount;
  };
  // The numbers that decide, in full (a range 0.99999994 m against a min_range of 1 m).
  const auto exact = [](double v) { return base_internal::Num(v); };
  // The region: floor polygon, height range, keep-out boxes.
  const double outside = OutsidePolygon(o.floor, station.head<2>());
  if (outside > 0.0) fail("floor", "outside the floor by " + Fmt("%.3g", outside) + " m", outside);
  const double below = o.z_min - station.z(), above = station.z() - o.z_max;
  if (below > 1e-12) fail("height", "below the height range by " + Fmt("%.3g", below) + " m", below);
  if (above > 1e-12) fail("height", "above the height range by " + Fmt("%.3g", above) + " m", above);
  for (const KeepOutBox& box : o.keep_out) {
    const double depth = DepthInside(box, station);
    if (depth > 0.0)
      fail("keep-out '" + box.name + "'", std::string(station.z() < box.max.z() ? "inside " : "above ") + box.name, depth);
  }
  // Every point: range, line of sight, acceptance angle.
  for (const JobPoint& p : job.points) {
    const Eigen::Vector3d d = station - p.nominal;
    const double range = d.norm();
    if (range < o.min_range)
      fail("min_range", "point '" + p.name + "': range " + exact(range) + " m below min_range " + exact(o.min_range) + " m",
           o.min_range - range);
    if (range > o.max_range)
      fail("max_range", "point '" + p.name + "': range " + exact(range) + " m above max_range " + exact(o.max_range) + " m",
           range - o.max_range);
    for (const KeepOutBox& box : o.keep_out) {
      if (Blocks(box, station, p.nominal))
        fail("line of sight", "point '" + p.name + "': line of sight blocked by " + box.name, 0.1);
    }
    if (o.acceptance_angle > 0.0 && range > 0.0) {
      const Eigen::Vector3d n = NormalOf(o, p.name);
      if (!n.isZero()) {
        const double angle = std::acos(std::clamp(n.dot(d) / range, -1.0, 1.0));
        if (angle > o.acceptance_angle) {
          fail("acceptance angle",
               "point '" + p.name + "': incidence " + Fmt("%.1f", angle * 180.0 / std::acos(-1.0)) +
                   " deg beyond the acceptance angle " + Fmt("%g", o.acceptance_angle * 180.0 / std::acos(-1.0)) + " deg",
               angle - o.acceptance_angle);
        }
      }
    }
  }
  if (e.violation > 0.0) return e;

  // The objective, computed as `vlt run` computes it (RunJob: JobReadings, PropagatePoints,
  // PropagateTask) with the station here.
  MeasurementModel model(SetupAt(job, station));
  std::vector<PointReadings> readings;
  readings.reserve(job.points.size());
  for (const JobPoint& p : job.points) {
    PointReadings r;
    r.name = p.name;
    try {
      r.readings = ReadingsForPartPoint(model, p.nominal, p.face == Face::kBack, p.name);
    } catch (const NumericalError& error) {
      fail("the readings", error.what(), 1e-3);
      return e;
    }
    readings.push_back(std::move(r));
  }
  GumOptions gum;
  gum.coverage_probability = job.monte_carlo.coverage_probability;
  gum.budgets = false;
  gum.threads = 1;
  e.terms.assign(o.objective.size(), 0.0);
  bool points_needed = false;
  for (const ObjectiveTerm& t : o.objective) points_needed = points_needed || t.task < 0;
  double largest = 0.0;
  if (points_needed) {
    for (const PointUncertainty& u : PropagatePoints(model, readings, gum))
      largest = std::max(largest, u.U_part.norm());
  }
  std::vector<std::optional<TaskUncertainty>> tasks(job.tasks.size());
  for (std::size_t i = 0; i < o.objective.size(); ++i) {
    const ObjectiveTerm& t = o.objective[i];
    if (t.task < 0) {
      e.terms[i] = largest;
      continue;
    }
    auto& task = tasks[static_cast<std::size_t>(t.task)];
    if (!task) task = PropagateTask(model, readings, job.tasks[static_cast<std::size_t>(t.task)], gum);
    e.terms[i] = task->U[t.output];
  }
  for (std::size_t i = 0; i < o.objective.size(); ++i) e.objective += o.objective[i].weight * e.terms[i];
  if (!std::isfinite(e.objective)) {
    fail("a finite objective", "the objective is not finite here", 1.0);
    e.objective = 0.0;
    return e;
  }
  e.feasible = true;
  return e;
}

namespace {

// The search's view of a position: a feasible one's objective over the sum of the weights (a
// weighted mean of expanded uncertainties, m) mapped onto [0, 1) by m / (1 + m), which keeps
// their order; an infeasible one kInfeasibleObjective (1) + its violation. So every feasible
// position scores below every infeasible one whatever the weights and uncertainties (with the
// objective itself, weights of 1e5 put feasible positions above 1 m and behind infeasible ones).
double Score(const StationEvaluation& e, double weight_sum) {
  if (!e.feasible) return kInfeasibleObjective + e.violation;
  const double mean = e.objective / weight_sum;
  return mean / (1.0 + mean);
}

// Rounded to 1 um, the resolution the planned job is written with (planning/outputs.cc).
Eigen::Vector3d RoundToMicrometre(const Eigen::Vector3d& v) {
  Eigen::Vector3d r;
  for (int k = 0; k < 3; ++k) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.6f", v[k]);
    r[k] = std::strtod(buf, nullptr);
  }
  return r;
}

std::string NloptVersion() {
  int major = 0, minor = 0, bugfix = 0;
  nlopt::version(major, minor, bugfix);
  return std::to_string(major) + "." + std::to_string(minor) + "." + std::to_string(bugfix);
}

// The search for the station: the region's bounding box, the best position evaluated so far
// (by the searches and the station map) and the count of evaluations of the current phase.
struct StationSearch {
  const Job& job;
  const OptimizeSettings& o;
  StationPlan& plan;
  Eigen::Vector2d lo, hi;  // bounding box of the floor
  bool fixed_height = false;
  unsigned dims = 3;
  std::vector<double> lower, upper;
  StationEvaluation best;
  double best_score = std::numeric_limits<double>::infinity();
  double weight_sum = 0.0;  // of the objective's terms (Score)
  std::map<std::string, int> failed_at_nodes;  // constraint -> map nodes where it failed
  std::int64_t* counter = nullptr;

  StationSearch(const Job& job, StationPlan& plan);
  Eigen::Vector3d Position(const std::vector<double>& x) const {
    return Eigen::Vector3d(x[0], x[1], fixed_height ? o.z_min : x[2]);
  }
  double Objective(const std::vector<double>& x);
  static double Trampoline(const std::vector<double>& x, std::vector<double>&, void* data) {
    return static_cast<StationSearch*>(data)->Objective(x);
  }
  void SearchGlobally();
  void RefineLocally();
  std::vector<StationEvaluation> MapStations(int threads);
  std::string ObjectiveText() const;
  void KeepFeasibleNodes(const std::vector<StationEvaluation>& at);
  void Recommend(std::size_t map_nodes);
};

StationSearch::StationSearch(const Job& job, StationPlan& plan) : job(job), o(*job.optimize), plan(plan) {
  lo = o.floor.front();
  hi = o.floor.front();
  for (const Eigen::Vector2d& p : o.floor) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  fixed_height = o.z_max == o.z_min;
  dims = fixed_height ? 2 : 3;
  for (const ObjectiveTerm& t : o.objective) weight_sum += t.weight;
  lower = {lo.x(), lo.y()};
  upper = {hi.x(), hi.y()};
  if (!fixed_height) {
    lower.push_back(o.z_min);
    upper.push_back(o.z_max);
  }
}

double StationSearch::Objective(const std::vector<double>& x) {
  const StationEvaluation e = EvaluateStation(job, Position(x));
  ++*counter;
  const double s = Score(e, weight_sum);
  if (s < best_score) {
    best_score = s;
    best = e;
  }
  return s;
}

// Global: controlled random search with local mutation (Kaelo & Ali 2006), NLopt's generator
// seeded for a reproducible search.
void StationSearch::SearchGlobally() {
  nlopt::srand(o.seed);
  counter = &plan.global_evaluations;
  nlopt::opt global(nlopt::GN_CRS2_LM, dims);
  global.set_lower_bounds(lower);
  global.set_upper_bounds(upper);
  global.set_min_objective(&StationSearch::Trampoline, this);
  global.set_maxeval(static_cast<int>(o.evaluations));
  std::vector<double> x(dims);
  for (unsigned k = 0; k < dims; ++k) x[k] = 0.5 * (lower[k] + upper[k]);
  double f = 0.0;
  try {
    global.optimize(x, f);
  } catch (const nlopt::roundoff_limited&) {
    // The best point so far is kept in `best`.
  } catch (const std::runtime_error&) {
    // NLopt's generic failure: the best point so far is kept in `best`.
  }
}

// Local: Subplex (Rowan 1990) from the best point, to 1 um.
void StationSearch::RefineLocally() {
  counter = &plan.local_evaluations;
  if (!best.feasible) return;
  nlopt::opt local(nlopt::LN_SBPLX, dims);
  local.set_lower_bounds(lower);
  local.set_upper_bounds(upper);
  local.set_min_objective(&StationSearch::Trampoline, this);
  local.set_xtol_abs(1e-6);
  local.set_maxeval(2000);
  std::vector<double> x = {best.station.x(), best.station.y()};
  if (!fixed_height) x.push_back(best.station.z());
  std::vector<double> step(dims, std::max(o.step, 1e-3));
  local.set_initial_step(step);
  double f = 0.0;
  try {
    local.optimize(x, f);
  } catch (const nlopt::roundoff_limited&) {
  } catch (const std::runtime_error&) {}
}

// The station map at the best height: the objective over the floor (infeasible nodes skipped).
std::vector<StationEvaluation> StationSearch::MapStations(int threads) {
  MapSettings grid;
  grid.kind = MapSettings::Kind::kPlane;
  grid.fixed_axis = 2;
  const double height = best.feasible ? best.station.z() : o.z_min;
  grid.level = height;
  grid.min = {lo.x(), lo.y(), height};
  grid.max = {hi.x(), hi.y(), height};
  grid.step = o.step;
  char description[256];
  std::snprintf(description, sizeof description,
                "station positions z = %.4g m, x %.4g .. %.4g m, y %.4g .. %.4g m, step %.4g m", height,
                lo.x(), hi.x(), lo.y(), hi.y(), o.step);
  grid.description = description;
  MapResult& map = plan.map;
  map.settings = grid;
  map.coverage_probability = job.monte_carlo.coverage_probability;
  map.k = NormalCoverageFactor(map.coverage_probability);
  map.value_name = "objective";
  map.nodes = grid.Nodes();
  const std::size_t n = map.nodes.size();
  std::vector<StationEvaluation> at(n);
  parallel_internal::ForEachChunk(n, 64, threads, [&](std::size_t, std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) at[i] = EvaluateStation(job, map.nodes[i]);
  });
  plan.map_evaluations = static_cast<std::int64_t>(n);
  return at;
}

std::string StationSearch::ObjectiveText() const {
  std::string objective_text;
  for (const ObjectiveTerm& t : o.objective) {
    objective_text += (objective_text.empty() ? "" : " + ") +
                      (t.weight == 1.0 ? "" : Fmt("%g * ", t.weight)) +
                      (t.task < 0 ? std::string("max |U| of the points") : "U(" + t.quantity + ")");
  }
  return objective_text;
}

void StationSearch::KeepFeasibleNodes(const std::vector<StationEvaluation>& at) {
  MapResult& map = plan.map;
  const std::size_t n = at.size();
  map.computed.assign(n, 0);
  map.U.assign(n, Eigen::Vector3d::Zero());
  map.U_norm.assign(n, 0.0);
  map.quantity = "Objective " + ObjectiveText() +
                 " [µm] with the station at each node (k = " + Fmt("%.4g", map.k) +
                 ", p = " + Fmt("%g", map.coverage_probability) + ")";
  for (std::size_t i = 0; i < n; ++i) {
    if (at[i].feasible) {
      map.computed[i] = 1;
      map.U_norm[i] = at[i].objective;
      if (Score(at[i], weight_sum) < best_score) {  // a grid node better than the searches: keep it
        best_score = Score(at[i], weight_sum);
        best = at[i];
      }
    } else {
      char node[96];
      std::snprintf(node, sizeof node, "%.6g,%.6g,%.6g m: ", map.nodes[i].x(), map.nodes[i].y(),
                    map.nodes[i].z());
      map.skipped.push_back(node + at[i].reason);
      for (const std::string& constraint : at[i].failed) ++failed_at_nodes[constraint];
    }
  }
}

void StationSearch::Recommend(std::size_t map_nodes) {
  if (!best.feasible) {
    // Which constraints rule the region out, and at how many map nodes each: the one at every
    // node is the one to relax.
    std::vector<std::pair<int, std::string>> tally;
    for (const auto& [constraint, nodes] : failed_at_nodes) tally.emplace_back(nodes, constraint);
    std::sort(tally.begin(), tally.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
    std::string failed;
    for (const auto& [nodes, constraint] : tally)
      failed += (failed.empty() ? "" : ", ") + constraint + " at " + std::to_string(nodes);
    throw InputError(o.where + ": no feasible station in the region (" +
                     std::to_string(plan.global_evaluations) + " positions searched and " +
                     std::to_string(map_nodes) + " map nodes; failed: " + (failed.empty() ? "-" : failed) +
                     " of the nodes; e.g. " + (best.reason.empty() ? std::string("none evaluated") : best.reason) + ")");
  }
  // The recommendation as it is written (1 um): evaluated there, so that `vlt run` on the planned
  // job reproduces its objective.
  plan.recommended = EvaluateStation(job, RoundToMicrometre(best.station));
  if (!plan.recommended.feasible) plan.recommended = best;  // rounding crossed a boundary
  const Eigen::Vector3d own = job.setup.pose
                                  ? Eigen::Vector3d(job.setup.pose->tx.estimate, job.setup.pose->ty.estimate,
                                                    job.setup.pose->tz.estimate)
                                  : Eigen::Vector3d::Zero();
  plan.job_station = EvaluateStation(job, own);
  plan.map.markers.push_back({"recommended", plan.recommended.station});
  plan.map.markers.push_back({"job's station", own});
}

}  // namespace

StationPlan PlanStation(const Job& job, int threads) {
  if (!job.optimize)
    throw InputError(job.file + ": optimize: the job has no [optimize] section (docs/planning.md)");
  const auto start = std::chrono::steady_clock::now();
  StationPlan plan;
  plan.job = &job;
  plan.settings = *job.optimize;
  plan.nlopt_version = NloptVersion();
  StationSearch search(job, plan);
  search.SearchGlobally();
  search.RefineLocally();
  const std::vector<StationEvaluation> at = search.MapStations(threads);
  search.KeepFeasibleNodes(at);
  search.Recommend(at.size());
  plan.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return plan;
}

}  // namespace vlt
