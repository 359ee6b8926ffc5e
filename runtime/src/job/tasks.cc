// job/tasks.cc — the [[task]] tables of a job file (kind, name, points). Keys: docs/job-file.md.
#include <cmath>
#include <optional>
#include <set>

#include "vlt/fits.h"

#include "vlt/tasks.h"
#include <toml++/toml.h>

#include "job/job_detail.h"
#include "vlt/error.h"
#include "vlt/job.h"
#include "vlt/units.h"

namespace vlt::job_internal {

// [task.tolerance.<quantity>] lower = ..., upper = ... (either or both; lengths in length units,
// direction components plain numbers).
void ReadTaskTolerances(Section& t, TaskSpec& spec) {
  Section tol = t.Sub("tolerance", false);
  if (!tol.exists()) return;
  const std::span<const TaskOutput> outputs = TaskOutputs(spec.kind);
  for (const auto& [key, node] : tol.table()) {
    const std::string name(key.str());
    const TaskOutput* output = nullptr;
    std::string list;
    for (const TaskOutput& o : outputs) {
      if (o.name == name) output = &o;
      list += (list.empty() ? "" : ", ") + std::string(o.name);
    }
    if (output == nullptr) {
      throw InputError(tol.Where(name) + ": a " + std::string(TaskKindName(spec.kind)) +
                       " task has no quantity '" + name + "' (" + list + ")");
    }
    const Dimension dim = output->unit == "m"     ? Dimension::kLength
                          : output->unit == "rad" ? Dimension::kAngle
                                                  : Dimension::kDimensionless;
    Section q = tol.Sub(name, true);
    q.set_hint("lower, upper");
    Tolerance limits;
    if (const toml::node* n = q.Get("lower")) limits.lower = AsQuantity(*n, dim, q.Where("lower"));
    if (const toml::node* n = q.Get("upper")) limits.upper = AsQuantity(*n, dim, q.Where("upper"));
    if (std::isinf(limits.lower) && std::isinf(limits.upper))
      throw InputError(q.WhereSelf() + ": give lower, upper or both");
    if (!(limits.lower < limits.upper)) throw InputError(q.Where("upper") + ": must be above lower");
    q.Finish();
    tol.Get(name);
    spec.tolerances.emplace_back(name, limits);
  }
  tol.Finish();
}

std::string WeightedName(const std::string& name) { return name + "_weighted"; }

std::vector<std::pair<bool, std::string>> ReadWeighting(Section& t, TaskKind kind, const std::string& name,
                                                        const char* table) {
  const toml::node* n = t.Get("weighting");
  const std::string value = n ? AsString(*n, t.Where("weighting")) : "none";
  if (value != "none" && value != "covariance" && value != "both") {
    throw InputError(t.Where("weighting") + ": unknown weighting '" + value +
                     "' (expected none, covariance or both)");
  }
  if (value == "none") return {{false, name}};
  if (!Weightable(kind)) {
    throw InputError(t.Where("weighting") + ": a " + std::string(TaskKindName(kind)) + " " + table +
                     " is not a least-squares fit; only plane, sphere, circle, line, cylinder, cone and the "
                     "best_fit and rps alignments are weighted by the points' covariance");
  }
  if (value == "covariance") return {{true, name}};
  return {{false, name}, {true, WeightedName(name)}};
}

void ReadTasks(Section& top, Job& job, int threads) {
  const toml::node* n = top.Get("task");
  if (!n) return;
  if (!n->is_array()) throw InputError(top.Where("task") + ": expected [[task]] tables");
  // The job's point names, copied only for a task that lists points (a scan's task over "all"
  // takes them once, into its spec).
  std::optional<std::vector<std::string>> point_names;
  int index = 0;
  std::set<std::string> seen;
  for (const toml::node& e : *n->as_array()) {
    std::string path = "task[" + std::to_string(index++) + "]";
    if (!e.is_table()) throw InputError(job.file + ": " + path + ": expected a table");
    Section t(*e.as_table(), job.file, path);
    t.set_hint("kind, name, points, weighting, tolerance");
    TaskSpec spec;
    spec.where = t.WhereSelf();
    spec.kind = ParseTaskKind(AsString(t.Require("kind"), t.Where("kind")), t.Where("kind"));
    spec.name = AsString(t.Require("name"), t.Where("name"));
    CheckName(spec.name, t.Where("name"), "task");
    if (!seen.insert(spec.name).second)
      throw InputError(t.Where("name") + ": task '" + spec.name + "' defined twice");
    const toml::node& pts = t.Require("points");
    if (pts.is_string() && *pts.value<std::string>() == "all") {
      spec.points = job.point_names(threads);  // a scan: every point of the job, in the job's order
      spec.all_points = true;
    } else if (!pts.is_array()) {
      throw InputError(t.Where("points") + ": expected an array of point names or \"all\"");
    } else {
      for (const toml::node& p : *pts.as_array()) spec.points.push_back(AsString(p, t.Where("points")));
    }
    ReadTaskTolerances(t, spec);
    const auto fits = ReadWeighting(t, spec.kind, spec.name, "task");
    t.Finish();
    if (!spec.all_points && !point_names) point_names = job.point_names();
    const std::vector<int> indices =
        ResolveTaskPoints(spec, spec.all_points ? spec.points : *point_names, t.Where("points"));
    for (std::size_t f = 0; f < fits.size(); ++f) {
      const auto& [weighted, name] = fits[f];
      if (name != spec.name && !seen.insert(name).second)
        throw InputError(t.Where("weighting") + ": its weighted fit's name '" + name +
                         "' is already a task's");
      // The last fit takes the spec itself: a scan's task over 10^6 points is not copied.
      TaskSpec fit = f + 1 < fits.size() ? spec : std::move(spec);
      fit.name = name;
      fit.weighted = weighted;
      job.task_points.push_back(indices);
      job.tasks.push_back(std::move(fit));
    }
  }
}

}  // namespace vlt::job_internal
