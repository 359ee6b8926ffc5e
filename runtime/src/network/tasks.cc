// network/tasks.cc — NetworkTasks (vlt/network.h): task quantities over adjusted targets with the
// joint covariance of the adjustment (docs/network.md "Tasks").
#include <cmath>

#include "vlt/error.h"
#include "vlt/fits.h"
#include "vlt/gum.h"
#include "vlt/network.h"

namespace vlt {

std::vector<NetworkTaskResult> NetworkTasks(const std::vector<TaskSpec>& tasks, const NetworkResult& result,
                                            const std::string& where) {
  std::vector<std::string> names;
  for (const AdjustedTarget& t : result.targets) names.push_back(t.name);
  std::vector<NetworkTaskResult> out;
  for (const TaskSpec& spec : tasks) {
    const std::vector<int> index = ResolveTaskPoints(spec, names, where + ": task '" + spec.name + "'");
    const int n = static_cast<int>(index.size());
    Eigen::Matrix3Xd points(3, n);
    Eigen::MatrixXd c(3 * n, 3 * n);
    for (int a = 0; a < n; ++a) {
      points.col(a) = result.targets[index[a]].position;
      for (int b = 0; b < n; ++b) {
        c.block<3, 3>(3 * a, 3 * b) =
            result.covariance.block<3, 3>(result.target_offset[index[a]], result.target_offset[index[b]]);
      }
    }
    FitOptions options = TaskFitOptions(spec, true);
    if (spec.weighted) {
      auto v = std::make_shared<PointCovariance>();
      v->dense = c;
      options.covariance = std::move(v);
    }
    const FitResult fit = FitTask(spec.kind, points, options, where + ": task '" + spec.name + "'");
    NetworkTaskResult r;
    r.name = spec.name;
    r.kind = spec.kind;
    r.weighted = spec.weighted;
    r.value = fit.values;
    r.covariance = fit.jacobian * c * fit.jacobian.transpose();
    r.differentiable = fit.differentiable;
    const double k = result.k;
    r.u = r.covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
    for (int q = 0; q < static_cast<int>(fit.outputs.size()); ++q) {
      if (!fit.differentiable[q]) r.u(q) = 0.0;
    }
    r.U = k * r.u;
    for (int q = 0; q < static_cast<int>(fit.outputs.size()); ++q) {
      r.quantities.emplace_back(fit.outputs[q].name);
      r.units.emplace_back(fit.outputs[q].unit);
      const Tolerance* tolerance = spec.ToleranceOf(fit.outputs[q].name);
      if (tolerance && fit.differentiable[q]) {
        r.conformity.push_back(DecideConformity(*tolerance, r.value(q), r.u(q), r.U(q)));
      } else {
        r.conformity.push_back(std::nullopt);
      }
      r.tolerance.push_back(tolerance ? DescribeTolerance(*tolerance, std::string(fit.outputs[q].unit))
                                      : std::string());
      r.limits.push_back(tolerance ? std::optional<Tolerance>(*tolerance) : std::nullopt);
    }
    if (!r.value.allFinite() || !r.covariance.allFinite()) {
      throw NumericalError(where + ": task '" + spec.name + "' has no finite result");
    }
    out.push_back(std::move(r));
  }
  return out;
}

}  // namespace vlt
