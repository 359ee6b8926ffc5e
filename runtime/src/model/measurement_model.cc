// The complete measurement function of one point (vlt/measurement_model.h, docs/gum.md):
//   y = thermal( pose( tracker_model( (rho n_est / n, A, E), params ) ) )
// evaluated exactly, and its Jacobian by the chain rule from the generated Jacobians of the
// tracker model and the analytic derivatives of the air, pose and thermal stages.
#include "vlt/measurement_model.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Dense>

#include "vlt/error.h"
#include "vlt/refractive_index.h"

namespace vlt {
namespace {

void Fill(UncertainInput& input, const char* name, const char* unit, const char* group) {
  if (input.name.empty()) input.name = name;
  if (input.unit.empty()) input.unit = unit;
  input.group = group;
}

// Calls visit(input, default name, default unit, group) for every shared input of `setup` in the
// order of the shared vector: params | environment | pose | thermal (enabled groups only). The one
// definition of that order and of the default names (MeasurementModel, SharedInputNames).
template <typename Setup, typename Visit>
void ForEachShared(Setup& setup, Visit visit) {
  for (std::size_t k = 0; k < setup.params.size(); ++k) {
    const bool known = setup.model != nullptr && static_cast<int>(k) < setup.model->num_params;
    visit(setup.params[k], known ? setup.model->params[k].name : "", known ? setup.model->params[k].unit : "",
          "parameter");
  }
  if (setup.environment) {
    auto& env = *setup.environment;
    visit(env.temperature, "environment.temperature", "degC", "environment");
    visit(env.pressure, "environment.pressure", "Pa", "environment");
    visit(env.humidity, "environment.humidity", "%", "environment");
    visit(env.co2, "environment.co2", "1", "environment");
  }
  if (setup.pose) {
    auto& pose = *setup.pose;
    visit(pose.rx, "pose.rx", "rad", "pose");
    visit(pose.ry, "pose.ry", "rad", "pose");
    visit(pose.rz, "pose.rz", "rad", "pose");
    visit(pose.tx, "pose.tx", "m", "pose");
    visit(pose.ty, "pose.ty", "m", "pose");
    visit(pose.tz, "pose.tz", "m", "pose");
  }
  if (setup.thermal) {
    auto& thermal = *setup.thermal;
    visit(thermal.cte, "thermal.cte", "1/K", "thermal");
    visit(thermal.temperature, "thermal.temperature", "degC", "thermal");
  }
}

void CheckInput(const UncertainInput& input) {
  if (!std::isfinite(input.estimate) || !std::isfinite(input.u) || input.u < 0.0) {
    throw InputError("measurement setup: input '" + input.name +
                     "' needs a finite estimate and a finite, non-negative standard uncertainty");
  }
}

// Elementary rotations and their derivatives with respect to the angle.
Eigen::Matrix3d Rx(double a) {
  const double c = std::cos(a), s = std::sin(a);
  Eigen::Matrix3d r;
  r << 1, 0, 0, 0, c, -s, 0, s, c;
  return r;
}
Eigen::Matrix3d Ry(double a) {
  const double c = std::cos(a), s = std::sin(a);
  Eigen::Matrix3d r;
  r << c, 0, s, 0, 1, 0, -s, 0, c;
  return r;
}
Eigen::Matrix3d Rz(double a) {
  const double c = std::cos(a), s = std::sin(a);
  Eigen::Matrix3d r;
  r << c, -s, 0, s, c, 0, 0, 0, 1;
  return r;
}
Eigen::Matrix3d dRx(double a) {
  const double c = std::cos(a), s = std::sin(a);
  Eigen::Matrix3d r;
  r << 0, 0, 0, 0, -s, -c, 0, c, -s;
  return r;
}
Eigen::Matrix3d dRy(double a) {
  const double c = std::cos(a), s = std::sin(a);
  Eigen::Matrix3d r;
  r << -s, 0, c, 0, 0, 0, -c, 0, -s;
  return r;
}
Eigen::Matrix3d dRz(double a) {
  const double c = std::cos(a), s = std::sin(a);
  Eigen::Matrix3d r;
  r << -s, -c, 0, c, -s, 0, 0, 0, 0;
  return r;
}

}  // namespace

Eigen::Matrix3d PoseRotationMatrix(double rx, double ry, double rz) { return Rz(rz) * Ry(ry) * Rx(rx); }

void PoseRotationDerivatives(double rx, double ry, double rz, Eigen::Matrix3d d_rotation[3]) {
  d_rotation[0] = Rz(rz) * Ry(ry) * dRx(rx);
  d_rotation[1] = Rz(rz) * dRy(ry) * Rx(rx);
  d_rotation[2] = dRz(rz) * Ry(ry) * Rx(rx);
}

std::vector<std::string> SharedInputNames(const MeasurementSetup& setup) {
  std::vector<std::string> names;
  ForEachShared(setup, [&](const UncertainInput& input, const char* name, const char*, const char*) {
    names.push_back(input.name.empty() ? std::string(name) : input.name);
  });
  return names;
}

MeasurementModel::MeasurementModel(MeasurementSetup setup) : setup_(std::move(setup)) {
  const ModelInfo* model = setup_.model;
  if (model == nullptr) throw InputError("measurement setup: no tracker model");
  if (model->num_readings != 3 || model->num_outputs != 3) {
    throw InputError(std::string("measurement setup: model '") + model->name +
                     "' is not a tracker model (3 readings -> 3 coordinates)");
  }
  if (model->forward == nullptr || model->forward_jacobians == nullptr) {
    throw InputError(std::string("measurement setup: model '") + model->name + "' has no forward kernels");
  }
  const int num_params = model->num_params;
  if (static_cast<int>(setup_.params.size()) != num_params) {
    throw InputError(std::string("measurement setup: model '") + model->name + "' has " +
                     std::to_string(num_params) + " parameters, " + std::to_string(setup_.params.size()) +
                     " given");
  }
  ForEachShared(setup_, [&](UncertainInput& input, const char* name, const char* unit, const char* group) {
    Fill(input, name, unit, group);
    CheckInput(input);
    shared_.push_back(input);
  });
  int offset = num_params;
  if (setup_.environment) {
    env_offset_ = offset;
    offset += 4;
    const double wavelength = setup_.environment->vacuum_wavelength;
    if (!(wavelength > 0.0) || !std::isfinite(wavelength)) {
      throw InputError("measurement setup: environment vacuum wavelength must be positive");
    }
  }
  if (setup_.pose) {
    pose_offset_ = offset;
    offset += 6;
  }
  if (setup_.thermal) thermal_offset_ = offset;

  std::vector<std::string> names;
  names.reserve(shared_.size());
  for (const UncertainInput& input : shared_) names.push_back(input.name);
  shared_correlation_ = SharedCorrelation(names, setup_.correlations);

  estimates_ = shared_estimates();
  if (env_offset_ >= 0) n_est_ = AirIndex(estimates_.data() + env_offset_, dn_est_);
  if (pose_offset_ >= 0) {
    const double* r = estimates_.data() + pose_offset_;
    rotation_est_ = PoseRotation(estimates_.data());
    PoseRotationDerivatives(r[0], r[1], r[2], d_rotation_est_);
  }
}

Eigen::VectorXd MeasurementModel::shared_estimates() const {
  Eigen::VectorXd x(num_shared());
  for (int k = 0; k < num_shared(); ++k) x(k) = shared_[k].estimate;
  return x;
}

Eigen::Vector3d MeasurementModel::reading_uncertainty(double range) const {
  const ReadingNoise& noise = setup_.noise;
  return {noise.range_a + noise.range_b * std::abs(range), noise.azimuth, noise.elevation};
}

namespace {
AirConditions Air(const Environment& e, const double* env) {
  AirConditions air;
  air.vacuum_wavelength = e.vacuum_wavelength;
  air.temperature = env[0];
  air.pressure = env[1];
  air.humidity = env[2];
  air.co2 = env[3];
  return air;
}
AirEquation Equation(const Environment& e) { return EquationOf(e); }
}  // namespace

AirEquation EquationOf(const Environment& e) { return e.equation; }

std::string_view RangingName(Ranging ranging) {
  switch (ranging) {
    case Ranging::kAbsoluteDistanceMeter: return "adm";
    case Ranging::kAbsoluteInterferometer: return "aifm";
    case Ranging::kInterferometer: break;
  }
  return "ifm";
}

Ranging ParseRanging(std::string_view text, std::string_view where) {
  for (Ranging r : {Ranging::kInterferometer, Ranging::kAbsoluteDistanceMeter, Ranging::kAbsoluteInterferometer}) {
    if (text == RangingName(r)) return r;
  }
  throw InputError(std::string(where) + ": unknown ranging principle '" + std::string(text) +
                   "' (expected one of: ifm, adm, aifm)");
}

RangingIndex IndexOf(Ranging ranging) {
  return ranging == Ranging::kInterferometer ? RangingIndex::kPhase : RangingIndex::kGroup;
}

AirConditions AirAtEstimates(const Environment& e) {
  const double estimates[4] = {e.temperature.estimate, e.pressure.estimate, e.humidity.estimate,
                               e.co2.estimate};
  return Air(e, estimates);
}

double MeasurementModel::AirIndex(const double* env, double* gradient) const {
  const Environment& e = *setup_.environment;
  const RefractiveIndex n = AirRefractiveIndex(Equation(e), Air(e, env), "environment", IndexOf(setup_.ranging));
  gradient[0] = n.dn_dtemperature;
  gradient[1] = n.dn_dpressure;
  gradient[2] = n.dn_dhumidity;
  gradient[3] = n.dn_dco2;
  return n.n;
}

Eigen::Matrix3d MeasurementModel::PoseRotation(const double* shared) const {
  if (pose_offset_ < 0) return Eigen::Matrix3d::Identity();
  const double* r = shared + pose_offset_;
  return PoseRotationMatrix(r[0], r[1], r[2]);
}

Eigen::Vector3d MeasurementModel::PoseTranslation(const double* shared) const {
  if (pose_offset_ < 0) return Eigen::Vector3d::Zero();
  const double* t = shared + pose_offset_ + 3;
  return {t[0], t[1], t[2]};
}

double MeasurementModel::ThermalScale(const double* shared) const {
  if (thermal_offset_ < 0) return 1.0;
  const double cte = shared[thermal_offset_];
  const double dt = shared[thermal_offset_ + 1] - setup_.thermal->reference;
  return 1.0 / (1.0 + cte * dt);
}

double MeasurementModel::RangeScale(const double* shared) const {
  if (env_offset_ < 0) return 1.0;
  // The tracker converted optical path to range with n_est; the true geometric range is
  // optical path / n = rho n_est / n (range scale error mu_env = n_est / n - 1); n is the phase
  // or the group index by the tracker's ranging principle.
  const Environment& e = *setup_.environment;
  return n_est_ /
         AirRefractiveIndexValue(Equation(e), Air(e, shared + env_offset_), "environment", IndexOf(setup_.ranging));
}

void MeasurementModel::TrackerPoint(double range_scale, const double* readings, const double* shared,
                                    double* x_tracker) const {
  double corrected[3] = {readings[0], readings[1], readings[2]};
  if (env_offset_ >= 0) corrected[0] *= range_scale;
  setup_.model->forward(corrected, shared, x_tracker);
}

void MeasurementModel::EvaluateTracker(const double* readings, const double* shared,
                                       double* x_tracker) const {
  TrackerPoint(RangeScale(shared), readings, shared, x_tracker);
}

MeasurementModel::PreparedShared MeasurementModel::PrepareShared(const double* shared) const {
  PreparedShared prepared;
  prepared.shared = shared;
  prepared.range_scale = RangeScale(shared);
  if (pose_offset_ >= 0) {
    prepared.rotation = PoseRotation(shared);
    prepared.translation = PoseTranslation(shared);
  }
  prepared.thermal_scale = ThermalScale(shared);
  return prepared;
}

// The one implementation of the composition y = s (R x_t + t) (Evaluate goes through here). Each
// row's sum is written out, ((R_i0 x + R_i1 y) + R_i2 z) + t_i, rather than left to Eigen, whose
// order depends on its vectorisation (its packet rows and its scalar last row differ): the GPU
// kernel (gpu/point_trials.h PlaceOnPart) does the same operations in the same order.
void MeasurementModel::Place(const PreparedShared& prepared, const Eigen::Vector3d& x_t, double* y) const {
  double x[3] = {x_t(0), x_t(1), x_t(2)};
  if (pose_offset_ >= 0) {
    const Eigen::Matrix3d& r = prepared.rotation;
    const Eigen::Vector3d& t = prepared.translation;
    for (int i = 0; i < 3; ++i) x[i] = ((r(i, 0) * x_t(0) + r(i, 1) * x_t(1)) + r(i, 2) * x_t(2)) + t(i);
  }
  if (thermal_offset_ >= 0) {
    for (double& c : x) c *= prepared.thermal_scale;
  }
  y[0] = x[0];
  y[1] = x[1];
  y[2] = x[2];
}

void MeasurementModel::EvaluatePrepared(const PreparedShared& prepared, const double* readings,
                                        double* y) const {
  Eigen::Vector3d x_t;
  TrackerPoint(prepared.range_scale, readings, prepared.shared, x_t.data());
  Place(prepared, x_t, y);
}

bool MeasurementModel::EvaluatePreparedLanes(const PreparedShared* const* prepared, const double* readings,
                                             const double* params, double* y, std::ptrdiff_t stride) const {
  const ModelInfo& model = *setup_.model;
  constexpr int kL = kForwardLanes;
  if (model.forward_lanes == nullptr) return false;
  if (!has_shared_stages()) {
    // rho' = rho and y = x_t exactly (Place multiplies by nothing): the kernel alone.
    model.forward_lanes(readings, params, y, stride, stride);
    return true;
  }
  // The readings after the air correction and x_t in blocks of kL; the parameters in place.
  double r[3 * kL], x[3 * kL];
  for (int l = 0; l < kL; ++l) {
    // TrackerPoint's air correction, lane by lane.
    r[l] = env_offset_ >= 0 ? readings[l] * prepared[l]->range_scale : readings[l];
    r[kL + l] = readings[stride + l];
    r[2 * kL + l] = readings[2 * stride + l];
  }
  model.forward_lanes(r, params, x, kL, stride);
  for (int l = 0; l < kL; ++l) {
    double y_l[3];
    Place(*prepared[l], Eigen::Vector3d(x[l], x[kL + l], x[2 * kL + l]), y_l);
    for (int i = 0; i < 3; ++i) y[stride * i + l] = y_l[i];
  }
  return true;
}

void MeasurementModel::Evaluate(const double* readings, const double* shared, double* y) const {
  EvaluatePrepared(PrepareShared(shared), readings, y);
}

MeasurementModel::AirStage MeasurementModel::AirAt(const double* shared) const {
  AirStage air;
  if (env_offset_ < 0) return air;
  const double* env = shared + env_offset_;
  const double* est = estimates_.data() + env_offset_;
  if (env[0] == est[0] && env[1] == est[1] && env[2] == est[2] && env[3] == est[3]) {
    air.n = n_est_;  // at the estimates: cached (the AD evaluation of n is the costly part)
    for (int k = 0; k < 4; ++k) air.dn[k] = dn_est_[k];
  } else {
    air.n = AirIndex(env, air.dn);
  }
  air.scale = n_est_ / air.n;
  return air;
}

bool MeasurementModel::NominalParams(const double* shared) const {
  for (int k = 0; k < setup_.model->num_params; ++k) {
    if (shared[k] != 0.0) return false;
  }
  return true;
}

void MeasurementModel::EvaluateWithJacobian(const double* readings, const double* shared, double* y,
                                            double* d_y_d_readings, double* d_y_d_shared) const {
  const ModelInfo& model = *setup_.model;
  // Stage 1: air. rho' = rho * n_est / n.
  const AirStage air = AirAt(shared);
  double corrected[3] = {readings[0], readings[1], readings[2]};
  if (env_offset_ >= 0) corrected[0] *= air.scale;

  // Stage 2: tracker model, generated Jacobians, written in place (ChainStation transforms them).
  if (model.nominal_jacobians != nullptr && NominalParams(shared)) {
    model.nominal_jacobians(corrected, y, d_y_d_readings, d_y_d_shared);
  } else {
    model.forward_jacobians(corrected, shared, y, d_y_d_readings, d_y_d_shared);
  }
  ChainStation(shared, air, corrected[0], y, d_y_d_readings, d_y_d_shared, true);
}

bool MeasurementModel::TrackerHessians(const double* readings, const double* shared, double* hessians) const {
  const ModelInfo& model = *setup_.model;
  if (model.hessians == nullptr) return false;
  const int n = 3 + model.num_params;
  // As EvaluateWithJacobian: rho' = rho n_est / n, so d rho' / d rho = n_est / n.
  const AirStage air = AirAt(shared);
  double corrected[3] = {readings[0], readings[1], readings[2]};
  if (env_offset_ >= 0) corrected[0] *= air.scale;
  model.hessians(corrected, shared, hessians);
  const double range_factor = env_offset_ >= 0 ? air.scale : 1.0;
  const Eigen::Matrix3d m = ThermalScale(shared) * PoseRotation(shared);
  const std::size_t stride = static_cast<std::size_t>(n) * n;
  for (int l = 0; l < n; ++l) {
    for (int k = 0; k < n; ++k) {
      const double c = (k == 0 ? range_factor : 1.0) * (l == 0 ? range_factor : 1.0);
      const std::size_t at = static_cast<std::size_t>(n) * l + k;
      const Eigen::Vector3d h_t(hessians[at], hessians[stride + at], hessians[2 * stride + at]);
      const Eigen::Vector3d h_y = c * (m * h_t);
      for (int a = 0; a < 3; ++a) hessians[a * stride + at] = h_y(a);
    }
  }
  return true;
}

bool MeasurementModel::EvaluateNominalLanes(int count, const double* readings, const double* shared,
                                            double* y, double* d_y_d_readings, double* d_y_d_shared,
                                            double* d_x_t_d_params, Eigen::Matrix3d& linear_map) const {
  if (count < 1 || count > kLanes) {
    throw std::invalid_argument("EvaluateNominalLanes: count " + std::to_string(count) + " is not in 1.." +
                                std::to_string(kLanes));
  }
  const ModelInfo& model = *setup_.model;
  if (model.nominal_jacobians_batch == nullptr || !NominalParams(shared)) return false;
  const int num_shared = this->num_shared();
  const AirStage air = AirAt(shared);
  // Structure of arrays, quantity q of lane l at [kLanes q + l]; lanes beyond count repeat the
  // last point (computed, not used).
  double r[3 * kLanes], x[3 * kLanes], jr[9 * kLanes];
  for (int l = 0; l < kLanes; ++l) {
    const double* point = readings + 3 * std::min(l, count - 1);
    for (int j = 0; j < 3; ++j) r[kLanes * j + l] = point[j];
    if (env_offset_ >= 0) r[l] *= air.scale;  // as EvaluateWithJacobian: rho' = rho n_est / n
  }
  model.nominal_jacobians_batch(r, x, jr, d_x_t_d_params);
  for (int i = 0; i < count; ++i) {
    for (int q = 0; q < 3; ++q) y[3 * i + q] = x[kLanes * q + i];
    for (int q = 0; q < 9; ++q) d_y_d_readings[9 * i + q] = jr[kLanes * q + i];
    linear_map = ChainStation(shared, air, r[i], y + 3 * i, d_y_d_readings + 9 * i,
                              d_y_d_shared + 3 * num_shared * i, false);
  }
  return true;
}

Eigen::Matrix3d MeasurementModel::ChainStation(const double* shared, const AirStage& air,
                                               double corrected_range, double* y, double* d_y_d_readings,
                                               double* d_y_d_shared, bool params_in_place) const {
  if (env_offset_ < 0 && pose_offset_ < 0 && thermal_offset_ < 0) {
    // The tracker alone: the general path below computes y = 1 (I x_t + 0), which for finite
    // x_t is x_t + 0 (x_t, with -0 made +0), and leaves the Jacobians as they are.
    for (int k = 0; k < 3; ++k) y[k] += 0.0;
    return Eigen::Matrix3d::Identity();
  }
  const int num_params = setup_.model->num_params;
  const int num_shared = this->num_shared();
  const Eigen::Vector3d x_t(y[0], y[1], y[2]);
  const Eigen::Matrix3d j_r = Eigen::Map<const Eigen::Matrix3d>(d_y_d_readings);
  // Stages 3 and 4: pose and thermal, as one linear map M = s R applied to the tracker-frame
  // columns.
  bool pose_at_estimates = pose_offset_ >= 0;
  for (int k = 0; k < 3 && pose_at_estimates; ++k) {
    pose_at_estimates = shared[pose_offset_ + k] == estimates_(pose_offset_ + k);
  }
  const Eigen::Matrix3d rotation = pose_at_estimates ? rotation_est_ : PoseRotation(shared);
  const double s = ThermalScale(shared);
  const bool linear_map = pose_offset_ >= 0 || thermal_offset_ >= 0;
  const Eigen::Matrix3d m = s * rotation;
  Eigen::Map<Eigen::Vector3d> out(y);
  const Eigen::Vector3d x_p = rotation * x_t + PoseTranslation(shared);
  out = s * x_p;

  // d y / d readings = M J_r diag(n_est / n, 1, 1).
  Eigen::Map<Eigen::Matrix3d> jy_r(d_y_d_readings);
  jy_r = linear_map ? Eigen::Matrix3d(m * j_r) : j_r;
  jy_r.col(0) *= air.scale;

  // d y / d params = M J_p (in place, column by column).
  if (linear_map && params_in_place) {
    for (int k = 0; k < num_params; ++k) {
      Eigen::Map<Eigen::Vector3d> col(d_y_d_shared + 3 * k);
      col = m * Eigen::Vector3d(col);
    }
  }
  Eigen::Map<Eigen::Matrix<double, 3, Eigen::Dynamic>> jy_s(d_y_d_shared, 3, num_shared);
  if (env_offset_ >= 0) {
    // d rho' / d env_k = -rho n_est / n^2 dn/dk = -(rho' / n) dn/dk.
    const Eigen::Vector3d along_range =
        (linear_map ? Eigen::Vector3d(m * j_r.col(0)) : Eigen::Vector3d(j_r.col(0)));
    for (int k = 0; k < 4; ++k) {
      jy_s.col(env_offset_ + k) = along_range * (-corrected_range / air.n * air.dn[k]);
    }
  }
  if (pose_offset_ >= 0) {
    if (pose_at_estimates) {
      for (int k = 0; k < 3; ++k) jy_s.col(pose_offset_ + k) = s * (d_rotation_est_[k] * x_t);
    } else {
      const double* r = shared + pose_offset_;
      Eigen::Matrix3d d_rotation[3];
      PoseRotationDerivatives(r[0], r[1], r[2], d_rotation);
      for (int k = 0; k < 3; ++k) jy_s.col(pose_offset_ + k) = s * (d_rotation[k] * x_t);
    }
    jy_s.block<3, 3>(0, pose_offset_ + 3) = s * Eigen::Matrix3d::Identity();
  }
  if (thermal_offset_ >= 0) {
    // y = x_p / (1 + cte dT): dy/dcte = -x_p dT s^2 = -y dT s, dy/dT = -y cte s.
    const double cte = shared[thermal_offset_];
    const double dt = shared[thermal_offset_ + 1] - setup_.thermal->reference;
    jy_s.col(thermal_offset_ + 0) = -out * (dt * s);
    jy_s.col(thermal_offset_ + 1) = -out * (cte * s);
  }
  return m;
}

}  // namespace vlt
