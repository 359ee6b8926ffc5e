// GUM engine, tasks over several points (vlt/gum.h, docs/gum.md "Tasks"):
//   cov_task = (G J_s) U_s (G J_s)^T + sum_j G_j (J_r,j U_r,j J_r,j^T) G_j^T
// G J_s (k x S) is accumulated point by point; no 3N x 3N or 3N x S matrix is ever formed.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "gum/internal.h"
#include "parallel/pool.h"
#include "vlt/error.h"
#include "vlt/fits.h"
#include "vlt/gum.h"

namespace vlt {
namespace {

using gum_internal::PointLabel;

// Points per work item (and per partial sum, added in item order: the same bits for any thread
// count): a task over a scan of 10^5 points offers 196 items, 8 for each of 16 threads (issue 33).
constexpr std::size_t kChunk = 512;

// What one chunk of points adds: G_j J_s,j summed (k x S) and the reading covariance (k x k).
struct Partial {
  Eigen::MatrixXd g_js;
  Eigen::MatrixXd cov_readings;
};

}  // namespace

std::vector<Eigen::Vector3d> PointEstimates(const MeasurementModel& model,
                                            std::span<const PointReadings> points, int threads) {
  const Eigen::VectorXd x = model.shared_estimates();
  std::vector<Eigen::Vector3d> y(points.size());
  parallel_internal::ForEachChunk(
      points.size(), kChunk, threads, [&](std::size_t, std::size_t begin, std::size_t end) {
        for (std::size_t i = begin; i < end; ++i) {
          model.Evaluate(points[i].readings.data(), x.data(), y[i].data());
          if (!y[i].allFinite()) {
            throw NumericalError(PointLabel(points[i].name, i) + "the model gives a non-finite result");
          }
        }
      });
  return y;
}

void PropagateTaskCovariance(const MeasurementModel& model, std::span<const PointReadings> points,
                             std::span<const int> indices, const Eigen::MatrixXd& g,
                             const GumOptions& options, TaskUncertainty& result) {
  const int k = static_cast<int>(g.rows());
  const int num_shared = model.num_shared();
  const std::size_t n = indices.size();
  if (g.cols() != static_cast<Eigen::Index>(3 * n)) {
    throw std::invalid_argument("PropagateTaskCovariance: G must have 3 columns per point");
  }
  const Eigen::VectorXd x = model.shared_estimates();
  const std::size_t num_chunks = (n + kChunk - 1) / kChunk;
  std::vector<Partial> partials(num_chunks);
  parallel_internal::ForEachChunk(
      n, kChunk, options.threads, [&](std::size_t c, std::size_t begin, std::size_t end) {
        Partial& p = partials[c];
        p.g_js = Eigen::MatrixXd::Zero(k, num_shared);
        p.cov_readings = Eigen::MatrixXd::Zero(k, k);
        std::vector<double> js(3 * num_shared);
        Eigen::Map<const Eigen::MatrixXd> js_map(js.data(), 3, num_shared);
        Eigen::MatrixXd b(k, 3);
        for (std::size_t j = begin; j < end; ++j) {
          const PointReadings& point = points[indices[j]];
          const Eigen::Vector3d& r = point.readings;
          if (!r.allFinite() || !(r(0) > 0.0)) {
            throw NumericalError(PointLabel(point.name, indices[j]) +
                                 "range reading must be positive and finite (zero range is "
                                 "singular)");
          }
          Eigen::Vector3d y;
          Eigen::Matrix3d jr;
          model.EvaluateWithJacobian(r.data(), x.data(), y.data(), jr.data(), js.data());
          const auto gj = g.middleCols(3 * j, 3);
          p.g_js.noalias() += gj * js_map;
          b.noalias() = gj * (jr * model.reading_uncertainty(r(0)).asDiagonal());
          p.cov_readings.noalias() += b * b.transpose();
        }
      });
  // Merge in chunk order: bit-identical for any thread count.
  Eigen::MatrixXd g_js = Eigen::MatrixXd::Zero(k, num_shared);
  Eigen::MatrixXd cov_readings = Eigen::MatrixXd::Zero(k, k);
  for (const Partial& p : partials) {
    g_js += p.g_js;
    cov_readings += p.cov_readings;
  }

  const gum_internal::SharedFactor factor = gum_internal::MakeSharedFactor(model);
  Eigen::MatrixXd a(k, num_shared);
  factor.Apply(g_js.data(), a.data(), k);
  result.covariance = cov_readings + a * a.transpose();
  if (!result.covariance.allFinite()) {
    throw NumericalError("task '" + result.name + "': non-finite covariance");
  }
  result.u = result.covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
  result.k = NormalCoverageFactor(options.coverage_probability);
  result.U = result.k * result.u;

  // Budget by group: each group's covariance with the correlations inside it, J_g F_g (J_g F_g)^T
  // with F_g the factor of the group's marginal covariance (the columns of A of the group when no
  // correlation links it to another group). Correlations between groups add the cross terms, the
  // entry "correlation" (total minus the groups; may be negative): the entries add up to the total.
  const Eigen::VectorXd total = result.covariance.diagonal();
  auto share = [&](const Eigen::VectorXd& v) {
    Eigen::VectorXd s(k);
    for (int i = 0; i < k; ++i) s(i) = total(i) > 0.0 ? v(i) / total(i) : 0.0;
    return s;
  };
  result.budget.clear();
  result.budget.push_back({"readings", cov_readings.diagonal(), share(cov_readings.diagonal())});
  const char* const groups[] = {"parameter", "environment", "pose", "thermal"};
  Eigen::VectorXd groups_sum = Eigen::VectorXd::Zero(k);
  bool between_groups = false;
  for (const char* group : groups) {
    std::vector<bool> in_group(num_shared, false);
    bool present = false;
    for (int s = 0; s < num_shared; ++s) {
      in_group[s] = model.shared_inputs()[s].group == group;
      present = present || in_group[s];
    }
    if (!present) continue;
    Eigen::VectorXd v = Eigen::VectorXd::Zero(k);
    if (factor.Separates(in_group)) {
      for (int s = 0; s < num_shared; ++s) {
        if (in_group[s]) v += a.col(s).cwiseAbs2();
      }
    } else {
      between_groups = true;
      Eigen::MatrixXd a_group(k, num_shared);
      factor.Marginal(in_group).Apply(g_js.data(), a_group.data(), k);
      v = a_group.rowwise().squaredNorm();
    }
    groups_sum += v;
    result.budget.push_back({group, v, share(v)});
  }
  if (between_groups) {
    const Eigen::VectorXd v = a.rowwise().squaredNorm() - groups_sum;
    result.budget.push_back({"correlation", v, share(v)});
  }
  std::stable_sort(result.budget.begin(), result.budget.end(),
                   [](const TaskGroupContribution& l, const TaskGroupContribution& r) {
                     return l.share.sum() > r.share.sum();
                   });

  // Per shared input: (G J_s column * u)^2; last column every cross term of correlated inputs
  // (the shared variance minus the inputs' own).
  result.shared_input_names.clear();
  result.shared_input_variance = Eigen::MatrixXd::Zero(k, num_shared + 1);
  for (int s = 0; s < num_shared; ++s) {
    result.shared_input_names.push_back(model.shared_inputs()[s].name);
    result.shared_input_variance.col(s) = (g_js.col(s) * factor.u(s)).cwiseAbs2();
  }
  result.shared_input_variance.col(num_shared) =
      a.rowwise().squaredNorm() - result.shared_input_variance.leftCols(num_shared).rowwise().sum();
}

PointCovariance TaskPointCovariance(const MeasurementModel& model, std::span<const PointReadings> points,
                                    std::span<const int> indices, int threads) {
  const int num_shared = model.num_shared();
  const std::size_t n = indices.size();
  const Eigen::VectorXd x = model.shared_estimates();
  const gum_internal::SharedFactor factor = gum_internal::MakeSharedFactor(model);
  PointCovariance v;
  v.blocks.resize(n);
  v.shared.resize(3 * static_cast<Eigen::Index>(n), num_shared);
  parallel_internal::ForEachChunk(n, kChunk, threads, [&](std::size_t, std::size_t begin, std::size_t end) {
    Eigen::Matrix<double, 3, Eigen::Dynamic> js(3, num_shared), a(3, num_shared);
    for (std::size_t j = begin; j < end; ++j) {
      const PointReadings& point = points[static_cast<std::size_t>(indices[j])];
      const Eigen::Vector3d& r = point.readings;
      Eigen::Vector3d y;
      Eigen::Matrix3d jr;
      model.EvaluateWithJacobian(r.data(), x.data(), y.data(), jr.data(), js.data());
      const Eigen::Matrix3d b = jr * model.reading_uncertainty(r(0)).asDiagonal();
      v.blocks[j] = b * b.transpose();
      factor.Apply(js.data(), a.data(), 3);
      v.shared.middleRows(3 * static_cast<Eigen::Index>(j), 3) = a;
    }
  });
  return v;
}

TaskUncertainty PropagateTask(const MeasurementModel& model, std::span<const PointReadings> points,
                              const TaskSpec& task, const GumOptions& options) {
  std::vector<std::string> names;
  names.reserve(points.size());
  for (const PointReadings& p : points) names.push_back(p.name);
  const std::vector<int> indices = ResolveTaskPoints(task, names, "task");
  return PropagateTask(model, points, task, indices, options);
}

TaskUncertainty PropagateTask(const MeasurementModel& model, std::span<const PointReadings> points,
                              const TaskSpec& task, std::span<const int> indices, const GumOptions& options) {
  // The part-frame estimates of the task's points, in the task's order.
  const Eigen::VectorXd x = model.shared_estimates();
  Eigen::Matrix3Xd coordinates(3, indices.size());
  parallel_internal::ForEachChunk(
      indices.size(), kChunk, options.threads, [&](std::size_t, std::size_t begin, std::size_t end) {
        for (std::size_t j = begin; j < end; ++j) {
          const PointReadings& point = points[static_cast<std::size_t>(indices[j])];
          model.Evaluate(point.readings.data(), x.data(),
                         coordinates.col(static_cast<Eigen::Index>(j)).data());
          if (!coordinates.col(static_cast<Eigen::Index>(j)).allFinite()) {
            throw NumericalError(PointLabel(point.name, static_cast<std::size_t>(indices[j])) +
                                 "the model gives a non-finite result");
          }
        }
      });
  FitOptions fit_options = TaskFitOptions(task, true);
  fit_options.threads = options.threads;
  if (task.weighted) {
    fit_options.covariance =
        std::make_shared<const PointCovariance>(TaskPointCovariance(model, points, indices, options.threads));
  }
  // G = d task / d point coordinates from the fit itself (vlt/fits.h), at the estimates.
  const FitResult fit = FitTask(task.kind, coordinates, fit_options, "task '" + task.name + "'");

  TaskUncertainty result;
  result.name = task.name;
  result.kind = task.kind;
  for (const TaskOutput& out : fit.outputs) {
    result.quantities.emplace_back(out.name);
    result.units.emplace_back(out.unit);
  }
  result.value = fit.values;
  result.differentiable = fit.differentiable;
  result.weights = fit.weights;
  result.chi2 = fit.chi2;
  result.degrees_of_freedom = fit.degrees_of_freedom;
  PropagateTaskCovariance(model, points, indices, fit.jacobian, options, result);
  // A quantity without derivative (flatness of points that fit exactly, ...) has no GUM
  // uncertainty: u = U = 0 with differentiable = false (never NaN); Monte Carlo reports it.
  for (int q = 0; q < static_cast<int>(result.differentiable.size()); ++q) {
    if (!result.differentiable[q]) {
      result.u(q) = 0.0;
      result.U(q) = 0.0;
    }
  }
  return result;
}

}  // namespace vlt
