// job/optimize.cc — [optimize]: the region where `vlt plan` may put the station, its constraints
// and the objective it minimises (docs/planning.md; the search: runtime/src/planning/).
#include <cmath>
#include <set>

#include <toml++/toml.h>

#include "job/job_detail.h"
#include "base/shared_settings.h"
#include "vlt/error.h"
#include "vlt/fits.h"
#include "vlt/job.h"
#include "vlt/units.h"

namespace vlt::job_internal {
namespace {

Eigen::Vector3d UnitVector(const toml::node& node, const std::string& where) {
  const toml::array* a = node.as_array();
  if (!a || a->size() != 3) throw InputError(where + ": expected [nx, ny, nz] (3 numbers)");
  Eigen::Vector3d v;
  for (int i = 0; i < 3; ++i) v[i] = AsNumber(*a->get(static_cast<std::size_t>(i)), where);
  const double norm = v.norm();
  if (!std::isfinite(norm) || !(norm > 0.0))
    throw InputError(where + ": the direction must be finite and non-zero");
  return v / norm;
}

// Twice the signed area of a polygon (shoelace).
double TwiceArea(const std::vector<Eigen::Vector2d>& p) {
  double a = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const Eigen::Vector2d& u = p[i];
    const Eigen::Vector2d& v = p[(i + 1) % p.size()];
    a += u.x() * v.y() - v.x() * u.y();
  }
  return a;
}

std::vector<Eigen::Vector2d> ReadFloor(const toml::node& node, const std::string& where) {
  std::vector<Eigen::Vector2d> floor;
  if (node.is_string()) {
    // A box: "xmin,xmax,ymin,ymax".
    const std::vector<double> v = LengthList(node, 4, where);
    if (!(v[1] > v[0]) || !(v[3] > v[2]))
      throw InputError(where + ": empty region (xmax <= xmin or ymax <= ymin)");
    floor = {{v[0], v[2]}, {v[1], v[2]}, {v[1], v[3]}, {v[0], v[3]}};
  } else if (const toml::array* a = node.as_array()) {
    // A polygon: [[x, y], ...], vertices in order.
    for (std::size_t i = 0; i < a->size(); ++i) {
      const std::string w = where + "[" + std::to_string(i) + "]";
      const std::vector<double> v = LengthList(*a->get(i), 2, w);
      floor.emplace_back(v[0], v[1]);
    }
    if (floor.size() < 3) throw InputError(where + ": a polygon needs at least 3 vertices [x, y]");
  } else {
    throw InputError(where + ": expected \"xmin,xmax,ymin,ymax\" or a polygon [[x, y], ...]");
  }
  for (const Eigen::Vector2d& p : floor) {
    if (!p.allFinite() || p.cwiseAbs().maxCoeff() > kMaxRange) {
      throw InputError(where + ": coordinates must be finite and within 10 km");
    }
  }
  if (!(std::abs(TwiceArea(floor)) > 1e-12))
    throw InputError(where + ": empty region (the polygon has no area)");
  return floor;
}

// Height of the origin: a range "zmin,zmax", one length (fixed), default the job's station tz.
void ReadHeight(Section& s, const Job& job, OptimizeSettings& o) {
  const double tz = job.setup.pose ? job.setup.pose->tz.estimate : 0.0;
  o.z_min = o.z_max = tz;
  const toml::node* n = s.Get("height");
  if (!n) return;
  const bool one =
      !n->is_array() && !(n->is_string() && n->value<std::string>()->find(',') != std::string::npos);
  const std::vector<double> z = LengthList(*n, one ? 1 : 2, s.Where("height"));
  o.z_min = z.front();
  o.z_max = z.back();
  if (!(o.z_max >= o.z_min)) throw InputError(s.Where("height") + ": empty range (zmax < zmin)");
  if (std::abs(o.z_min) > kMaxRange || std::abs(o.z_max) > kMaxRange) {
    throw InputError(s.Where("height") + ": must be within 10 km");
  }
}

// What the tracker can measure from the station: its range limits and the targets' acceptance
// angle about their normals.
void ReadSightConstraints(Section& s, const Job& job, OptimizeSettings& o) {
  if (const toml::node* n = s.Get("min_range"))
    o.min_range = AsQuantity(*n, Dimension::kLength, s.Where("min_range"));
  if (const toml::node* n = s.Get("max_range"))
    o.max_range = AsQuantity(*n, Dimension::kLength, s.Where("max_range"));
  if (!(o.min_range >= 0.0)) throw InputError(s.Where("min_range") + ": must be >= 0");
  if (!(o.max_range > o.min_range) || o.max_range > kMaxRange) {
    throw InputError(s.Where("max_range") + ": must be above min_range and at most 10 km");
  }
  if (const toml::node* n = s.Get("acceptance_angle")) {
    o.acceptance_angle = AsQuantity(*n, Dimension::kAngle, s.Where("acceptance_angle"));
    if (!(o.acceptance_angle > 0.0 && o.acceptance_angle <= std::acos(-1.0) / 2)) {
      throw InputError(s.Where("acceptance_angle") + ": must be a half-angle above 0 and at most 90 deg");
    }
  }
  if (const toml::node* n = s.Get("target_normal"))
    o.target_normal = UnitVector(*n, s.Where("target_normal"));
  Section normals = s.Sub("normals", false);
  if (normals.exists()) {
    const std::vector<std::string> names = job.point_names();
    const std::set<std::string> known(names.begin(), names.end());
    std::vector<std::string> keys;
    for (const auto& [key, value] : normals.table()) keys.emplace_back(key.str());
    for (const std::string& key : keys) {
      if (!known.count(key)) throw InputError(normals.Where(key) + ": no point '" + key + "' in the job");
      o.normals.emplace_back(key, UnitVector(*normals.Get(key), normals.Where(key)));
    }
    normals.Finish();
  }
  if (o.acceptance_angle > 0.0 && o.target_normal.isZero() && o.normals.empty()) {
    throw InputError(s.Where("acceptance_angle") +
                     ": needs the targets' normals (target_normal or [optimize.normals])");
  }
}

void ReadKeepOut(Section& s, const Job& job, OptimizeSettings& o) {
  const toml::node* n = s.Get("keep_out");
  if (!n) return;
  const toml::array* a = n->as_array();
  if (!a) throw InputError(s.Where("keep_out") + ": expected [[optimize.keep_out]] tables {name, box}");
  for (std::size_t i = 0; i < a->size(); ++i) {
    const std::string path = s.path() + ".keep_out[" + std::to_string(i) + "]";
    if (!a->get(i)->is_table()) throw InputError(job.file + ": " + path + ": expected a table {name, box}");
    Section k(*a->get(i)->as_table(), job.file, path);
    k.set_hint("name, box");
    KeepOutBox box;
    box.name = "keep_out[" + std::to_string(i) + "]";
    if (const toml::node* nm = k.Get("name")) box.name = AsString(*nm, k.Where("name"));
    const std::vector<double> v = LengthList(k.Require("box"), 6, k.Where("box"));
    box.min = {v[0], v[2], v[4]};
    box.max = {v[1], v[3], v[5]};
    if (!(box.max.array() > box.min.array()).all()) {
      throw InputError(k.Where("box") + ": empty box (every max must exceed its min)");
    }
    k.Finish();
    o.keep_out.push_back(box);
  }
}

// One term of the objective: "points" or "<task>.<quantity>", a length with a GUM uncertainty
// (`where`: the key of the quantity), and its weight (> 0, checked by the caller).
ObjectiveTerm ReadObjectiveTerm(const Job& job, const std::string& quantity, double weight,
                                const std::string& where) {
  ObjectiveTerm t;
  t.quantity = quantity;
  t.weight = weight;
  if (quantity == "points") return t;
  const std::size_t dot = quantity.find('.');
  std::string names;
  for (const TaskSpec& task : job.tasks) names += (names.empty() ? "" : ", ") + task.name;
  if (dot == std::string::npos) {
    throw InputError(where + ": '" + quantity + "': expected \"points\" or \"<task>.<quantity>\" (tasks: " +
                     (names.empty() ? "none" : names) + ")");
  }
  const std::string task_name = quantity.substr(0, dot), output = quantity.substr(dot + 1);
  for (std::size_t i = 0; i < job.tasks.size(); ++i) {
    if (job.tasks[i].name != task_name) continue;
    t.task = static_cast<int>(i);
    const auto outputs = TaskOutputs(job.tasks[i].kind);
    std::string known;
    for (std::size_t q = 0; q < outputs.size(); ++q) {
      // Lengths with a GUM uncertainty at nominal points (form quantities have none there:
      // vlt/fits.h; their uncertainty comes from Monte Carlo in `vlt run`).
      const bool form =
          outputs[q].name == "flatness" || outputs[q].name == "straightness" || outputs[q].name == "rms";
      if (outputs[q].unit != "m" || form) continue;
      known += (known.empty() ? "" : ", ") + std::string(outputs[q].name);
      if (outputs[q].name == output) t.output = static_cast<int>(q);
    }
    if (t.output < 0) {
      throw InputError(where + ": task '" + task_name + "' has no length quantity '" + output +
                       "' with a GUM " + "uncertainty (it has: " + known +
                       "; form quantities such as flatness have none at " + "nominal points)");
    }
    return t;
  }
  throw InputError(where + ": no task '" + task_name + "' (tasks: " + (names.empty() ? "none" : names) + ")");
}

// Objective: one quantity, or terms {quantity, weight} summed.
void ReadObjective(Section& s, const Job& job, OptimizeSettings& o) {
  const toml::node* n = s.Get("objective");
  if (!n) {
    o.objective.push_back(ObjectiveTerm{});
    return;
  }
  if (n->is_string()) {
    o.objective.push_back(ReadObjectiveTerm(job, *n->value<std::string>(), 1.0, s.Where("objective")));
  } else if (const toml::array* a = n->as_array(); a && !a->empty()) {
    for (std::size_t i = 0; i < a->size(); ++i) {
      const std::string path = s.path() + ".objective[" + std::to_string(i) + "]";
      if (!a->get(i)->is_table())
        throw InputError(job.file + ": " + path + ": expected a table {quantity, weight}");
      Section t(*a->get(i)->as_table(), job.file, path);
      t.set_hint("quantity, weight");
      const double weight = t.Get("weight") ? AsNumber(*t.Get("weight"), t.Where("weight")) : 1.0;
      // Relative weights: a ratio beyond 1e6 between two terms is one term alone (and a sum of
      // weights near 1e308 would overflow the search's score).
      if (!(weight > 0.0 && weight <= 1e6)) throw InputError(t.Where("weight") + ": a weight above 0, at most 1e6");
      o.objective.push_back(ReadObjectiveTerm(job, AsString(t.Require("quantity"), t.Where("quantity")),
                                              weight, t.Where("quantity")));
      t.Finish();
    }
  } else {
    throw InputError(s.Where("objective") +
                     ": expected \"points\", \"<task>.<quantity>\" or [[optimize.objective]] "
                     "tables {quantity, weight}");
  }
}

// Station map spacing: default 1/40 of the floor's longer side.
void ReadStationMapStep(Section& s, OptimizeSettings& o) {
  Eigen::Vector2d lo = o.floor.front(), hi = o.floor.front();
  for (const Eigen::Vector2d& p : o.floor) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  o.step = (hi - lo).maxCoeff() / 40.0;
  if (const toml::node* n = s.Get("step")) {
    o.step = AsQuantity(*n, Dimension::kLength, s.Where("step"));
    if (!(o.step > 0.0)) throw InputError(s.Where("step") + ": must be positive");
  }
  const double nodes =
      (std::floor((hi.x() - lo.x()) / o.step) + 1) * (std::floor((hi.y() - lo.y()) / o.step) + 1);
  if (!(nodes <= 250000))
    throw InputError(s.Where("step") + ": the station map would have more than 250000 nodes");
}

}  // namespace

void ReadOptimize(Section& top, Job& job) {
  Section s = top.Sub("optimize", false);
  if (!s.exists()) return;
  s.set_hint(
      "floor, height, min_range, max_range, acceptance_angle, target_normal, normals, keep_out, objective, "
      "step, evaluations, seed");
  if (job.mode != JobMode::kPlan) {
    throw InputError(s.WhereSelf() +
                     ": a station is planned for a [plan] job (nominal points); the readings of a "
                     "[readings] job were taken from their station");
  }
  OptimizeSettings o;
  o.where = s.WhereSelf();
  o.seed = job.monte_carlo.seed;
  o.floor = ReadFloor(s.Require("floor"), s.Where("floor"));
  ReadHeight(s, job, o);
  ReadSightConstraints(s, job, o);
  ReadKeepOut(s, job, o);
  ReadObjective(s, job, o);
  ReadStationMapStep(s, o);
  if (const toml::node* n = s.Get("evaluations")) {
    const std::int64_t v = AsInteger(*n, s.Where("evaluations"));
    if (v < 100 || v > 1000000) throw InputError(s.Where("evaluations") + ": must be 100 .. 1000000");
    o.evaluations = v;
  }
  ReadSeed(s, "seed", o.seed);
  s.Finish();
  job.optimize = std::move(o);
}

}  // namespace vlt::job_internal
