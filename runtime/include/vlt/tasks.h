// vlt/tasks.h — what a measurement task asks for: WHICH points and WHICH feature.
//
// A task is a quantity derived from several measured points: the distance between two named
// points, the two-face difference of a point measured in both faces, or a plane / sphere /
// circle / line fitted to a named set of points. The fit itself
// (value and d value / d point coordinates) is computed by vlt/fits.h; this header only
// describes the task, names its output quantities and resolves point names to indices.
// The GUM engine (vlt/gum.h) propagates the point uncertainties, including the correlation the
// shared inputs induce between points, to the task quantities.
#pragma once

#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "vlt/conformity.h"

namespace vlt {

enum class TaskKind {
  kDistance,  // |p2 - p1| between exactly two points
  kPlane,     // least-squares plane (>= 3 points) + flatness
  kSphere,    // least-squares sphere (>= 4 points): centre, radius
  kCircle,    // least-squares 3-D circle (>= 3 points): centre, radius, normal
  kLine,      // least-squares 3-D line (>= 2 points)
  kTwoFace,   // p2 - p1 (dx, dy, dz) of exactly two points: the same nominal point measured in
              // the front face (first) and the back face (second); the faces are not checked
};

// "distance", "plane", "sphere", "circle", "line", "two_face".
std::string_view TaskKindName(TaskKind kind);
// Inverse of TaskKindName; throws InputError "<where>: unknown task kind '<text>' (expected ...)".
TaskKind ParseTaskKind(std::string_view text, std::string_view where);
// Minimum number of points the feature needs (2, 3, 4, 3, 2, 2).
int MinimumPoints(TaskKind kind);

struct TaskSpec {
  std::string name;  // user's label, e.g. "bore_A"
  TaskKind kind = TaskKind::kDistance;
  std::vector<std::string> points;  // names of the measured points used, in order
  // Tolerances of some of its quantities (vlt/conformity.h): quantity name (TaskOutputs(kind),
  // e.g. "distance", "flatness", "radius") and the interval, SI units.
  std::vector<std::pair<std::string, Tolerance>> tolerances;
  bool all_points = false;  // `points = "all"`: every point of the job, in job order

  // The tolerance of `quantity`, or nullptr.
  const Tolerance* ToleranceOf(std::string_view quantity) const {
    for (const auto& [name, limits] : tolerances) {
      if (name == quantity) return &limits;
    }
    return nullptr;
  }
};

// Indices of spec.points in `point_names`. Throws InputError "<where>: task '<name>': point
// '<p>' not measured" for an unknown name, and "... needs at least N points" / "distance needs
// exactly 2 points" (two_face: "two_face needs exactly 2 points") for a wrong count, and
// "... point '<p>' listed twice" for a duplicate.
std::vector<int> ResolveTaskPoints(const TaskSpec& spec, std::span<const std::string> point_names,
                                   std::string_view where);

}  // namespace vlt
