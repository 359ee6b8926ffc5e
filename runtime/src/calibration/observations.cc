// calibration/observations.cc — observation equations of a tracker calibration (observations.h).
#include "calibration/observations.h"

#include <cmath>
#include <map>

#include <Eigen/LU>

#include "vlt/error.h"

namespace vlt::calibration_internal {

IndexedProblem IndexProblem(const CalibrationData& data) {
  IndexedProblem problem;
  const ModelInfo* model = data.model;
  if (!model || std::string_view(model->kind) != "tracker" || model->num_readings != 3) {
    throw InputError(data.where + ": tracker.model: calibration needs a tracker model");
  }
  problem.model = model;
  const int P = model->num_params;
  problem.num_params = P;
  if (static_cast<int>(data.priors.size()) != P) {
    throw InputError(data.where + ": tracker.parameters: " + std::to_string(data.priors.size()) +
                     " priors for a model with " + std::to_string(P) + " parameters");
  }
  problem.p0.resize(P);
  problem.u0.resize(P);
  for (int k = 0; k < P; ++k) {
    problem.p0(k) = data.priors[k].estimate;
    problem.u0(k) = data.priors[k].u;
  }
  if (data.readings.empty()) throw InputError(data.where + ": readings: no readings");

  std::map<std::string, int> index;
  for (const TargetReading& r : data.readings) {
    auto [it, inserted] = index.emplace(r.target, static_cast<int>(problem.target_names.size()));
    if (inserted) {
      problem.target_names.push_back(r.target);
      problem.target_reading_count.push_back(0);
    }
    ++problem.target_reading_count[it->second];
    ReadingObservation obs;
    obs.target = it->second;
    obs.readings = r.readings;
    if (!(r.readings(0) > 0.0)) throw InputError(r.where + ": range must be positive");
    const double range_u = data.noise.range_a + data.noise.range_b * r.readings(0);
    obs.sigma = Eigen::Vector3d(range_u, data.noise.azimuth, data.noise.elevation);
    if (!(obs.sigma.minCoeff() > 0.0)) {
      throw InputError(data.where +
                       ": tracker.noise: every reading needs a positive standard "
                       "uncertainty (range, azimuth, elevation) to be weighted");
    }
    // Whitening at the prior estimates: W = S^-1/2 J_r^-1, so that W (f(m) - x) is the
    // correction of the readings in units of their standard uncertainties.
    Eigen::Vector3d out;
    Eigen::Matrix3d jr;
    Eigen::Matrix<double, 3, Eigen::Dynamic> jp(3, P);
    model->forward_jacobians(r.readings.data(), problem.p0.data(), out.data(), jr.data(), jp.data());
    Eigen::FullPivLU<Eigen::Matrix3d> lu(jr);
    if (!lu.isInvertible() || !out.allFinite()) {
      throw NumericalError(r.where + ": target '" + r.target +
                           "': the readings are singular for the tracker model (on the standing axis?)");
    }
    obs.whitening = obs.sigma.cwiseInverse().asDiagonal() * lu.inverse();
    problem.readings.push_back(obs);
  }

  auto target = [&](const std::string& name, const std::string& where) {
    auto it = index.find(name);
    if (it == index.end()) {
      throw InputError(where + ": target '" + name + "' has no readings");
    }
    return it->second;
  };
  for (const ReferenceBar& bar : data.bars) {
    if (!(bar.length > 0.0)) throw InputError(bar.where + ": length must be positive");
    if (!(bar.u > 0.0))
      throw InputError(bar.where + ": u must be positive (the bar's calibration uncertainty)");
    if (!(bar.u_position > 0.0)) throw InputError(bar.where + ": u_position must be positive");
    if (bar.positions.empty()) throw InputError(bar.where + ": positions: no positions");
    const int b = static_cast<int>(problem.bar_length.size());
    problem.bar_length.push_back(bar.length);
    problem.bar_u.push_back(bar.u);
    int k = 0;
    for (const auto& [a_name, b_name] : bar.positions) {
      DistanceObservation d;
      d.a = target(a_name, bar.where);
      d.b = target(b_name, bar.where);
      if (d.a == d.b)
        throw InputError(bar.where + ": position " + std::to_string(k + 1) + ": both ends are target '" +
                         a_name + "'");
      d.bar = b;
      d.u = bar.u_position;
      d.label = bar.name + " position " + std::to_string(++k) + " (" + a_name + "-" + b_name + ")";
      d.where = bar.where;
      problem.distances.push_back(d);
    }
  }
  for (const ReferenceDistance& ref : data.distances) {
    if (!(ref.length > 0.0)) throw InputError(ref.where + ": length must be positive");
    if (!(ref.u > 0.0)) throw InputError(ref.where + ": u must be positive");
    DistanceObservation d;
    d.a = target(ref.from, ref.where);
    d.b = target(ref.to, ref.where);
    if (d.a == d.b) throw InputError(ref.where + ": from and to are the same target '" + ref.from + "'");
    d.length = ref.length;
    d.u = ref.u;
    d.label = "distance " + ref.from + "-" + ref.to;
    d.where = ref.where;
    problem.distances.push_back(d);
  }
  return problem;
}

void ReadingResidual(const IndexedProblem& problem, const ReadingObservation& obs, const double* p,
                     const double* x, double* e, double* d_e_d_p) {
  const int P = problem.num_params;
  Eigen::Vector3d f;
  Eigen::Matrix3d jr;
  Eigen::Matrix<double, 3, Eigen::Dynamic> jp(3, P);
  problem.model->forward_jacobians(obs.readings.data(), p, f.data(), jr.data(), jp.data());
  Eigen::Map<Eigen::Vector3d> residual(e);
  residual = obs.whitening * (f - Eigen::Map<const Eigen::Vector3d>(x));
  if (d_e_d_p) {
    Eigen::Map<Eigen::Matrix<double, 3, Eigen::Dynamic>> d(d_e_d_p, 3, P);
    d = obs.whitening * jp;
  }
}

double DistanceResidual(const DistanceObservation& obs, const double* xa, const double* xb, double length,
                        double* d_e_d_xa, double* d_e_d_xb) {
  const Eigen::Vector3d d = Eigen::Map<const Eigen::Vector3d>(xb) - Eigen::Map<const Eigen::Vector3d>(xa);
  const double n = d.norm();
  if (!(n > 0.0)) throw NumericalError(obs.where + ": " + obs.label + ": the two targets coincide");
  const Eigen::Vector3d unit = d / n;
  for (int i = 0; i < 3; ++i) {
    if (d_e_d_xa) d_e_d_xa[i] = -unit(i) / obs.u;
    if (d_e_d_xb) d_e_d_xb[i] = unit(i) / obs.u;
  }
  return (n - length) / obs.u;
}

void DenseSystem(const IndexedProblem& problem, const Eigen::VectorXd& p, const Eigen::VectorXd& targets,
                 const Eigen::VectorXd& bars, Eigen::VectorXd& e, Eigen::MatrixXd& jacobian) {
  const int P = problem.num_params;
  const int T = static_cast<int>(problem.target_names.size());
  const int B = static_cast<int>(problem.bar_length.size());
  const int m = problem.num_residuals();
  e.setZero(m);
  jacobian.setZero(m, P + 3 * T + B);
  int row = 0;
  Eigen::Matrix<double, 3, Eigen::Dynamic> dp(3, P);
  for (const ReadingObservation& obs : problem.readings) {
    ReadingResidual(problem, obs, p.data(), targets.data() + 3 * obs.target, e.data() + row, dp.data());
    jacobian.block(row, 0, 3, P) = dp;
    jacobian.block<3, 3>(row, P + 3 * obs.target) = -obs.whitening;
    row += 3;
  }
  for (const DistanceObservation& obs : problem.distances) {
    const double length = obs.bar >= 0 ? bars(obs.bar) : obs.length;
    Eigen::Vector3d da, db;
    e(row) = DistanceResidual(obs, targets.data() + 3 * obs.a, targets.data() + 3 * obs.b, length, da.data(),
                              db.data());
    jacobian.block<1, 3>(row, P + 3 * obs.a) += da.transpose();
    jacobian.block<1, 3>(row, P + 3 * obs.b) += db.transpose();
    if (obs.bar >= 0) jacobian(row, P + 3 * T + obs.bar) = -1.0 / obs.u;
    ++row;
  }
  for (int b = 0; b < B; ++b) {
    e(row) = (bars(b) - problem.bar_length[b]) / problem.bar_u[b];
    jacobian(row, P + 3 * T + b) = 1.0 / problem.bar_u[b];
    ++row;
  }
}

}  // namespace vlt::calibration_internal
