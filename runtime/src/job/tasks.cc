// job/tasks.cc — the [[task]] tables of a job file (kind, name, points). Keys: docs/job-file.md.
#include <set>

#include "vlt/tasks.h"
#include <toml++/toml.h>

#include "job/job_detail.h"
#include "vlt/error.h"
#include "vlt/job.h"
#include "vlt/units.h"

namespace vlt::job_detail {

void ReadTasks(Section& top, Job& job) {
  const toml::node* n = top.Get("task");
  if (!n) return;
  if (!n->is_array()) throw InputError(top.Where("task") + ": expected [[task]] tables");
  std::vector<std::string> point_names = job.point_names();
  int index = 0;
  std::set<std::string> seen;
  for (const toml::node& e : *n->as_array()) {
    std::string path = "task[" + std::to_string(index++) + "]";
    if (!e.is_table()) throw InputError(job.file + ": " + path + ": expected a table");
    Section t(*e.as_table(), job.file, path);
    t.set_hint("kind, name, points");
    TaskSpec spec;
    spec.kind = ParseTaskKind(AsString(t.Require("kind"), t.Where("kind")), t.Where("kind"));
    spec.name = AsString(t.Require("name"), t.Where("name"));
    if (spec.name.empty()) throw InputError(t.Where("name") + ": empty task name");
    if (!seen.insert(spec.name).second) throw InputError(t.Where("name") + ": task '" + spec.name + "' defined twice");
    const toml::node& pts = t.Require("points");
    if (!pts.is_array()) throw InputError(t.Where("points") + ": expected an array of point names");
    for (const toml::node& p : *pts.as_array()) spec.points.push_back(AsString(p, t.Where("points")));
    t.Finish();
    job.task_points.push_back(ResolveTaskPoints(spec, point_names, t.Where("points")));
    job.tasks.push_back(std::move(spec));
  }
}


}  // namespace vlt::job_detail
