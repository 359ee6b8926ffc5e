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
  // Orientation of normals/directions and the angles of an alignment: those of the fit to the
  // estimates, so that no trial flips a sign or turns by 2 pi (vlt/fits.h TrialFitOptions).
  const FitOptions options = TrialFitOptions(spec, gum.value, gum.weights);
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
