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

#include <array>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <Eigen/Core>

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
  kCylinder,  // least-squares cylinder (>= 5 points): axis point, direction, radius, cylindricity
  kCone,      // least-squares cone (>= 6 points): axis point, direction, radius, half-angle, form
  // The part's frame (docs/tasks.md "Alignment to nominal"): not [[task]] kinds, made by the job's
  // [[alignment]] and [[deviation]] tables, which give the nominal geometry (TaskSpec::nominal).
  kBestFit,       // rigid best fit (6 DOF) of >= 3 measured points to their nominal positions
  kBestFitScale,  // the same with a scale (7 parameters)
  kRps,           // reference point system: chosen part-frame directions of chosen points (3-2-1)
  kDeviation,     // one point's deviation from nominal in the part frame of an alignment
  kPosition,      // the same and its ISO 1101 position (a hole's or a pin's axis point)
  kProfile,       // the extreme deviations along the normals of a set of points (ISO 1101 profile)
  // Form by the minimum-zone (Chebyshev) definition of ISO 1101, beside the least-squares one
  // (docs/tasks.md "Form by minimum zone"): Monte Carlo only (not differentiable).
  kFlatness,      // two parallel planes (>= 4 points), ISO 12781-1
  kStraightness,  // a cylinder about a line in space (>= 3 points), ISO 12780-1
  kRoundness,     // two concentric circles in the least-squares circle's plane (>= 4 points), ISO 12181-1
  kCylindricity,  // two coaxial cylinders (>= 6 points), ISO 12180-1
  kFeatures,      // alignment by datum features (plane, line, point: >= 3 + 2 + 1 points), [[alignment]]
};

// "distance", "plane", "sphere", "circle", "line", "two_face", "cylinder", "cone", "best_fit",
// "best_fit_scale", "rps", "deviation", "position", "profile", "flatness", "straightness",
// "roundness", "cylindricity", "features".
std::string_view TaskKindName(TaskKind kind);
// Inverse of TaskKindName for the kinds a [[task]] table may name (distance ... cone, the forms); throws
// InputError "<where>: unknown task kind '<text>' (expected ...)".
TaskKind ParseTaskKind(std::string_view text, std::string_view where);
// Minimum number of points the feature needs (2, 3, 4, 3, 2, 2, 5, 6, 3, 3, 3, 3, 3, 3, 4, 3, 4, 6, 6).
int MinimumPoints(TaskKind kind);

// The nominal (CAD, part-frame) geometry of an alignment or deviation task, SI. An alignment maps
// the measured points x_i onto their nominal positions n_i: part = s R x + t (s = 1 without a
// scale), minimising sum |s R x_i + t - n_i|^2 (docs/tasks.md).
struct NominalGeometry {
  Eigen::Matrix3Xd positions;  // column i: nominal position of the task's point i [m]
  bool scale = false;          // the alignment fits a scale too
  int alignment_points = 0;    // the first alignment_points points define the alignment
  // RPS: per alignment point, which part-frame axes (x, y, z) it holds (a reference point
  // system, e.g. 3-2-1: "xyz", "yz", "z"); empty for a best fit (every axis of every point).
  std::vector<std::array<bool, 3>> holds;
  // Features (kind features): the first plane_points alignment points are the primary datum (a
  // plane), the next line_points the secondary (a line), the last one the tertiary (a point); 0:
  // not a features alignment. The nominal datums are the same fits of the nominal positions.
  int plane_points = 0;
  int line_points = 0;
  // Deviation, position: the point (index into the task's points) whose deviation s R x + t - n
  // is reported, and its nominal unit normal (surface normal, or a hole's axis) [1].
  int point = -1;
  bool position = false;  // kPosition: the ISO 1101 position too
  // Profile: the points (indices into the task's points) whose deviations it spans, and the unit
  // normal of each.
  std::vector<int> profile;
  std::vector<Eigen::Vector3d> profile_normals;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  std::string alignment;  // deviation: the alignment's name
};

struct TaskSpec {
  std::string name;  // user's label, e.g. "bore_A"
  TaskKind kind = TaskKind::kDistance;
  std::vector<std::string> points;  // names of the measured points used, in order
  // Tolerances of some of its quantities (vlt/conformity.h): quantity name (TaskOutputs(kind),
  // e.g. "distance", "flatness", "radius") and the interval, SI units.
  std::vector<std::pair<std::string, Tolerance>> tolerances;
  bool all_points = false;  // `points = "all"`: every point of the job, in job order
  std::string where{};      // the table that defined it, for messages ("job.toml: alignment[0]")
  // weighting = "covariance": the fit is weighted by the points' covariance (vlt/fits.h
  // FitOptions::covariance; docs/tasks.md "Fits weighted by the points' covariance").
  bool weighted = false;
  // best_fit, best_fit_scale, deviation: the nominal geometry (shared: Monte Carlo trials copy it).
  std::shared_ptr<const NominalGeometry> nominal{};

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
