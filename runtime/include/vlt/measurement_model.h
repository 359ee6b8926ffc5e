// vlt/measurement_model.h — the complete measurement function of one point, shared by the GUM
// engine (which linearises it) and the Monte Carlo engine (which evaluates it on samples), so
// that both engines propagate exactly the same model.
//
//   y = thermal( pose( tracker_model( readings scaled by the air's refractive index, params ) ) )
//
// Inputs are split into the 3 readings of each point (range [m], azimuth [rad], elevation [rad];
// independent between points, u(range) = a + b*range) and the shared inputs, common to every
// point of a job and therefore the source of correlation between points:
//   [ error parameters of the model | environment | station pose | part thermal ]
// Groups that a job does not enable are absent from the shared vector.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "vlt/model_info.h"
#include "vlt/refractive_index.h"

namespace vlt {

// One uncertain scalar input (JCGM 100 4.1): estimate and standard uncertainty in SI units,
// plus the probability distribution the Monte Carlo engine samples (runtime/distributions).
struct UncertainInput {
  std::string name;   // e.g. "tmv", "environment.temperature", "pose.rx"
  std::string unit;   // SI unit of estimate and u: "m", "rad", "1", "degC", "Pa", ...
  std::string group;  // "parameter", "environment", "pose", "thermal"
  double estimate = 0.0;
  double u = 0.0;  // standard uncertainty
  std::string distribution = "normal";
  double shape = 0.0;  // degrees of freedom (student_t), half-width uncertainty ratio
                       // (curvilinear_trapezoid), ... ; 0 where the distribution has none
  // The estimate and u in the units the job file gave them ("22.3 degC", "0.3 K", "0.4 arcsec");
  // empty when not typed with a unit (model defaults, bare SI numbers): reports then use
  // FormatReadable (vlt/units.h).
  std::string display_estimate;
  std::string display_u;
};

// Standard uncertainty of the readings of one point.
struct ReadingNoise {
  double range_a = 0.0;    // m       u(range) = range_a + range_b * range
  double range_b = 0.0;    // m/m
  double azimuth = 0.0;    // rad
  double elevation = 0.0;  // rad
};

// Air at the tracker: its refractive index scales every range (the tracker compensates with the
// estimates; the deviation of the true index from the compensated one is a range scale error).
struct Environment {
  using Equation = AirEquation;  // one enum for the equation everywhere (vlt/refractive_index.h)
  Equation equation = Equation::kCiddor;
  double vacuum_wavelength = 633e-9;  // m
  UncertainInput temperature;         // degC
  UncertainInput pressure;            // Pa
  UncertainInput humidity;            // relative humidity, % (0..100)
  UncertainInput co2;                 // mole fraction, 1 (e.g. 450e-6)
};

// The refractive-index equation and the air conditions at the estimates of an Environment
// (vlt/refractive_index.h).
AirEquation EquationOf(const Environment& environment);
AirConditions AirAtEstimates(const Environment& environment);

// Station pose: x_part = R * x_tracker + t, R = Rz(rz) * Ry(ry) * Rx(rx).
struct StationPose {
  UncertainInput rx, ry, rz;  // rad
  UncertainInput tx, ty, tz;  // m
};

// R = Rz(rz) Ry(ry) Rx(rx) of a pose (angles [rad]) and its partial derivatives d R / d(rx, ry, rz).
Eigen::Matrix3d PoseRotationMatrix(double rx, double ry, double rz);
void PoseRotationDerivatives(double rx, double ry, double rz, Eigen::Matrix3d d_rotation[3]);

// Part thermal expansion: coordinates reported at the reference temperature,
// x_ref = x_part / (1 + cte * (temperature - reference)).
struct PartThermal {
  UncertainInput cte;          // 1/K
  UncertainInput temperature;  // degC
  double reference = 20.0;     // degC
};

// A group of correlated shared inputs (JCGM 100 5.2, JCGM 101 6.4.8): any shared inputs, named
// as MeasurementModel::shared_inputs() names them (a parameter's name such as "tmv",
// "environment.temperature", "pose.rx", "thermal.temperature"; SharedInputNames), and their
// correlation matrix in the order of `inputs`: symmetric, unit diagonal, entries in [-1, 1],
// positive semi-definite (r = +-1 allowed). An input is in one group at most; inputs in no group
// are independent of every other input. An input with u = 0 may be in a group (it has no effect).
struct CorrelationGroup {
  std::string name;                 // unique among the groups, e.g. "thermometer"; a job's
                                    // calibration file gives the group "calibration"
  std::vector<std::string> inputs;  // shared input names, in matrix order
  Eigen::MatrixXd matrix;           // inputs.size() x inputs.size()
  // Where the group was given, for messages: "job.toml: correlations.thermometer.inputs" and
  // "job.toml: correlations.thermometer.matrix"; empty: "measurement setup: correlation group
  // '<name>'".
  std::string where_inputs;
  std::string where_matrix;
};

// How the tracker measures range, which decides the refractive index that converts its optical
// path to range (vlt/refractive_index.h, docs/units.md "Group index"): an interferometer counts
// fringes (phase index n); an absolute distance meter and an absolute interferometer (frequency
// scanning or several wavelengths) measure a phase against optical frequency, a group delay
// (group index n_g: at 633 nm in standard air about 8e-6 above n, its sensitivities to the air
// about 3 % larger).
enum class Ranging { kInterferometer, kAbsoluteDistanceMeter, kAbsoluteInterferometer };

// "ifm", "adm", "aifm" (the spellings of job files and results.json), and the inverse; an unknown
// one is InputError "<where>: unknown ranging principle '<text>' (expected one of: ifm, adm, aifm)".
std::string_view RangingName(Ranging ranging);
Ranging ParseRanging(std::string_view text, std::string_view where);
// The index of a ranging principle: phase for an interferometer, group otherwise.
RangingIndex IndexOf(Ranging ranging);

struct MeasurementSetup {
  const ModelInfo* model = nullptr;            // a tracker model (3 readings)
  Ranging ranging = Ranging::kInterferometer;  // [tracker] ranging (docs/job-file.md)
  std::vector<UncertainInput> params;          // one per model->params, same order
  std::vector<CorrelationGroup> correlations;  // empty = every shared input independent
  ReadingNoise noise;
  std::optional<Environment> environment;
  std::optional<StationPose> pose;
  std::optional<PartThermal> thermal;
};

// The names of the shared inputs of a setup, in the order of MeasurementModel::shared_inputs():
// the parameters' (the model's names unless given), then "environment.temperature", "...pressure",
// "...humidity", "...co2", "pose.rx", ..., "pose.tz", "thermal.cte", "thermal.temperature" for
// the groups the setup enables (an input's own non-empty name replaces the default).
std::vector<std::string> SharedInputNames(const MeasurementSetup& setup);

// Checks a correlation matrix: square, finite, symmetric, unit diagonal, entries in [-1, 1],
// positive semi-definite (smallest eigenvalue >= -1e-10; r = +-1 pass). InputError
// "<where>: <problem>" (one line).
void CheckCorrelationMatrix(const Eigen::MatrixXd& matrix, const std::string& where);

// The correlation matrix of the shared inputs named `names` (SharedInputNames order): the identity
// with the entries of every group. Each group is checked (names known, each input in one group
// only, group names unique, matrix of the right size and a correlation matrix:
// CheckCorrelationMatrix); InputError at the group's where_inputs / where_matrix. The one place
// where groups become a matrix (MeasurementModel, the job reader's checks).
Eigen::MatrixXd SharedCorrelation(const std::vector<std::string>& names,
                                  const std::vector<CorrelationGroup>& groups);

class MeasurementModel {
 public:
  explicit MeasurementModel(MeasurementSetup setup);

  const MeasurementSetup& setup() const { return setup_; }
  // The shared inputs in order: params, then environment, pose, thermal (enabled ones only).
  const std::vector<UncertainInput>& shared_inputs() const { return shared_; }
  int num_shared() const { return static_cast<int>(shared_.size()); }
  Eigen::VectorXd shared_estimates() const;
  // Correlation of the shared inputs, S x S: SharedCorrelation of setup().correlations.
  const Eigen::MatrixXd& shared_correlation() const { return shared_correlation_; }
  // Standard uncertainties of the 3 readings of a point at this range.
  Eigen::Vector3d reading_uncertainty(double range) const;

  // y (part frame, at reference temperature when thermal is enabled) from the readings of one
  // point and a value of every shared input. Exact: no linearisation anywhere.
  // Same as EvaluatePrepared(PrepareShared(shared), readings, y): one implementation.
  void Evaluate(const double* readings, const double* shared, double* y) const;

  // The stages that depend on the shared inputs only, computed once for a value of the shared
  // vector and reused for every point evaluated at it (the Monte Carlo engine: once per trial,
  // not once per point): the air's range scale n_est / n (Ciddor / Edlen, the costly part), the
  // pose R, t and the thermal scale s. Refers to the shared vector it was prepared from (the
  // tracker model reads its error parameters there), which must outlive it.
  struct PreparedShared {
    const double* shared = nullptr;  // the shared vector (params | environment | pose | thermal)
    double range_scale = 1.0;        // n_est / n(t, p, RH, x); 1 without environment
    Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  // R; identity without pose
    Eigen::Vector3d translation = Eigen::Vector3d::Zero();   // t [m]; zero without pose
    double thermal_scale = 1.0;  // s = 1 / (1 + cte (T - T_ref)); 1 without thermal
  };
  PreparedShared PrepareShared(const double* shared) const;
  // y of one point at the prepared shared inputs, bit for bit Evaluate(readings, shared, y):
  //   rho' = rho (n_est / n),  x_t = f(rho', A, E; params),  y = s (R x_t + t).
  void EvaluatePrepared(const PreparedShared& prepared, const double* readings, double* y) const;
  // EvaluatePrepared for kForwardLanes trials at once (the Monte Carlo job kernel), the tracker
  // model run in SIMD lanes (vlt/model_info.h ForwardLanesFn; its sin/cos are vlt's own, so y
  // may differ from EvaluatePrepared's in the last bits): lane l has prepared[l], the readings
  // readings[stride j + l] and the tracker model's error parameters (the first
  // setup().model->num_params entries of its shared vector) params[stride k + l], in the kernel's
  // layout (the job kernel passes its structure-of-arrays draws in place, stride kSubBatch, and
  // prepared[l].shared need not hold them); it gets y[stride i + l]. stride >= kForwardLanes. The
  // stages before and after the tracker model are EvaluatePrepared's, lane by lane. Returns false,
  // computing nothing, when the model has no lanes kernel (has_forward_lanes()).
  bool EvaluatePreparedLanes(const PreparedShared* const* prepared, const double* readings,
                             const double* params, double* y, std::ptrdiff_t stride = kForwardLanes) const;
  bool has_forward_lanes() const { return setup_.model->forward_lanes != nullptr; }
  // Whether any stage around the tracker model (air, station pose, thermal) is on; without one,
  // y = x_t and PrepareShared's stages are the same (identity) for every shared vector.
  bool has_shared_stages() const { return env_offset_ >= 0 || pose_offset_ >= 0 || thermal_offset_ >= 0; }
  // Same plus d y / d readings (3x3, column-major) and d y / d shared (3 x S, column-major).
  // Chain rule (docs/gum.md "Measurement model"), with rho' = rho n_est / n(t, p, RH, x):
  //   x_t = f(rho', A, E; params)                       tracker model (generated Jacobians)
  //   x_p = R x_t + t,  R = Rz(rz) Ry(ry) Rx(rx)        station pose
  //   y   = x_p / (1 + cte (T - T_ref))                 part thermal expansion
  //   dy/dreadings = s R J_r diag(n_est/n, 1, 1),   s = 1 / (1 + cte (T - T_ref))
  //   dy/dparams   = s R J_p
  //   dy/d env_k   = s R J_r(:,0) * (-rho'/n) dn/d env_k
  //   dy/d r_j     = s (dR/dr_j) x_t,   dy/d t = s I
  //   dy/dcte      = -y (T - T_ref) s,  dy/dT = -y cte s
  void EvaluateWithJacobian(const double* readings, const double* shared, double* y, double* d_y_d_readings,
                            double* d_y_d_shared) const;
  // The tracker model's exact second derivatives (vlt/model_info.h HessiansFn, from vlt-gen)
  // carried to y, for q = (readings, error parameters), the first n = 3 + P inputs of (readings,
  // shared): with q' = (rho n_est / n, A, E, params) the tracker model's inputs and M = s R the
  // pose and thermal map, neither depending on q,
  //   d2 y / dq_k dq_l = M (d2 x_t / dq'_k dq'_l) c_k c_l,  c = (n_est / n, 1, ..., 1).
  // hessians[n * n * a + n * l + k] = d2 y_a / dq_k dq_l (a = 0..2; symmetric, column-major, 3 n^2
  // values, caller-owned). The environment, pose and thermal inputs are not in q: their stages
  // are the runtime's, not generated (gum/nonlinearity.cc takes their columns from differences of
  // exact Jacobians). Returns false, computing nothing, when the model has no Hessians kernel.
  bool TrackerHessians(const double* readings, const double* shared, double* hessians) const;
  // The GUM engine's SIMD path (CovarianceField): EvaluateWithJacobian of `count` points (1 ..
  // kLanes) at shared inputs whose error parameters are all 0, with the tracker kernel run on the
  // points at once in SIMD lanes (vlt/model_info.h NominalJacobiansBatchFn). Returns false, and
  // computes nothing, when that does not apply (parameters not all 0, or a model without the
  // batch kernel). Per point, as EvaluateWithJacobian and bit for bit its numbers: y (3 x kLanes),
  // d_y_d_readings (9 x kLanes) and the columns of d_y_d_shared (3S x kLanes) other than the
  // parameters'. The parameters' columns stay in the lanes for the caller to reduce with SIMD:
  // d_x_t_d_params (3P x kLanes, entry q of point l at [kLanes q + l]) holds d x_t / d params,
  // and d y / d params = linear_map * d x_t / d params (linear_map = s R, the identity without
  // pose and thermal; EvaluateWithJacobian forms exactly these products). Buffers are sized for
  // kLanes points whatever the count; lanes beyond it are scratch.
  static constexpr int kLanes = kNominalBatchLanes;
  bool EvaluateNominalLanes(int count, const double* readings, const double* shared, double* y,
                            double* d_y_d_readings, double* d_y_d_shared, double* d_x_t_d_params,
                            Eigen::Matrix3d& linear_map) const;

  // Intermediate stages at a value of the shared inputs (for the GUM engine's tracker-frame
  // results): the tracker-frame point (after the air correction, before pose and thermal), the
  // pose rotation R (identity without pose) and the thermal scale s (1 without thermal), so that
  // y = s (R x_t + t) and d x_t / d(readings, params, environment) = R^T (dy/d...) / s.
  void EvaluateTracker(const double* readings, const double* shared, double* x_tracker) const;
  Eigen::Matrix3d PoseRotation(const double* shared) const;
  Eigen::Vector3d PoseTranslation(const double* shared) const;
  double ThermalScale(const double* shared) const;

  // Index of the first input of each group in the shared vector, -1 when the group is absent.
  int params_offset() const { return 0; }
  int environment_offset() const { return env_offset_; }
  int pose_offset() const { return pose_offset_; }
  int thermal_offset() const { return thermal_offset_; }
  // Refractive index of the air at the estimates (n_est; 1 without environment).
  double refractive_index_estimate() const { return n_est_; }

 private:
  // n and dn/d(t, p, RH, x) at shared[env_offset_ .. +3].
  double AirIndex(const double* env, double* gradient) const;
  // n_est / n at the shared inputs (1 without environment).
  double RangeScale(const double* shared) const;
  // x_t = f(rho range_scale, A, E; params): the air correction and the tracker model.
  // y = s (R x_t + t) from the tracker-frame point (pose and thermal when enabled).
  void Place(const PreparedShared& prepared, const Eigen::Vector3d& x_t, double* y) const;
  void TrackerPoint(double range_scale, const double* readings, const double* shared,
                    double* x_tracker) const;
  // Stage 1 of EvaluateWithJacobian (the air) at the shared inputs: rho' = rho scale with
  // scale = n_est / n, and dn/d(t, p, RH, x) for the environment's columns.
  struct AirStage {
    double scale = 1.0;
    double n = 1.0;
    double dn[4] = {0, 0, 0, 0};
  };
  AirStage AirAt(const double* shared) const;
  // Whether every error parameter is 0 (the symbolically specialised nominal kernels apply).
  bool NominalParams(const double* shared) const;
  // Stages 3 and 4 (pose, thermal) and the environment's columns, in place: on entry y holds the
  // tracker-frame point x_t, d_y_d_readings the generated J_r and, when params_in_place, the
  // first 3P entries of d_y_d_shared d x_t / d params, all at the air-corrected range. Returns
  // the linear map s R applied to the tracker-frame columns.
  Eigen::Matrix3d ChainStation(const double* shared, const AirStage& air, double corrected_range, double* y,
                               double* d_y_d_readings, double* d_y_d_shared, bool params_in_place) const;

  MeasurementSetup setup_;
  std::vector<UncertainInput> shared_;
  Eigen::MatrixXd shared_correlation_;
  int env_offset_ = -1;
  int pose_offset_ = -1;
  int thermal_offset_ = -1;
  double n_est_ = 1.0;
  // Caches at the estimates (the GUM engine evaluates every point there): dn/d(t, p, RH, x),
  // R and its three partial derivatives. Used when the shared values equal the estimates.
  Eigen::VectorXd estimates_;
  double dn_est_[4] = {0, 0, 0, 0};
  Eigen::Matrix3d rotation_est_ = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d d_rotation_est_[3];
};

}  // namespace vlt
