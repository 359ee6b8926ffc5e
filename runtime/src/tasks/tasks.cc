// Task descriptions (vlt/tasks.h): names, minimum point counts, point-name resolution.
#include "vlt/tasks.h"

#include <algorithm>
#include <string>
#include <unordered_map>

#include "vlt/error.h"

namespace vlt {
namespace {

struct KindName {
  TaskKind kind;
  std::string_view name;
  int minimum_points;
  bool task_table;  // a [[task]] table may name it (the alignment kinds need their nominal geometry)
};

constexpr KindName kKinds[] = {
    {TaskKind::kDistance, "distance", 2, true},
    {TaskKind::kPlane, "plane", 3, true},
    {TaskKind::kSphere, "sphere", 4, true},
    {TaskKind::kCircle, "circle", 3, true},
    {TaskKind::kLine, "line", 2, true},
    {TaskKind::kTwoFace, "two_face", 2, true},
    {TaskKind::kCylinder, "cylinder", 5, true},
    {TaskKind::kCone, "cone", 6, true},
    {TaskKind::kBestFit, "best_fit", 3, false},
    {TaskKind::kBestFitScale, "best_fit_scale", 3, false},
    {TaskKind::kRps, "rps", 3, false},
    {TaskKind::kDeviation, "deviation", 3, false},
    {TaskKind::kPosition, "position", 3, false},
    {TaskKind::kProfile, "profile", 3, false},
    {TaskKind::kFlatness, "flatness", 4, true},
    {TaskKind::kStraightness, "straightness", 3, true},
    {TaskKind::kRoundness, "roundness", 4, true},
    {TaskKind::kCylindricity, "cylindricity", 6, true},
    {TaskKind::kFeatures, "features", 6, false},
};

}  // namespace

std::string_view TaskKindName(TaskKind kind) {
  for (const KindName& k : kKinds) {
    if (k.kind == kind) return k.name;
  }
  return "unknown";
}

TaskKind ParseTaskKind(std::string_view text, std::string_view where) {
  for (const KindName& k : kKinds) {
    if (k.task_table && k.name == text) return k.kind;
  }
  throw InputError(std::string(where) + ": unknown task kind '" + std::string(text) +
                   "' (expected distance, plane, sphere, circle, line, two_face, cylinder, cone, flatness, "
                   "straightness, roundness or cylindricity)");
}

int MinimumPoints(TaskKind kind) {
  for (const KindName& k : kKinds) {
    if (k.kind == kind) return k.minimum_points;
  }
  return 0;
}

std::vector<int> ResolveTaskPoints(const TaskSpec& spec, std::span<const std::string> point_names,
                                   std::string_view where) {
  const std::string prefix = std::string(where) + ": task '" + spec.name + "'";
  const int count = static_cast<int>(spec.points.size());
  if ((spec.kind == TaskKind::kDistance || spec.kind == TaskKind::kTwoFace) && count != 2) {
    throw InputError(prefix + ": " + std::string(TaskKindName(spec.kind)) + " needs exactly 2 points, " +
                     std::to_string(count) + " given");
  }
  if (count < MinimumPoints(spec.kind)) {
    throw InputError(prefix + ": " + std::string(TaskKindName(spec.kind)) + " needs at least " +
                     std::to_string(MinimumPoints(spec.kind)) + " points, " + std::to_string(count) +
                     " given");
  }
  // `points = "all"` of a job: its points in its order (the readers refuse a name used twice), so
  // the indices are 0 .. N-1 once the names are seen to be those (no hash of 10^6 names).
  if (spec.all_points && spec.points.size() == point_names.size() &&
      std::equal(spec.points.begin(), spec.points.end(), point_names.begin())) {
    std::vector<int> all(point_names.size());
    for (std::size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
    return all;
  }
  // Hash lookup: tasks over 10^5 points must not cost N^2.
  std::unordered_map<std::string_view, int> index_of;
  index_of.reserve(point_names.size());
  for (int i = 0; i < static_cast<int>(point_names.size()); ++i) {
    index_of.emplace(point_names[i], i);  // first occurrence wins
  }
  std::vector<int> indices;
  indices.reserve(spec.points.size());
  std::vector<char> used(point_names.size(), 0);
  for (const std::string& name : spec.points) {
    const auto it = index_of.find(name);
    if (it == index_of.end()) throw InputError(prefix + ": point '" + name + "' not measured");
    if (used[it->second]) throw InputError(prefix + ": point '" + name + "' listed twice");
    used[it->second] = 1;
    indices.push_back(it->second);
  }
  return indices;
}

}  // namespace vlt
