// job/alignment.cc — the part's frame in a job file: [nominal] (the CAD positions and normals of
// the points), [[alignment]] (a best fit or reference point system of measured points to
// nominal), [[deviation]] (each point's deviation from nominal in an alignment's frame) and
// [[profile]] (the extreme deviations of a set of points). Each becomes a task (vlt/tasks.h
// kBestFit, kBestFitScale, kRps, kDeviation, kPosition, kProfile) whose nominal geometry it carries, so the GUM, the Monte
// Carlo method, validation, conformity decisions and every output treat it as any task.
// Keys: docs/job-file.md "[nominal], [[alignment]], [[deviation]]"; the method: docs/tasks.md.
#include <array>
#include <cmath>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <unordered_map>

#include "job/job_detail.h"
#include "vlt/calibration.h"
#include "vlt/input_file.h"

namespace vlt::job_internal {
namespace {

struct Nominal {
  Eigen::Vector3d position;
  std::optional<Eigen::Vector3d> normal;  // unit
};

struct Alignment {
  std::string name;
  std::vector<std::string> points;
  bool scale = false;
  std::vector<std::array<bool, 3>> holds;  // rps: the axes each point holds
  int plane_points = 0, line_points = 0;   // features: the datum plane's and line's points
  std::vector<int> indices;                // of its points in the job, resolved once
  // weighting (ReadWeighting): "none" {false}, "covariance" {true}, "both" {false, true}; the
  // deviations and profiles over it take the same.
  std::vector<bool> weighted;
};

// One variant of `pattern`: its name (unique among the job's tasks) and weighting.
TaskSpec Variant(const TaskSpec& pattern, bool weighted, const std::string& task_name, Section& t,
                 std::set<std::string>& names) {
  TaskSpec spec = pattern;
  spec.name = task_name;
  spec.weighted = weighted;
  if (!names.insert(spec.name).second)
    throw InputError(t.Where("name") + ": '" + spec.name + "' is already the name of a task");
  return spec;
}

// The variants of a task over `alignment` named `name` ("<name>.<point>" for a deviation: the
// twin is "<name>_weighted.<point>"): one per weighting of the alignment.
std::vector<std::pair<bool, std::string>> Variants(const Alignment& alignment, const std::string& name,
                                                   const std::string& suffix) {
  std::vector<std::pair<bool, std::string>> out;
  for (bool weighted : alignment.weighted) {
    const bool twin = weighted && alignment.weighted.size() > 1;
    out.emplace_back(weighted, (twin ? WeightedName(name) : name) + suffix);
  }
  return out;
}

// The job's points by name, built once for all the tables (a scan's deviations must not cost N^2).
using PointIndex = std::unordered_map<std::string, int>;

// The nominal (CAD) geometry of the job's points: [nominal] csv (name, x, y, z [, i, j, k]) in
// `unit`; without [nominal], a plan's own points (their nominal positions, no normals).
std::map<std::string, Nominal> ReadNominal(Section& top, Job& job) {
  std::map<std::string, Nominal> out;
  Section s = top.Sub("nominal", false);
  if (!s.exists()) {
    if (job.mode == JobMode::kPlan) {
      for (const JobPoint& p : job.points) out[p.name] = {p.nominal, std::nullopt};
    }
    return out;
  }
  s.set_hint("csv, unit");
  std::string unit = "m";
  if (const toml::node* n = s.Get("unit")) unit = AsString(*n, s.Where("unit"));
  const double scale = UnitScale(unit, Dimension::kLength, s.Where("unit"));
  const std::string path = (job.base_dir / AsString(s.Require("csv"), s.Where("csv"))).string();
  if (const std::string problem = InputFileProblem(path); !problem.empty()) {
    throw InputError(s.Where("csv") + ": cannot read '" + path + "': " + problem);
  }
  s.Finish();
  const CsvTable table = ReadCsvFile(path, path);
  job.input_files.push_back({"nominal csv", path, Sha256File(path)});
  const std::string header = path + ": line " + std::to_string(table.header_line);
  for (const std::string& col : table.header) {
    if (col != "name" && col != "x" && col != "y" && col != "z" && col != "i" && col != "j" && col != "k") {
      throw InputError(header + ": unknown column '" + col +
                       "' (nominal CSV columns: name, x, y, z [, i, j, k])");
    }
  }
  int c[7];
  const char* names[7] = {"name", "x", "y", "z", "i", "j", "k"};
  for (int k = 0; k < 7; ++k) {
    c[k] = table.Column(names[k]);
    if (c[k] < 0 && k < 4)
      throw InputError(header + ": missing column '" + names[k] +
                       "' (nominal CSV columns: name, x, y, z [, i, j, k])");
  }
  const bool has_normals = c[4] >= 0 || c[5] >= 0 || c[6] >= 0;
  if (has_normals && (c[4] < 0 || c[5] < 0 || c[6] < 0)) {
    throw InputError(header + ": give all three normal columns i, j, k or none");
  }
  for (const CsvRow& row : table.rows) {
    const std::string where = table.Where(row);
    const std::string& name = row.fields[c[0]];
    CheckName(name, where, "point");
    Nominal n;
    for (int a = 0; a < 3; ++a) {
      n.position(a) =
          CsvQuantity(row.fields[c[1 + a]], Dimension::kLength, scale, 0, where + ": " + names[1 + a]);
      if (!std::isfinite(n.position(a)) || std::abs(n.position(a)) > kMaxRange) {
        throw InputError(where + ": " + names[1 + a] +
                         ": a nominal coordinate beyond any laser tracker's reach");
      }
    }
    if (has_normals && !(row.fields[c[4]].empty() && row.fields[c[5]].empty() && row.fields[c[6]].empty())) {
      Eigen::Vector3d v;
      for (int a = 0; a < 3; ++a)
        v(a) = CsvQuantity(row.fields[c[4 + a]], std::nullopt, 1.0, 0, where + ": " + names[4 + a]);
      // Scaled by its largest component first: (1e200, 0, 1e200) is a direction, its norm is not finite.
      const double largest = v.cwiseAbs().maxCoeff();
      if (!std::isfinite(largest) || !(largest > 0.0))
        throw InputError(where + ": the normal (i, j, k) has no direction");
      n.normal = (v / largest).normalized();
    }
    if (!out.emplace(name, n).second) throw InputError(where + ": point '" + name + "' given twice");
  }
  if (out.empty()) throw InputError(path + ": no points (nominal CSV columns: name, x, y, z [, i, j, k])");
  return out;
}

// `points` of a table: an array of names or "all" (every measured point the filter accepts).
template <class Accept>
std::vector<std::string> PointList(Section& t, const Job& job, const Accept& accept, bool required) {
  std::vector<std::string> out;
  const toml::node* pts = required ? &t.Require("points") : t.Get("points");
  if (pts == nullptr || (pts->is_string() && *pts->value<std::string>() == "all")) {
    for (const JobPoint& p : job.points) {
      if (accept(p.name)) out.push_back(p.name);
    }
    return out;
  }
  if (!pts->is_array()) throw InputError(t.Where("points") + ": expected an array of point names or \"all\"");
  for (const toml::node& p : *pts->as_array()) out.push_back(AsString(p, t.Where("points")));
  return out;
}

const Nominal& NominalOf(const std::map<std::string, Nominal>& nominal, const std::string& point,
                         const std::string& where) {
  const auto it = nominal.find(point);
  if (it == nominal.end())
    throw InputError(where + ": point '" + point + "' has no nominal position ([nominal] csv)");
  return it->second;
}

// [alignment.rps] <point> = "xyz" | "yz" | "z" | ...: the part-frame axes each point holds.
void ReadHeldAxes(Section& t, Alignment& a) {
  Section rps = t.Sub("rps", true);
  rps.set_hint("<point> = \"xyz\", \"xy\", \"z\", ...");
  for (const auto& [key, node] : rps.table()) {
    const std::string point(key.str());
    const std::string axes = AsString(node, rps.Where(point));
    std::array<bool, 3> held = {false, false, false};
    for (const char c : axes) {
      const int axis = c == 'x' ? 0 : c == 'y' ? 1 : c == 'z' ? 2 : -1;
      if (axis < 0 || held[static_cast<std::size_t>(axis)]) {
        throw InputError(rps.Where(point) +
                         ": expected the axes the point holds, each of x, y, z at most once (e.g. \"xyz\", "
                         "\"yz\", \"z\"), got '" +
                         axes + "'");
      }
      held[static_cast<std::size_t>(axis)] = true;
    }
    if (axes.empty())
      throw InputError(rps.Where(point) +
                       ": a point that holds no axis does not belong to the reference point system");
    rps.Get(point);
    a.points.push_back(point);
    a.holds.push_back(held);
  }
  rps.Finish();
  int count = 0;
  for (const std::array<bool, 3>& h : a.holds) count += h[0] + h[1] + h[2];
  if (count < 6) {
    throw InputError(rps.WhereSelf() + ": the points hold " + std::to_string(count) +
                     " directions; a part has 6 degrees of freedom (3-2-1: \"xyz\", \"yz\", \"z\")");
  }
}

// kind = "features": plane (>= 3 point names), line (>= 2), point (one name): the datum features
// (docs/tasks.md "Alignment by datum features"); the alignment's points are them in that order.
void ReadDatumFeatures(Section& t, Alignment& a) {
  if (t.Get("points") != nullptr) {
    throw InputError(t.Where("points") + ": a features alignment's points are its plane, line and point");
  }
  auto names = [&](const char* key, std::size_t minimum) {
    const toml::node& node = t.Require(key);
    if (!node.is_array()) throw InputError(t.Where(key) + ": expected an array of point names");
    std::vector<std::string> out;
    for (const toml::node& p : *node.as_array()) out.push_back(AsString(p, t.Where(key)));
    if (out.size() < minimum) {
      throw InputError(t.Where(key) + ": a datum " + key + " needs at least " + std::to_string(minimum) +
                       " points, " + std::to_string(out.size()) + " given");
    }
    return out;
  };
  const std::vector<std::string> plane = names("plane", 3), line = names("line", 2);
  const std::string point = AsString(t.Require("point"), t.Where("point"));
  std::set<std::string> seen;
  auto once = [&](const std::string& name, const char* key) {
    if (!seen.insert(name).second) {
      throw InputError(t.Where(key) + ": point '" + name +
                       "' is already a datum point of this alignment (each once)");
    }
  };
  for (const std::string& p : plane) once(p, "plane");
  for (const std::string& p : line) once(p, "line");
  once(point, "point");
  a.points = plane;
  a.points.insert(a.points.end(), line.begin(), line.end());
  a.points.push_back(point);
  a.plane_points = static_cast<int>(plane.size());
  a.line_points = static_cast<int>(line.size());
}

// One [[alignment]] table: a best_fit, rps or features task over its points.
Alignment ReadAlignment(Section& t, Job& job, const std::map<std::string, Nominal>& nominal,
                        std::set<std::string>& names) {
  t.set_hint("name, kind, points, scale, rps, plane, line, point, weighting, tolerance");
  Alignment a;
  a.name = AsString(t.Require("name"), t.Where("name"));
  CheckName(a.name, t.Where("name"), "alignment");
  if (!names.insert(a.name).second)
    throw InputError(t.Where("name") + ": '" + a.name + "' is already the name of a task or alignment");
  const std::string kind = AsString(t.Require("kind"), t.Where("kind"));
  if (kind != "best_fit" && kind != "rps" && kind != "features") {
    throw InputError(t.Where("kind") + ": unknown alignment kind '" + kind +
                     "' (expected best_fit, rps or features)");
  }
  if (const toml::node* n = t.Get("scale")) a.scale = AsBool(*n, t.Where("scale"));
  if (kind == "features") {
    if (a.scale) throw InputError(t.Where("scale") + ": a features alignment fits no scale");
    ReadDatumFeatures(t, a);
  } else if (kind == "rps") {
    if (a.scale) throw InputError(t.Where("scale") + ": a reference point system fits no scale");
    if (t.Get("points") != nullptr)
      throw InputError(t.Where("points") + ": an rps alignment's points are the keys of [alignment.rps]");
    ReadHeldAxes(t, a);
  } else {
    a.points = PointList(
        t, job, [&](const std::string& p) { return nominal.count(p) > 0; }, false);
  }
  TaskSpec spec;
  spec.where = t.WhereSelf();
  spec.name = a.name;
  spec.kind = kind == "features" ? TaskKind::kFeatures
              : kind == "rps"    ? TaskKind::kRps
              : a.scale          ? TaskKind::kBestFitScale
                                 : TaskKind::kBestFit;
  spec.points = a.points;
  auto geometry = std::make_shared<NominalGeometry>();
  geometry->positions.resize(3, static_cast<Eigen::Index>(a.points.size()));
  // An rps alignment's points are the keys of [alignment.rps]: messages name that table.
  const std::string points_where = kind == "rps"        ? t.Where("rps")
                                   : kind == "features" ? t.WhereSelf()
                                                        : t.Where("points");
  for (std::size_t i = 0; i < a.points.size(); ++i) {
    geometry->positions.col(static_cast<Eigen::Index>(i)) =
        NominalOf(nominal, a.points[i], points_where).position;
  }
  geometry->scale = a.scale;
  geometry->alignment_points = static_cast<int>(a.points.size());
  geometry->holds = a.holds;
  geometry->plane_points = a.plane_points;
  geometry->line_points = a.line_points;
  spec.nominal = geometry;
  ReadTaskTolerances(t, spec);
  const auto fits = ReadWeighting(t, spec.kind, spec.name, "alignment");
  t.Finish();
  a.indices = ResolveTaskPoints(spec, job.point_names(), points_where);
  for (const auto& [weighted, name] : fits) {
    if (name != spec.name && !names.insert(name).second)
      throw InputError(t.Where("weighting") + ": its weighted fit's name '" + name + "' is already a task's");
    TaskSpec fit = spec;
    fit.name = name;
    fit.weighted = weighted;
    a.weighted.push_back(weighted);
    job.task_points.push_back(a.indices);
    job.tasks.push_back(std::move(fit));
  }
  return a;
}

// The alignment a [[deviation]] or [[profile]] table names (`alignment`), or the job's only one.
const Alignment& AlignmentOf(Section& t, const std::vector<Alignment>& alignments) {
  if (const toml::node* n = t.Get("alignment")) {
    const std::string wanted = AsString(*n, t.Where("alignment"));
    for (const Alignment& a : alignments) {
      if (a.name == wanted) return a;
    }
    throw InputError(t.Where("alignment") + ": no [[alignment]] named '" + wanted + "'");
  }
  if (alignments.size() == 1) return alignments.front();
  throw InputError(
      t.Where("alignment") + ": required key is missing (" +
      (alignments.empty() ? std::string("give an [[alignment]] first") : "the job has several alignments") +
      ")");
}

// `points` of a [[deviation]] or [[profile]] table: names of points with a nominal normal, or
// "all" of them.
std::vector<std::string> PointsWithNormals(Section& t, const Job& job,
                                           const std::map<std::string, Nominal>& nominal) {
  const std::vector<std::string> points = PointList(
      t, job,
      [&](const std::string& p) {
        const auto it = nominal.find(p);
        return it != nominal.end() && it->second.normal;
      },
      true);
  if (points.empty()) throw InputError(t.Where("points") + ": no point with a nominal normal");
  std::set<std::string> seen;
  for (const std::string& point : points) {
    if (!seen.insert(point).second)
      throw InputError(t.Where("points") + ": point '" + point + "' listed twice");
    if (!NominalOf(nominal, point, t.Where("points")).normal) {
      throw InputError(t.Where("points") + ": point '" + point +
                       "' has no nominal normal (columns i, j, k of [nominal] csv)");
    }
  }
  return points;
}

// A task over the alignment's points and then `extra` (each once): its spec, its points' indices
// in the job (pushed to job.task_points) and its nominal geometry (positions, the alignment's
// scale and held axes); extra_index[i] is extra[i]'s index among the task's points.
std::shared_ptr<NominalGeometry> OverAlignment(const Alignment& alignment,
                                               const std::vector<std::string>& extra,
                                               const std::map<std::string, Nominal>& nominal,
                                               const PointIndex& measured, const std::string& where,
                                               TaskSpec& spec, Job& job, std::vector<int>& extra_index) {
  spec.points = alignment.points;
  std::vector<int> indices = alignment.indices;
  std::unordered_map<std::string_view, int> in_alignment;
  for (std::size_t i = 0; i < alignment.points.size(); ++i)
    in_alignment.emplace(alignment.points[i], static_cast<int>(i));
  for (const std::string& point : extra) {
    if (const auto it = in_alignment.find(point); it != in_alignment.end()) {
      extra_index.push_back(it->second);
      continue;
    }
    const auto job_index = measured.find(point);
    if (job_index == measured.end())
      throw InputError(where + ": task '" + spec.name + "': point '" + point + "' not measured");
    extra_index.push_back(static_cast<int>(spec.points.size()));
    spec.points.push_back(point);
    indices.push_back(job_index->second);
  }
  job.task_points.push_back(std::move(indices));
  auto geometry = std::make_shared<NominalGeometry>();
  geometry->alignment_points = static_cast<int>(alignment.points.size());
  geometry->scale = alignment.scale;
  geometry->holds = alignment.holds;
  geometry->plane_points = alignment.plane_points;
  geometry->line_points = alignment.line_points;
  // The frame's name as its task has it: a weighted twin's alignment is "<name>_weighted".
  geometry->alignment =
      spec.weighted && alignment.weighted.size() > 1 ? WeightedName(alignment.name) : alignment.name;
  geometry->positions.resize(3, static_cast<Eigen::Index>(spec.points.size()));
  for (std::size_t i = 0; i < spec.points.size(); ++i) {
    geometry->positions.col(static_cast<Eigen::Index>(i)) =
        NominalOf(nominal, spec.points[i], where).position;
  }
  return geometry;
}

// One [[deviation]] table: a deviation task per point, named "<name>.<point>", over the
// alignment's points and the point (once, where it is an alignment point itself).
void ReadDeviation(Section& t, Job& job, const std::map<std::string, Nominal>& nominal,
                   const PointIndex& measured, const std::vector<Alignment>& alignments,
                   std::set<std::string>& names) {
  t.set_hint("name, alignment, points, position, tolerance");
  const std::string name = AsString(t.Require("name"), t.Where("name"));
  CheckName(name, t.Where("name"), "deviation");
  const Alignment& alignment = AlignmentOf(t, alignments);
  const std::vector<std::string> points = PointsWithNormals(t, job, nominal);
  bool position = false;
  if (const toml::node* n = t.Get("position")) position = AsBool(*n, t.Where("position"));
  TaskSpec pattern;
  pattern.kind = position ? TaskKind::kPosition : TaskKind::kDeviation;
  ReadTaskTolerances(t, pattern);
  t.Finish();
  for (const std::string& point : points) {
    for (const auto& [weighted, task_name] : Variants(alignment, name, "." + point)) {
      TaskSpec spec = Variant(pattern, weighted, task_name, t, names);
      spec.where = t.WhereSelf() + " (point '" + point + "')";
      std::vector<int> index;
      const auto geometry =
          OverAlignment(alignment, {point}, nominal, measured, t.Where("points"), spec, job, index);
      geometry->point = index.front();
      geometry->normal = *NominalOf(nominal, point, t.Where("points")).normal;
      geometry->position = position;
      spec.nominal = geometry;
      job.tasks.push_back(std::move(spec));
    }
  }
}

// One [[profile]] table: one profile task over the alignment's points and its own.
void ReadProfile(Section& t, Job& job, const std::map<std::string, Nominal>& nominal,
                 const PointIndex& measured, const std::vector<Alignment>& alignments,
                 std::set<std::string>& names) {
  t.set_hint("name, alignment, points, tolerance");
  TaskSpec pattern;
  pattern.where = t.WhereSelf();
  pattern.kind = TaskKind::kProfile;
  const std::string name = AsString(t.Require("name"), t.Where("name"));
  CheckName(name, t.Where("name"), "profile");
  const Alignment& alignment = AlignmentOf(t, alignments);
  const std::vector<std::string> points = PointsWithNormals(t, job, nominal);
  ReadTaskTolerances(t, pattern);
  t.Finish();
  for (const auto& [weighted, task_name] : Variants(alignment, name, "")) {
    TaskSpec spec = Variant(pattern, weighted, task_name, t, names);
    std::vector<int> index;
    const auto geometry =
        OverAlignment(alignment, points, nominal, measured, t.Where("points"), spec, job, index);
    geometry->profile = index;
    for (const std::string& point : points)
      geometry->profile_normals.push_back(*NominalOf(nominal, point, t.Where("points")).normal);
    spec.nominal = geometry;
    job.tasks.push_back(std::move(spec));
  }
}

// The tables of array `key` of `top`, each as a Section named "<key>[i]".
template <class Read>
void ForEachTable(Section& top, Job& job, const char* key, const Read& read) {
  const toml::node* n = top.Get(key);
  if (n == nullptr) return;
  if (!n->is_array()) throw InputError(top.Where(key) + ": expected [[" + key + "]] tables");
  int index = 0;
  for (const toml::node& e : *n->as_array()) {
    const std::string path = std::string(key) + "[" + std::to_string(index++) + "]";
    if (!e.is_table()) throw InputError(job.file + ": " + path + ": expected a table");
    Section t(*e.as_table(), job.file, path);
    read(t);
  }
}

}  // namespace

void ReadAlignments(Section& top, Job& job) {
  const bool any =
      top.Get("alignment") != nullptr || top.Get("deviation") != nullptr || top.Get("profile") != nullptr;
  if (!any) {
    if (Section s = top.Sub("nominal", false); s.exists()) {
      throw InputError(
          s.WhereSelf() +
          ": a nominal is used by [[alignment]], [[deviation]] and [[profile]]; the job has none");
    }
    return;
  }
  const std::map<std::string, Nominal> nominal = ReadNominal(top, job);
  if (nominal.empty()) {
    throw InputError(
        job.file + ": nominal: required key is missing (the nominal positions of the points: [nominal] csv)");
  }
  std::set<std::string> names;
  for (const TaskSpec& t : job.tasks) names.insert(t.name);
  std::vector<Alignment> alignments;
  ForEachTable(top, job, "alignment",
               [&](Section& t) { alignments.push_back(ReadAlignment(t, job, nominal, names)); });
  PointIndex measured;
  for (std::size_t i = 0; i < job.points.size(); ++i)
    measured.emplace(job.points[i].name, static_cast<int>(i));
  ForEachTable(top, job, "deviation",
               [&](Section& t) { ReadDeviation(t, job, nominal, measured, alignments, names); });
  ForEachTable(top, job, "profile",
               [&](Section& t) { ReadProfile(t, job, nominal, measured, alignments, names); });
}

}  // namespace vlt::job_internal
