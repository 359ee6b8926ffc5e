// GUM engine, custom models (no readings): U_y = J U_x J^T with J = d f / d x at the estimates
// (JCGM 100 5.1.2 uncorrelated, 5.2.2 correlated inputs), budget per output (JCGM 100 8).
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "gum/internal.h"
#include "model/correlation.h"
#include "vlt/error.h"
#include "vlt/gum.h"

namespace vlt {

namespace {

// Components of the Welch-Satterthwaite sum (vlt/gum.h InputDegreesOfFreedom): the given sets
// (merged where they share an input, union-find), every other input on its own. Returns the
// component index of every input.
std::vector<int> WelchSatterthwaiteComponents(int n, const std::vector<std::vector<int>>& sets) {
  std::vector<int> parent(n);
  for (int i = 0; i < n; ++i) parent[i] = i;
  auto find = [&](int i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  auto join = [&](int a, int b) { parent[find(a)] = find(b); };
  for (const std::vector<int>& set : sets) {
    for (std::size_t k = 1; k < set.size(); ++k) join(set[0], set[k]);
  }
  std::vector<int> component(n);
  for (int i = 0; i < n; ++i) component[i] = find(i);
  return component;
}

// The model linearised at the input estimates (JCGM 100 5.1.2): what the budget of every output
// needs.
struct Linearisation {
  const ModelInfo& model;
  std::span<const UncertainInput> inputs;
  Eigen::VectorXd x, u;  // estimates and standard uncertainties of the inputs
  Eigen::MatrixXd r;     // their correlation matrix (identity when uncorrelated)
  bool correlated = false;
  std::vector<double> dof;               // their degrees of freedom
  std::vector<int> component;            // their Welch-Satterthwaite components
  Eigen::VectorXd y;                     // the outputs at the estimates
  Eigen::MatrixXd j, ju;                 // sensitivities c and contributions c_i u_i
  std::vector<Eigen::MatrixXd> hz;       // per output: its Hessian in z at the estimates
  std::vector<Eigen::MatrixXd> hz_span;  // the same from differences over +-1 u (SecondOrderDecides)

  Linearisation(const ModelInfo& m, std::span<const UncertainInput> in) : model(m), inputs(in) {}
};

void InputEstimates(Linearisation& lin) {
  const ModelInfo& model = lin.model;
  const int num_inputs = model.num_params;
  lin.x.resize(num_inputs);
  lin.u.resize(num_inputs);
  for (int i = 0; i < num_inputs; ++i) {
    lin.x(i) = lin.inputs[i].estimate;
    lin.u(i) = lin.inputs[i].u;
    if (!std::isfinite(lin.x(i)) || !std::isfinite(lin.u(i)) || lin.u(i) < 0.0) {
      throw InputError(std::string("model '") + model.name + "': input '" + model.params[i].name +
                       "' needs a finite estimate and a finite, non-negative uncertainty");
    }
  }
}

// The correlation matrix R of the inputs: the identity when none is given.
Eigen::MatrixXd InputCorrelation(const ModelInfo& model, const Eigen::MatrixXd& correlation) {
  const int num_inputs = model.num_params;
  Eigen::MatrixXd r = Eigen::MatrixXd::Identity(num_inputs, num_inputs);
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
    Eigen::MatrixXd factor;
    if (!model_internal::CorrelationFactor(correlation, factor)) {
      throw InputError(std::string("model '") + model.name +
                       "': the correlation matrix of the inputs is not positive semi-definite");
    }
    r = correlation;
  }
  return r;
}

// The degrees of freedom of every input (infinite when not given), and the Welch-Satterthwaite
// component of every input.
void InputDegrees(Linearisation& lin, const InputDegreesOfFreedom& degrees_of_freedom) {
  const ModelInfo& model = lin.model;
  const int num_inputs = model.num_params;
  std::vector<double>& dof = lin.dof;
  dof.assign(num_inputs, std::numeric_limits<double>::infinity());
  if (!degrees_of_freedom.dof.empty()) {
    if (static_cast<int>(degrees_of_freedom.dof.size()) != num_inputs) {
      throw InputError(std::string("model '") + model.name + "': degrees of freedom for " +
                       std::to_string(degrees_of_freedom.dof.size()) + " of " + std::to_string(num_inputs) +
                       " inputs");
    }
    for (int i = 0; i < num_inputs; ++i) {
      dof[i] = degrees_of_freedom.dof[i];
      if (!(dof[i] >= 1.0)) {
        throw InputError(std::string("model '") + model.name + "': input '" + model.params[i].name +
                         "': degrees of freedom must be >= 1 (or infinite)");
      }
    }
  }
  for (const std::vector<int>& set : degrees_of_freedom.components) {
    for (int i : set) {
      if (i < 0 || i >= num_inputs)
        throw InputError(std::string("model '") + model.name + "': bad input index in a component");
    }
  }
  lin.component = WelchSatterthwaiteComponents(num_inputs, degrees_of_freedom.components);
}

// x = x0 + F z for the second-order terms (JCGM 100 5.1.2 note; gum/nonlinearity.cc for points):
// F = diag(u) L, L L^T = R.
Eigen::MatrixXd InputFactor(const Linearisation& lin) {
  if (!lin.correlated) return lin.u.asDiagonal();
  Eigen::MatrixXd l;
  model_internal::CorrelationFactor(lin.r, l);
  return lin.u.asDiagonal() * l;
}

// Per output, its Hessian in z: H_z = F^T H_x F with H_x exact (vlt-gen's Hessians kernel,
// vlt/model_info.h HessiansFn) at the estimates (lin.hz; the note's formula needs exact
// derivatives: JCGM 101 9.3's 0.0750 mg needs them to 0.1 %, and a step of one u, as vlt once
// used, saw 10 rad of JCGM 102 9.3's phase at x1 = 0.001, u = 0.01 as "reliable"). Null when the
// model has no such kernel (a hand-written ModelInfo).
std::optional<std::vector<Eigen::MatrixXd>> ExactHessians(const Linearisation& lin) {
  const ModelInfo& model = lin.model;
  if (model.hessians == nullptr) return std::nullopt;
  const int n = model.num_readings + model.num_params;  // custom models: no readings
  std::vector<double> hx(static_cast<std::size_t>(model.num_outputs) * n * n);
  model.hessians(nullptr, lin.x.data(), hx.data());
  const Eigen::MatrixXd f = InputFactor(lin);
  std::vector<Eigen::MatrixXd> hz(model.num_outputs);
  for (int o = 0; o < model.num_outputs; ++o) {
    Eigen::MatrixXd h =
        Eigen::Map<const Eigen::MatrixXd>(hx.data() + static_cast<std::size_t>(o) * n * n, n, n);
    // An input that does not vary (a zero row of F) has no second-order term: its row and column
    // left out, so that a second derivative infinite at its estimate (x^1.5 at x = 0) is not 0 inf.
    for (int i = 0; i < n; ++i) {
      if (f.row(i).isZero(0.0)) {
        h.row(i).setZero();
        h.col(i).setZero();
      }
    }
    hz[o] = f.transpose() * h * f;
  }
  return hz;
}

// The same from central differences of the exact Jacobian: column k of H_z is
// D(h) = (J(x0 + h F e_k) - J(x0 - h F e_k)) F / (2 h). Over the inputs' spread (lin.hz_span):
// D(1), for SecondOrderDecides. At the estimates, for a model without a Hessians kernel:
// D(h) Richardson-extrapolated, (4 D(h/2) - D(h)) / 3 with h = 10^-3, the exact second
// derivatives to about 10^-12.
std::vector<Eigen::MatrixXd> SecondOrderHessians(const Linearisation& lin, std::vector<double>& j_readings,
                                                 double step, bool richardson) {
  const ModelInfo& model = lin.model;
  const int num_inputs = model.num_params;
  const int num_outputs = model.num_outputs;
  const Eigen::VectorXd& x = lin.x;
  const Eigen::MatrixXd f = InputFactor(lin);
  std::vector<Eigen::MatrixXd> hz(num_outputs, Eigen::MatrixXd::Zero(num_inputs, num_inputs));
  Eigen::VectorXd y_step(num_outputs);
  Eigen::MatrixXd j_plus(num_outputs, num_inputs), j_minus(num_outputs, num_inputs);
  auto central = [&](int k, double h) {
    const Eigen::VectorXd x_plus = x + h * f.col(k), x_minus = x - h * f.col(k);
    model.forward_jacobians(nullptr, x_plus.data(), y_step.data(), j_readings.data(), j_plus.data());
    model.forward_jacobians(nullptr, x_minus.data(), y_step.data(), j_readings.data(), j_minus.data());
    return Eigen::MatrixXd((j_plus - j_minus) * f / (2.0 * h));  // num_outputs x num_inputs
  };
  for (int k = 0; k < num_inputs; ++k) {
    if (f.col(k).isZero(0.0)) continue;
    const Eigen::MatrixXd d = richardson
                                  ? Eigen::MatrixXd((4.0 * central(k, 0.5 * step) - central(k, step)) / 3.0)
                                  : central(k, step);
    for (int o = 0; o < num_outputs; ++o) hz[o].col(k) = d.row(o).transpose();
  }
  return hz;
}

// JCGM 100 G.4.1: one variance per component (a set's cross terms included), its smallest nu.
double EffectiveDegreesOfFreedom(const Linearisation& lin, int o, double u) {
  const int num_inputs = lin.model.num_params;
  const std::vector<int>& component = lin.component;
  std::vector<double> comp_var(num_inputs, 0.0);
  std::vector<double> comp_dof(num_inputs, std::numeric_limits<double>::infinity());
  for (int a = 0; a < num_inputs; ++a) {
    comp_dof[component[a]] = std::min(comp_dof[component[a]], lin.dof[a]);
    for (int b = 0; b < num_inputs; ++b) {
      if (component[a] == component[b]) comp_var[component[a]] += lin.ju(o, a) * lin.r(a, b) * lin.ju(o, b);
    }
  }
  return WelchSatterthwaite(u, comp_var, comp_dof);
}

// The second-order variance of output o against its first-order variance (JCGM 100 5.1.2 note).
void SecondOrderCheck(const Linearisation& lin, int o, double var, CustomOutput& out) {
  const double v_local = gum_internal::SecondOrderVariance(lin.hz[o]);
  const double v_span = gum_internal::SecondOrderVariance(lin.hz_span[o]);
  if (!std::isfinite(v_local)) {
    throw NumericalError(std::string("model '") + lin.model.name + "': output '" + out.name +
                         "': the second-order check gives a non-finite result");
  }
  // A pole at +-1 u itself (v_span not finite): the curvature changes within 1 u, undecided.
  const bool span_finite = std::isfinite(v_span);
  // The note's term with exact derivatives (JCGM 101 9.3's 0.0750 mg); the one over +-1 u only
  // decides whether it can be trusted (docs/gum.md "Non-linearity").
  out.second_order_variance = v_local;
  // A first-order variance of 0 with second-order terms: no ratio (infinity; gum/nonlinearity.cc).
  out.second_order_ratio = var > 0.0                         ? out.second_order_variance / var
                           : out.second_order_variance > 0.0 ? std::numeric_limits<double>::infinity()
                                                             : 0.0;
  // Reliable when the second order decides and neither its value at the estimates nor over the
  // inputs' spread exceeds the threshold (docs/gum.md "Non-linearity").
  out.second_order_decided = span_finite && SecondOrderDecides(v_local, v_span, var);
  out.gum_reliable = out.second_order_decided && out.second_order_ratio <= kSecondOrderThreshold;
}

// The uncertainty budget of output o (JCGM 100 8): a row per input, one for the correlations,
// the largest share first.
void AddBudget(const Linearisation& lin, int o, double var, CustomOutput& out) {
  const ModelInfo& model = lin.model;
  double sum_of_squares = 0.0;
  for (int i = 0; i < model.num_params; ++i) {
    BudgetRow row;
    row.input = model.params[i].name;
    row.group = "parameter";
    row.input_unit = lin.inputs[i].unit.empty() ? model.params[i].unit : lin.inputs[i].unit;
    row.estimate = lin.x(i);
    row.u = lin.u(i);
    row.sensitivity(0) = lin.j(o, i) + 0.0;  // + 0.0: no "-0" in reports
    row.sensitivity_unit = SensitivityUnit(out.unit, row.input_unit);
    row.contribution(0) = lin.ju(o, i) + 0.0;
    row.variance(0) = lin.ju(o, i) * lin.ju(o, i);
    sum_of_squares += row.variance(0);
    row.share(0) = var > 0.0 ? row.variance(0) / var : 0.0;
    row.share_total = row.share(0);
    out.budget.push_back(std::move(row));
  }
  if (lin.correlated) {
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
                   [](const BudgetRow& l, const BudgetRow& r) { return l.share_total > r.share_total; });
}

// Output o: its estimate, standard and expanded uncertainty, second-order check and budget.
CustomOutput OutputOf(const Linearisation& lin, int o, const CustomUncertainty& result,
                      const GumOptions& options) {
  CustomOutput out;
  out.name = lin.model.outputs[o].name;
  out.unit = lin.model.outputs[o].unit;
  out.estimate = lin.y(o);
  const double var = result.covariance(o, o);
  out.u = std::sqrt(std::max(0.0, var));
  out.dof_effective = EffectiveDegreesOfFreedom(lin, o, out.u);
  // G.4.1 note 1 / G.6.4: nu_eff truncated to the next lower integer for t_p (a relative 1e-9
  // guards the truncation of an exact integer against rounding: one component of nu = 4 gives
  // 4, not 3.999999999).
  out.k = std::isinf(out.dof_effective)
              ? result.k
              : StudentTCoverageFactor(options.coverage_probability,
                                       std::max(1.0, std::floor(out.dof_effective * (1.0 + 1e-9))));
  out.U = out.k * out.u;
  SecondOrderCheck(lin, o, var, out);
  AddBudget(lin, o, var, out);
  if (!std::isfinite(out.u)) {
    throw NumericalError(std::string("model '") + lin.model.name + "': non-finite uncertainty");
  }
  return out;
}

}  // namespace

CustomUncertainty PropagateCustom(const ModelInfo& model, std::span<const UncertainInput> inputs,
                                  const Eigen::MatrixXd& correlation, const GumOptions& options,
                                  const InputDegreesOfFreedom& degrees_of_freedom) {
  const int num_inputs = model.num_params;
  const int num_outputs = model.num_outputs;
  if (static_cast<int>(inputs.size()) != num_inputs) {
    throw InputError(std::string("model '") + model.name + "' has " + std::to_string(num_inputs) +
                     " inputs, " + std::to_string(inputs.size()) + " given");
  }
  if (model.forward_jacobians == nullptr) {
    throw InputError(std::string("model '") + model.name + "' has no Jacobian kernel");
  }
  Linearisation lin(model, inputs);
  InputEstimates(lin);
  lin.correlated = correlation.size() != 0 && !correlation.isIdentity(0.0);
  lin.r = InputCorrelation(model, correlation);
  InputDegrees(lin, degrees_of_freedom);

  lin.y.resize(num_outputs);
  lin.j.resize(num_outputs, num_inputs);
  std::vector<double> j_readings(std::max(1, 3 * model.num_readings));
  model.forward_jacobians(nullptr, lin.x.data(), lin.y.data(), j_readings.data(), lin.j.data());
  if (!lin.y.allFinite() || !lin.j.allFinite()) {
    throw NumericalError(std::string("model '") + model.name +
                         "': non-finite value or sensitivity at the estimates");
  }
  lin.ju = lin.j * lin.u.asDiagonal();  // contributions c_i u_i
  std::optional<std::vector<Eigen::MatrixXd>> exact = ExactHessians(lin);
  lin.hz = exact ? std::move(*exact) : SecondOrderHessians(lin, j_readings, 1e-3, true);
  lin.hz_span = SecondOrderHessians(lin, j_readings, 1.0, false);

  CustomUncertainty result;
  result.covariance = lin.ju * lin.r * lin.ju.transpose();
  result.k = NormalCoverageFactor(options.coverage_probability);
  if (num_outputs >= 2) result.region_k = ChiSquareCoverageFactor(options.coverage_probability, num_outputs);
  result.correlation = model_internal::CorrelationOfCovariance(result.covariance);
  result.correlation_handling = lin.correlated
                                    ? "inputs correlated: each row is (c u)^2 of one input; the cross terms "
                                      "2 sum_{i<j} c_i c_j u_i u_j r_ij are the row 'correlations' (may be "
                                      "negative); the shares, that row included, sum to 100 %"
                                    : "all inputs uncorrelated: each row is (c u)^2, the shares sum to 100 %";
  for (int o = 0; o < num_outputs; ++o) result.outputs.push_back(OutputOf(lin, o, result, options));
  return result;
}

}  // namespace vlt
