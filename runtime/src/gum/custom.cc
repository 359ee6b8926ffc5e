// GUM engine, custom models (no readings): U_y = J U_x J^T with J = d f / d x at the estimates
// (JCGM 100 5.1.2 uncorrelated, 5.2.2 correlated inputs), budget per output (JCGM 100 8).
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "vlt/error.h"
#include "vlt/gum.h"

namespace vlt {

CustomUncertainty PropagateCustom(const ModelInfo& model, std::span<const UncertainInput> inputs,
                                  const Eigen::MatrixXd& correlation, const GumOptions& options) {
  const int num_inputs = model.num_params;
  const int num_outputs = model.num_outputs;
  if (static_cast<int>(inputs.size()) != num_inputs) {
    throw InputError(std::string("model '") + model.name + "' has " + std::to_string(num_inputs) +
                     " inputs, " + std::to_string(inputs.size()) + " given");
  }
  if (model.forward_jacobians == nullptr) {
    throw InputError(std::string("model '") + model.name + "' has no Jacobian kernel");
  }
  Eigen::VectorXd x(num_inputs), u(num_inputs);
  for (int i = 0; i < num_inputs; ++i) {
    x(i) = inputs[i].estimate;
    u(i) = inputs[i].u;
    if (!std::isfinite(x(i)) || !std::isfinite(u(i)) || u(i) < 0.0) {
      throw InputError(std::string("model '") + model.name + "': input '" + model.params[i].name +
                       "' needs a finite estimate and a finite, non-negative uncertainty");
    }
  }
  Eigen::MatrixXd r = Eigen::MatrixXd::Identity(num_inputs, num_inputs);
  const bool correlated = correlation.size() != 0 && !correlation.isIdentity(0.0);
  if (correlation.size() != 0) {
    if (correlation.rows() != num_inputs || correlation.cols() != num_inputs) {
      throw InputError(std::string("model '") + model.name + "': correlation matrix must be " +
                       std::to_string(num_inputs) + " x " + std::to_string(num_inputs));
    }
    for (int a = 0; a < num_inputs; ++a) {
      for (int b = 0; b < num_inputs; ++b) {
        const double v = correlation(a, b);
        if (!std::isfinite(v) || std::abs(v) > 1.0 || std::abs(v - correlation(b, a)) > 1e-12 ||
            (a == b && std::abs(v - 1.0) > 1e-12)) {
          throw InputError(std::string("model '") + model.name + "': correlation of '" +
                           model.params[a].name + "' and '" + model.params[b].name +
                           "' must be symmetric, in [-1, 1], 1 on the diagonal");
        }
      }
    }
    r = correlation;
  }

  Eigen::VectorXd y(num_outputs);
  Eigen::MatrixXd j(num_outputs, num_inputs);
  std::vector<double> j_readings(std::max(1, 3 * model.num_readings));
  model.forward_jacobians(nullptr, x.data(), y.data(), j_readings.data(), j.data());
  if (!y.allFinite() || !j.allFinite()) {
    throw NumericalError(std::string("model '") + model.name +
                         "': non-finite value or sensitivity at the estimates");
  }
  const Eigen::MatrixXd ju = j * u.asDiagonal();  // contributions c_i u_i
  CustomUncertainty result;
  result.covariance = ju * r * ju.transpose();
  result.k = NormalCoverageFactor(options.coverage_probability);
  result.correlation_handling =
      correlated ? "inputs correlated: each row is (c u)^2 of one input; the cross terms "
                   "2 sum_{i<j} c_i c_j u_i u_j r_ij are the row 'correlations' (may be "
                   "negative); the shares, that row included, sum to 100 %"
                 : "all inputs uncorrelated: each row is (c u)^2, the shares sum to 100 %";
  for (int o = 0; o < num_outputs; ++o) {
    CustomOutput out;
    out.name = model.outputs[o].name;
    out.unit = model.outputs[o].unit;
    out.estimate = y(o);
    const double var = result.covariance(o, o);
    out.u = std::sqrt(std::max(0.0, var));
    out.U = result.k * out.u;
    double sum_of_squares = 0.0;
    for (int i = 0; i < num_inputs; ++i) {
      BudgetRow row;
      row.input = model.params[i].name;
      row.group = "parameter";
      row.input_unit = inputs[i].unit.empty() ? model.params[i].unit : inputs[i].unit;
      row.estimate = x(i);
      row.u = u(i);
      row.sensitivity(0) = j(o, i) + 0.0;  // + 0.0: no "-0" in reports
      row.sensitivity_unit = SensitivityUnit(out.unit, row.input_unit);
      row.contribution(0) = ju(o, i) + 0.0;
      row.variance(0) = ju(o, i) * ju(o, i);
      sum_of_squares += row.variance(0);
      row.share(0) = var > 0.0 ? row.variance(0) / var : 0.0;
      row.share_total = row.share(0);
      out.budget.push_back(std::move(row));
    }
    if (correlated) {
      BudgetRow row;
      row.input = "correlations";
      row.group = "correlation";
      row.variance(0) = var - sum_of_squares;
      row.contribution(0) = std::copysign(std::sqrt(std::abs(row.variance(0))), row.variance(0));
      row.share(0) = var > 0.0 ? row.variance(0) / var : 0.0;
      row.share_total = row.share(0);
      out.budget.push_back(std::move(row));
    }
    std::stable_sort(out.budget.begin(), out.budget.end(),
                     [](const BudgetRow& l, const BudgetRow& r) {
                       return l.share_total > r.share_total;
                     });
    if (!std::isfinite(out.u)) {
      throw NumericalError(std::string("model '") + model.name + "': non-finite uncertainty");
    }
    result.outputs.push_back(std::move(out));
  }
  return result;
}

}  // namespace vlt
