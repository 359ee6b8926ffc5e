// Tasks in the Monte Carlo engine: each trial refits the drawn points with vlt/fits.h, the same
// definition the GUM engine linearises, so the fitting algorithm is itself propagated.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>

#include "results/internal.h"
#include "vlt/fits.h"

namespace vlt::results_internal {

McmTask MakeMcmTask(const TaskSpec& spec, const std::vector<int>& point_indices, const TaskUncertainty& gum) {
  McmTask task;
  task.name = spec.name;
  task.points = point_indices;
  std::span<const TaskOutput> outputs = TaskOutputs(spec.kind);
  for (const TaskOutput& o : outputs) {
    task.output_names.push_back(spec.name + "." + std::string(o.name));
    task.output_units.push_back(std::string(o.unit));
  }
  // Orientation of normals/directions: that of the fit to the estimates, so that no trial flips
  // the sign (vlt/fits.h FitOptions::orientation).
  FitOptions options;
  options.jacobian = false;
  auto component = [&](const char* name) {
    for (std::size_t q = 0; q < gum.quantities.size(); ++q) {
      if (gum.quantities[q] == name && q < static_cast<std::size_t>(gum.value.size())) return gum.value[q];
    }
    return 0.0;
  };
  if (spec.kind == TaskKind::kPlane || spec.kind == TaskKind::kCircle) {
    options.orientation = {component("normal_x"), component("normal_y"), component("normal_z")};
  } else if (spec.kind == TaskKind::kLine) {
    options.orientation = {component("direction_x"), component("direction_y"), component("direction_z")};
  }
  const TaskKind kind = spec.kind;
  const std::string where = "task '" + spec.name + "' (Monte Carlo trial)";
  const std::size_t n_out = outputs.size();
  task.evaluate = [kind, options, where, n_out](std::span<const Eigen::Vector3d> points,
                                                std::span<double> out) {
    Eigen::Matrix3Xd m(3, static_cast<Eigen::Index>(points.size()));
    for (std::size_t i = 0; i < points.size(); ++i) m.col(static_cast<Eigen::Index>(i)) = points[i];
    FitResult fit = FitTask(kind, m, options, where);
    for (std::size_t q = 0; q < n_out; ++q) out[q] = fit.values[static_cast<Eigen::Index>(q)];
  };
  return task;
}

}  // namespace vlt::results_internal
