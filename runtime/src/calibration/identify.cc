// calibration/identify.cc — Calibrate (vlt/calibration.h): identifiability analysis, the Ceres
// solve of the determined parameter combinations with the nuisance unknowns, covariance and
// residual statistics. The equations are in docs/calibration.md.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <numbers>

#include <Eigen/Cholesky>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <ceres/ceres.h>

#include "calibration/observations.h"
#include "vlt/error.h"
#include "vlt/gum.h"
#include "vlt/inverse.h"

namespace vlt {

using calibration_internal::DenseSystem;
using calibration_internal::DistanceObservation;
using calibration_internal::DistanceResidual;
using calibration_internal::IndexedProblem;
using calibration_internal::ReadingObservation;
using calibration_internal::ReadingResidual;

namespace {

// The parameters as the solver sees them: p = p0 + D (T alpha), D = diag(u0) over the active
// parameters, T (A x n) the determined combinations in prior-scaled coordinates.
struct ParameterMap {
  Eigen::VectorXd p0;
  std::vector<int> active;  // model indices of the parameters with u0 > 0
  Eigen::VectorXd u_active;
  Eigen::MatrixXd determined;  // A x n: columns v_i of the determined combinations
  Eigen::MatrixXd held;        // A x h: held combinations (prior kept)

  Eigen::VectorXd Params(const double* alpha) const {
    Eigen::VectorXd p = p0;
    if (determined.cols() == 0) return p;
    const Eigen::VectorXd z = determined * Eigen::Map<const Eigen::VectorXd>(alpha, determined.cols());
    for (std::size_t a = 0; a < active.size(); ++a) p(active[a]) += u_active(a) * z(a);
    return p;
  }
  // d p / d alpha (P x n) = D T on the active rows.
  Eigen::MatrixXd ParamsJacobian(int num_params, const Eigen::MatrixXd& basis) const {
    Eigen::MatrixXd j = Eigen::MatrixXd::Zero(num_params, basis.cols());
    for (std::size_t a = 0; a < active.size(); ++a) j.row(active[a]) = u_active(a) * basis.row(a);
    return j;
  }
};

// One reading: blocks [alpha (n), x_target (3)], or [x_target] when nothing is determined.
class ReadingCost : public ceres::CostFunction {
 public:
  ReadingCost(const IndexedProblem& problem, const ReadingObservation& obs, const ParameterMap& map)
      : problem_(problem), obs_(obs), map_(map), n_(static_cast<int>(map.determined.cols())) {
    set_num_residuals(3);
    if (n_ > 0) mutable_parameter_block_sizes()->push_back(n_);
    mutable_parameter_block_sizes()->push_back(3);
    d_p_d_alpha_ = map.ParamsJacobian(problem.num_params, map.determined);
  }
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const double* alpha = n_ > 0 ? parameters[0] : nullptr;
    const double* x = parameters[n_ > 0 ? 1 : 0];
    const Eigen::VectorXd p = map_.Params(alpha);
    const bool want_alpha = jacobians && n_ > 0 && jacobians[0];
    Eigen::Matrix<double, 3, Eigen::Dynamic> dp(3, problem_.num_params);
    ReadingResidual(problem_, obs_, p.data(), x, residuals, want_alpha ? dp.data() : nullptr);
    if (!jacobians) return true;
    if (want_alpha) {
      Eigen::Map<Eigen::Matrix<double, 3, Eigen::Dynamic, Eigen::RowMajor>> d(jacobians[0], 3, n_);
      d = dp * d_p_d_alpha_;
    }
    if (double* jx = jacobians[n_ > 0 ? 1 : 0]) {
      Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> d(jx);
      d = -obs_.whitening;
    }
    return true;
  }

 private:
  const IndexedProblem& problem_;
  const ReadingObservation& obs_;
  const ParameterMap& map_;
  int n_;
  Eigen::MatrixXd d_p_d_alpha_;
};

// A bar position or a reference distance: blocks [x_a, x_b] (+ [L_bar]).
class DistanceCost : public ceres::CostFunction {
 public:
  explicit DistanceCost(const DistanceObservation& obs) : obs_(obs) {
    set_num_residuals(1);
    mutable_parameter_block_sizes()->push_back(3);
    mutable_parameter_block_sizes()->push_back(3);
    if (obs.bar >= 0) mutable_parameter_block_sizes()->push_back(1);
  }
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const double length = obs_.bar >= 0 ? parameters[2][0] : obs_.length;
    // Coincident ends: no direction. Tell Ceres the step is unusable (never throw through it).
    const double dx = parameters[1][0] - parameters[0][0], dy = parameters[1][1] - parameters[0][1],
                 dz = parameters[1][2] - parameters[0][2];
    if (!(dx * dx + dy * dy + dz * dz > 0.0)) return false;
    double da[3], db[3];
    residuals[0] = DistanceResidual(obs_, parameters[0], parameters[1], length, da, db);
    if (jacobians) {
      if (jacobians[0]) std::copy(da, da + 3, jacobians[0]);
      if (jacobians[1]) std::copy(db, db + 3, jacobians[1]);
      if (obs_.bar >= 0 && jacobians[2]) jacobians[2][0] = -1.0 / obs_.u;
    }
    return true;
  }

 private:
  const DistanceObservation& obs_;
};

// The calibration of a bar: (L - L_cal) / u_cal.
class BarCalibrationCost : public ceres::SizedCostFunction<1, 1> {
 public:
  BarCalibrationCost(double length, double u) : length_(length), u_(u) {}
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    residuals[0] = (parameters[0][0] - length_) / u_;
    if (jacobians && jacobians[0]) jacobians[0][0] = 1.0 / u_;
    return true;
  }

 private:
  double length_, u_;
};

std::string FormatCoefficient(double c) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%+.3f", c);
  return buffer;
}

// Upper tail of chi-square: P(chi2_dof >= x).
double ChiSquareUpperTail(double x, int dof) {
  return dof > 0 ? std::clamp(1.0 - ChiSquareCdf(x, dof), 0.0, 1.0) : 1.0;
}

// A held combination v (F free parameters, prior-scaled) as the report names it: its terms of at
// least 5 % of the largest, that one positive.
HeldCombination DescribeHeld(const Eigen::VectorXd& v, const std::vector<std::string>& free_parameters,
                             double ratio, bool blind) {
  const int F = static_cast<int>(v.size());
  HeldCombination h;
  h.ratio = ratio;
  const double big = v.cwiseAbs().maxCoeff();
  const double sign =
      v(static_cast<Eigen::Index>(std::distance(
          v.data(), std::max_element(v.data(), v.data() + F,
                                     [](double x, double y) { return std::abs(x) < std::abs(y); })))) < 0
          ? -1.0
          : 1.0;
  for (int f = 0; f < F; ++f) {
    if (std::abs(v(f)) >= 0.05 * big) {
      h.terms.emplace_back(free_parameters[f], sign * v(f));
      if (!h.description.empty()) h.description += " ";
      h.description += FormatCoefficient(sign * v(f)) + " " + free_parameters[f];
    }
  }
  char ratio_text[48];
  std::snprintf(ratio_text, sizeof ratio_text, "%.3g", ratio);
  h.description += blind ? std::string(" (the data are blind to it)")
                         : std::string(" (data alone: ") + ratio_text + " x its prior u)";
  return h;
}

// One calibration (docs/calibration.md), its state from the indexed problem to the result.
struct Calibration {
  const CalibrationData& data;
  const CalibrationOptions& options;
  const IndexedProblem problem;
  const int P, T, B, nuisance, m;
  ParameterMap map;
  std::vector<int> free;  // positions in `active`
  int A = 0, F = 0;
  Eigen::MatrixXd prior_corr;  // correlation of z
  Eigen::VectorXd targets, bars;
  Eigen::VectorXd e;
  Eigen::MatrixXd jac;
  std::vector<int> determined, held_free;
  int n = 0;
  std::vector<double> alpha;
  Eigen::MatrixXd j_fit, c_fit, cov_all;
  CalibrationResult result;

  Calibration(const CalibrationData& d, const CalibrationOptions& o)
      : data(d),
        options(o),
        problem(calibration_internal::IndexProblem(d)),
        P(problem.num_params),
        T(static_cast<int>(problem.target_names.size())),
        B(static_cast<int>(problem.bar_length.size())),
        nuisance(3 * T + B),
        m(problem.num_residuals()) {
    if (!(options.hold_ratio > 0.0))
      throw InputError(data.where + ": calibration.hold_ratio: must be positive");
  }

  // Prior-scaled coordinates z over the active parameters (u0 > 0); the user's `fit` selects
  // which of them the data may move.
  void MapParameters() {
    if (!data.fit.empty() && static_cast<int>(data.fit.size()) != P) {
      throw InputError(data.where + ": calibration.fit: " + std::to_string(data.fit.size()) +
                       " flags for a model with " + std::to_string(P) + " parameters");
    }
    map.p0 = problem.p0;
    for (int k = 0; k < P; ++k) {
      if (problem.u0(k) > 0.0) {
        if (data.fit.empty() || data.fit[k]) free.push_back(static_cast<int>(map.active.size()));
        map.active.push_back(k);
      }
    }
    A = static_cast<int>(map.active.size());
    F = static_cast<int>(free.size());
    if (F == 0) {
      throw InputError(data.where +
                       ": calibration.fit: no parameter is left to identify (every parameter is excluded "
                       "or has prior u = 0)");
    }
    map.u_active.resize(A);
    for (int a = 0; a < A; ++a) map.u_active(a) = problem.u0(map.active[a]);
    prior_corr = Eigen::MatrixXd::Identity(A, A);
    if (data.prior_correlation.size() > 0) {
      for (int a = 0; a < A; ++a)
        for (int b = 0; b < A; ++b) prior_corr(a, b) = data.prior_correlation(map.active[a], map.active[b]);
    }
  }

  // Starting values of the nuisance unknowns: targets from their readings at the prior
  // estimates (mean over the readings), bars at their calibrated lengths.
  void StartingValues() {
    targets = Eigen::VectorXd::Zero(3 * T);
    for (const ReadingObservation& obs : problem.readings) {
      Eigen::Vector3d f;
      problem.model->forward(obs.readings.data(), problem.p0.data(), f.data());
      targets.segment<3>(3 * obs.target) += f / problem.target_reading_count[obs.target];
    }
    bars = Eigen::Map<const Eigen::VectorXd>(problem.bar_length.data(), B);
  }

  // Combination i (a right singular vector, over the free parameters) in z, A-dimensional.
  Eigen::VectorXd FreeAxis(int i) const {
    Eigen::VectorXd vz = Eigen::VectorXd::Zero(A);
    for (int f = 0; f < F; ++f) vz(free[f]) = result.singular_vectors(f, i);
    return vz;
  }

  // The design of the data (I-2): every reading replaced by the model's exact readings of its
  // target's start position at the prior, in the reading's face — the same geometry without the
  // readings' noise, so that a combination the design cannot see (the range offset of two-face
  // data, whose front and back readings of a target move alike) comes out exactly blind instead of
  // "held, data alone 1e4 x prior" by the noise's inconsistency. The data itself where the inverse
  // fails (a reading the prior model cannot reproduce).
  IndexedProblem Design() const {
    IndexedProblem design = problem;
    try {
      for (ReadingObservation& obs : design.readings) {
        const Face face = obs.readings(2) > std::numbers::pi / 2 ? Face::kBack : Face::kFront;
        const Eigen::Vector3d x = targets.segment<3>(3 * obs.target);
        const std::array<double, 3> r = InverseReadings(*problem.model, problem.p0.data(), {x(0), x(1), x(2)}, face);
        obs.readings = Eigen::Vector3d(r[0], r[1], r[2]);
      }
    } catch (const NumericalError&) {
      return problem;
    }
    return design;
  }

  // --- Identifiability at the prior (docs/calibration.md, eq. I-1..I-3), from the design.
  void Identifiability() {
    DenseSystem(Design(), problem.p0, targets, bars, e, jac);
    const Eigen::MatrixXd j_nuisance = jac.rightCols(nuisance);
    Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr_n(j_nuisance);
    if (qr_n.rank() < nuisance) {
      throw NumericalError(data.where +
                           ": the target coordinates and bar lengths are not all determined by the readings");
    }
    result.model = problem.model->name;
    Eigen::MatrixXd j_free(m, F);
    for (int f = 0; f < F; ++f) {
      const int a = free[f];
      j_free.col(f) = jac.col(map.active[a]) * map.u_active(a);
      result.free_parameters.push_back(problem.model->params[map.active[a]].name);
    }
    // Eliminate the nuisance unknowns: J~ = (I - Q Q^T) J_free with Q an orthonormal basis of the
    // nuisance columns; the singular values of J~ are the data's information on z.
    Eigen::MatrixXd q = qr_n.householderQ() * Eigen::MatrixXd::Identity(m, nuisance);
    Eigen::MatrixXd reduced = j_free - q * (q.transpose() * j_free);
    Eigen::JacobiSVD<Eigen::MatrixXd> svd(reduced, Eigen::ComputeFullV);
    // With fewer rows than free parameters the SVD has min(m, F) singular values: the remaining
    // right singular vectors span directions the data cannot see at all (singular value 0).
    result.singular_values = Eigen::VectorXd::Zero(F);
    result.singular_values.head(svd.singularValues().size()) = svd.singularValues();
    result.singular_vectors = svd.matrixV();
    SortCombinations();
  }

  // Each combination determined (fitted) or held at its prior, by the ratio of the data's u to the prior's.
  void SortCombinations() {
    const double s_max = F > 0 ? result.singular_values(0) : 0.0;
    for (int i = 0; i < F; ++i) {
      const double s = result.singular_values(i);
      const Eigen::VectorXd v = result.singular_vectors.col(i);
      const Eigen::VectorXd vz = FreeAxis(i);
      const double prior_u = std::sqrt(std::max(0.0, vz.dot(prior_corr * vz)));  // prior u of v^T z
      const bool blind = !(s > 1e-9 * s_max) || s == 0.0;
      const double ratio = blind ? std::numeric_limits<double>::infinity() : (1.0 / s) / prior_u;
      if (!blind && ratio <= options.hold_ratio) {
        determined.push_back(i);
        continue;
      }
      held_free.push_back(i);
      result.held.push_back(DescribeHeld(v, result.free_parameters, ratio, blind));
    }
    // Condition number of what is fitted: the determined combinations (the blind ones are held).
    result.condition_number = determined.empty() ? std::numeric_limits<double>::infinity()
                                                 : s_max / result.singular_values(determined.back());
  }

  // Bases in z (A-dimensional): determined combinations; held = held free ones + the active
  // parameters the user excluded from the fit.
  void Bases() {
    map.determined.setZero(A, static_cast<int>(determined.size()));
    for (std::size_t c = 0; c < determined.size(); ++c)
      for (int f = 0; f < F; ++f) map.determined(free[f], c) = result.singular_vectors(f, determined[c]);
    std::vector<Eigen::VectorXd> held_cols;
    for (int i : held_free) held_cols.push_back(FreeAxis(i));
    for (int a = 0; a < A; ++a) {
      if (std::find(free.begin(), free.end(), a) == free.end()) {
        held_cols.push_back(Eigen::VectorXd::Unit(A, a));
      }
    }
    map.held.setZero(A, static_cast<int>(held_cols.size()));
    for (std::size_t c = 0; c < held_cols.size(); ++c) map.held.col(c) = held_cols[c];
  }

  void CheckRedundancy() {
    n = static_cast<int>(map.determined.cols());
    result.observations = m;
    result.unknowns = n + nuisance;
    result.dof = m - result.unknowns;
    // At least one redundant observation: without one the fit cannot be checked (chi-square,
    // residuals) and nothing distinguishes a gross error from a parameter.
    if (result.dof < 1) {
      throw InputError(data.where + ": " + std::to_string(m) + " scalar observations for " +
                       std::to_string(result.unknowns) + " unknowns (" + std::to_string(n) +
                       " parameter combinations, " + std::to_string(3 * T) + " target coordinates, " +
                       std::to_string(B) +
                       " bar lengths): too few observations (no redundancy to check the fit)");
    }
  }

  // --- The solve (Ceres, Levenberg-Marquardt). DENSE_SCHUR: Ceres eliminates an independent
  // set of target blocks (the ends of one bar share a residual, so not all of them) by the Schur
  // complement and solves the reduced system for the parameter combinations and the rest.
  void Solve() {
    alpha.assign(static_cast<std::size_t>(std::max(n, 1)), 0.0);
    ceres::Problem::Options problem_options;
    problem_options.cost_function_ownership = ceres::TAKE_OWNERSHIP;
    ceres::Problem solver_problem(problem_options);
    for (const ReadingObservation& obs : problem.readings) {
      auto* cost = new ReadingCost(problem, obs, map);
      double* x = targets.data() + 3 * obs.target;
      if (n > 0)
        solver_problem.AddResidualBlock(cost, nullptr, alpha.data(), x);
      else
        solver_problem.AddResidualBlock(cost, nullptr, x);
    }
    for (const DistanceObservation& obs : problem.distances) {
      auto* cost = new DistanceCost(obs);
      double* xa = targets.data() + 3 * obs.a;
      double* xb = targets.data() + 3 * obs.b;
      if (obs.bar >= 0)
        solver_problem.AddResidualBlock(cost, nullptr, xa, xb, bars.data() + obs.bar);
      else
        solver_problem.AddResidualBlock(cost, nullptr, xa, xb);
    }
    for (int b = 0; b < B; ++b) {
      solver_problem.AddResidualBlock(new BarCalibrationCost(problem.bar_length[b], problem.bar_u[b]),
                                      nullptr, bars.data() + b);
    }
    ceres::Solver::Options solver_options;
    solver_options.linear_solver_type = n > 0 ? ceres::DENSE_SCHUR : ceres::DENSE_QR;
    solver_options.max_num_iterations = options.max_iterations;
    solver_options.function_tolerance = 1e-14;
    solver_options.gradient_tolerance = 1e-14;
    solver_options.parameter_tolerance = 1e-12;
    solver_options.num_threads = 1;
    solver_options.logging_type = ceres::SILENT;
    ceres::Solver::Summary summary;
    ceres::Solve(solver_options, &solver_problem, &summary);
    result.iterations = summary.num_successful_steps + summary.num_unsuccessful_steps;
    if (summary.termination_type == ceres::NO_CONVERGENCE) {
      throw NumericalError(data.where + ": the calibration did not converge in " +
                           std::to_string(options.max_iterations) + " iterations (" + summary.message + ")");
    }
    if (summary.termination_type != ceres::CONVERGENCE) {
      throw NumericalError(data.where + ": the calibration failed: " + summary.message +
                           " (two targets of a bar or reference at one place?)");
    }
  }

  // --- Covariance at the solution (eq. C-1..C-3).
  void Covariance() {
    const Eigen::VectorXd p_hat = map.Params(alpha.data());
    DenseSystem(problem, p_hat, targets, bars, e, jac);
    const int h = static_cast<int>(map.held.cols());
    j_fit.resize(m, n + nuisance);  // [alpha | targets | bars]
    j_fit.leftCols(n) = jac.leftCols(P) * map.ParamsJacobian(P, map.determined);
    j_fit.rightCols(nuisance) = jac.rightCols(nuisance);
    const Eigen::MatrixXd j_held = jac.leftCols(P) * map.ParamsJacobian(P, map.held);
    Eigen::LDLT<Eigen::MatrixXd> normal(j_fit.transpose() * j_fit);
    if (normal.info() != Eigen::Success || !(normal.vectorD().minCoeff() > 0.0)) {
      throw NumericalError(data.where + ": the normal equations are singular at the solution");
    }
    c_fit = normal.solve(Eigen::MatrixXd::Identity(n + nuisance, n + nuisance));
    // Held combinations beta ~ (0, Sigma_b) move the estimate by K beta, K = -C J^T J_held.
    const Eigen::MatrixXd sigma_held = map.held.transpose() * prior_corr * map.held;
    const Eigen::MatrixXd gain = -c_fit * (j_fit.transpose() * j_held);
    cov_all.resize(n + nuisance + h, n + nuisance + h);  // [alpha | nuisance | beta]
    cov_all.topLeftCorner(n + nuisance, n + nuisance) = c_fit + gain * sigma_held * gain.transpose();
    cov_all.topRightCorner(n + nuisance, h) = gain * sigma_held;
    cov_all.bottomLeftCorner(h, n + nuisance) = (gain * sigma_held).transpose();
    cov_all.bottomRightCorner(h, h) = sigma_held;
    // p = p0 + D (T alpha + H beta): the parameters' covariance.
    Eigen::MatrixXd d_p(P, n + nuisance + h);
    d_p.setZero();
    d_p.leftCols(n) = map.ParamsJacobian(P, map.determined);
    d_p.rightCols(h) = map.ParamsJacobian(P, map.held);
    result.covariance = d_p * cov_all * d_p.transpose();
    result.covariance = 0.5 * (result.covariance + result.covariance.transpose()).eval();
    result.correlation = Eigen::MatrixXd::Identity(P, P);
    const Eigen::MatrixXd cov_data = map.ParamsJacobian(P, map.determined) * c_fit.topLeftCorner(n, n) *
                                     map.ParamsJacobian(P, map.determined).transpose();
    for (int k = 0; k < P; ++k) result.parameters.push_back(Parameter(k, p_hat, cov_data));
  }

  CalibratedParameter Parameter(int k, const Eigen::VectorXd& p_hat, const Eigen::MatrixXd& cov_data) const {
    const QuantityInfo& q = problem.model->params[k];
    CalibratedParameter cp;
    cp.name = q.name;
    cp.unit = q.unit;
    cp.quantity = q.quantity;
    cp.prior_estimate = problem.p0(k);
    cp.prior_u = problem.u0(k);
    cp.estimate = p_hat(k);
    cp.u = std::sqrt(std::max(0.0, result.covariance(k, k)));
    cp.u_data = std::sqrt(std::max(0.0, cov_data(k, k)));
    cp.status = Status(k, cp);
    return cp;
  }

  // Status from the share of the parameter's prior-scaled axis in the held space.
  ParameterStatus Status(int k, const CalibratedParameter& cp) const {
    const auto it = std::find(map.active.begin(), map.active.end(), k);
    if (it == map.active.end()) return ParameterStatus::kFixed;
    const int a = static_cast<int>(it - map.active.begin());
    const bool is_free = std::find(free.begin(), free.end(), a) != free.end();
    const double held_share = map.held.cols() ? map.held.row(a).squaredNorm() : 0.0;
    // Identified: its axis lies in the determined directions AND its u is the data's (the
    // priors of excluded parameters or held combinations reach it through K otherwise).
    const bool data_only = cp.u > 0.0 && cp.u_data * cp.u_data >= 0.9 * cp.u * cp.u;
    if (!is_free) return ParameterStatus::kFixed;
    if (held_share < 1e-3 && data_only) return ParameterStatus::kIdentified;
    if (held_share > 1.0 - 1e-3) return ParameterStatus::kHeld;
    return ParameterStatus::kPartly;
  }

  void CorrelationAndNuisance() {
    for (int i = 0; i < P; ++i) {
      for (int j = 0; j < P; ++j) {
        const double den = result.parameters[i].u * result.parameters[j].u;
        result.correlation(i, j) = i == j ? 1.0 : (den > 0.0 ? result.covariance(i, j) / den : 0.0);
      }
    }
    for (int t = 0; t < T; ++t) {
      CalibratedTarget ct;
      ct.name = problem.target_names[t];
      ct.position = targets.segment<3>(3 * t);
      ct.covariance = cov_all.block<3, 3>(n + 3 * t, n + 3 * t);
      ct.readings = problem.target_reading_count[t];
      result.targets.push_back(ct);
    }
    for (int b = 0; b < B; ++b) {
      result.bars.push_back({data.bars[b].name, bars(b), std::sqrt(cov_all(n + 3 * T + b, n + 3 * T + b))});
    }
  }

  // One residual, with its redundancy number and Baarda's w (data snooping).
  void AddResidual(const Eigen::MatrixXd& jc, int row, std::string label, std::string where, std::string unit,
                   double sigma, double sign) {
    CalibrationResidual r;
    r.observation = std::move(label);
    r.where = std::move(where);
    r.unit = std::move(unit);
    r.u = sigma;
    r.normalised = sign * e(row);
    r.residual = r.normalised * sigma;
    r.redundancy = std::clamp(1.0 - jc.row(row).dot(j_fit.row(row)), 0.0, 1.0);
    r.w = r.redundancy > 1e-9 ? r.normalised / std::sqrt(r.redundancy) : 0.0;
    r.outlier = std::abs(r.w) > options.outlier_limit;
    result.outliers += r.outlier ? 1 : 0;
    result.residuals.push_back(std::move(r));
  }

  // --- Residuals: chi-square, Birge ratio, redundancy numbers, data snooping.
  void Residuals() {
    result.chi2 = e.squaredNorm();
    result.birge_ratio = result.dof > 0 ? std::sqrt(result.chi2 / result.dof) : 0.0;
    result.p_value = ChiSquareUpperTail(result.chi2, result.dof);
    result.k = NormalCoverageFactor(options.coverage_probability);
    const Eigen::MatrixXd jc = j_fit * c_fit;
    static const char* kReadingNames[3] = {"range", "azimuth", "elevation"};
    for (std::size_t i = 0; i < problem.readings.size(); ++i) {
      const ReadingObservation& obs = problem.readings[i];
      const TargetReading& src = data.readings[i];
      for (int c = 0; c < 3; ++c) {
        // e = W (f(m) - x) ~ S^-1/2 (m - m_adjusted): observed minus adjusted reading.
        AddResidual(jc, static_cast<int>(3 * i) + c,
                    src.target + " " + FaceName(src.face) + " " + kReadingNames[c], src.where,
                    c == 0 ? "m" : "rad", obs.sigma(c), 1.0);
      }
    }
    int row = 3 * static_cast<int>(problem.readings.size());
    for (const DistanceObservation& obs : problem.distances) {
      AddResidual(jc, row++, obs.label, obs.where, "m", obs.u, -1.0);  // observed L - adjusted |xa - xb|
    }
    for (int b = 0; b < B; ++b) {
      AddResidual(jc, row++, data.bars[b].name + " calibration", data.bars[b].where, "m", problem.bar_u[b],
                  -1.0);
    }
    for (const CalibratedParameter& cp : result.parameters) {
      if (!std::isfinite(cp.estimate) || !std::isfinite(cp.u)) {
        throw NumericalError(data.where + ": parameter '" + cp.name + "' came out non-finite");
      }
    }
  }
};

}  // namespace

CalibrationResult Calibrate(const CalibrationData& data, const CalibrationOptions& options) {
  Calibration calibration(data, options);
  calibration.MapParameters();
  calibration.StartingValues();
  calibration.Identifiability();
  calibration.Bases();
  calibration.CheckRedundancy();
  calibration.Solve();
  calibration.Covariance();
  calibration.CorrelationAndNuisance();
  calibration.Residuals();
  return std::move(calibration.result);
}

}  // namespace vlt
