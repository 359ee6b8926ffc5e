// vlt/gum.h — the GUM engine: law of propagation of uncertainty (JCGM 100 5.1.2, 5.2.2; vector
// form JCGM 102 6.2.1.3) through the measurement model of vlt/measurement_model.h.
//
// What is propagated (docs/gum.md):
//  - Per point: U_y = J_r U_r J_r^T + J_s U_s J_s^T, with J_r = d y / d readings (3x3),
//    U_r = diag(u(range)^2, u(azimuth)^2, u(elevation)^2) (readings independent between points
//    and between the three readings), J_s = d y / d shared inputs (3 x S) and U_s the covariance
//    of the shared inputs (diagonal except the correlation groups of the setup, which may link
//    any shared inputs: MeasurementSetup::correlations). The linearisation is
//    at the estimates (JCGM 100 5.1.2: first-order Taylor series); the Monte Carlo engine
//    validates it (JCGM 101 8).
//  - Expanded uncertainty per axis U = k u with k from the coverage probability p assuming a
//    normal output (k = 1.96 for p = 0.95, JCGM 100 6.2.1, G.1.3); the 3-D coverage ellipsoid
//    uses k^2 = chi^2_3(p) (JCGM 102 6.5.2.3; k = 2.796 for p = 0.95).
//  - Between points: the shared inputs correlate them. A task (distance, plane, sphere, circle,
//    line) over N points gets cov_task = (G J_s) U_s (G J_s)^T + sum_i G_i (J_r,i U_r,i J_r,i^T) G_i^T
//    with G = d task / d point coordinates (vlt/fits.h). Neither J_s (3N x S) nor the 3N x 3N
//    joint covariance is ever stored: G J_s is accumulated point by point (k x S).
//
// Everything is SI (m, rad, degC, Pa, %, 1, 1/K). Results never contain NaN: a singular point
// (zero range, on the standing axis) or a non-finite result throws NumericalError naming the point.
#pragma once

#include <limits>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "vlt/fits.h"
#include "vlt/measurement_model.h"
#include "vlt/model_info.h"
#include "vlt/tasks.h"

namespace vlt {

// ---------------------------------------------------------------------------------------------
// Coverage factors (computed, not tabulated).

// k such that a normal output lies in [y - k u, y + k u] with probability p:
// k = Phi^-1((1 + p) / 2) (JCGM 100 G.1.3). p in (0, 1); else std::invalid_argument.
double NormalCoverageFactor(double p);
// k with k^2 = chi^2_m(p), the p-quantile of the chi-square distribution with m degrees of
// freedom (JCGM 102 6.5.2.3; k = 2.448 for m = 2, 2.796 for m = 3 at p = 0.95).
double ChiSquareCoverageFactor(double p, int m);
// P(chi^2_m <= x): the chi-square distribution function with m degrees of freedom (regularized
// lower incomplete gamma P(m/2, x/2)); 0 for x <= 0.
double ChiSquareCdf(double x, int m);

// The fit test of an adjustment (vlt calibrate, vlt network; docs/calibration.md "Fit"): "" when
// the residuals are what the model and the stated uncertainties make likely, else why not, one
// line: chi-square's upper tail p below kFitProblemP, or the largest |w| of the `tested` normalised
// residuals beyond z_(1 - alpha/(2 n)), alpha = kFitProblemAlphaW (any of n good observations
// exceeds it with probability alpha; a lone |w| > 3.29 among a thousand is expected).
inline constexpr double kFitProblemP = 0.001;
inline constexpr double kFitProblemAlphaW = 0.01;
std::string FitProblem(double chi2, int dof, double largest_w, int tested);
// t_p(nu): P(|t_nu| <= k) = p for Student's t with nu degrees of freedom (JCGM 100 G.3.4, table
// G.2: t_95.45(16) = 2.17, t_99(16) = 2.92); nu = infinity gives NormalCoverageFactor(p).
// nu >= 1 (non-integer allowed); else std::invalid_argument.
double StudentTCoverageFactor(double p, double nu);
// Welch-Satterthwaite (JCGM 100 G.4.1, eq. G.2b): nu_eff = u_c^4 / sum_i (u_i(y)^4 / nu_i) over
// independent components u_i(y) (signed or not: only u_i^2 enters) with nu_i degrees of freedom
// (infinite ones contribute nothing). Returns infinity when every nu_i is infinite or u_c = 0.
double WelchSatterthwaite(double u_c, const std::vector<double>& component_variances,
                          const std::vector<double>& component_dof);

// Unit of a sensitivity coefficient d output / d input from the two units: "m" and "rad" ->
// "m/rad"; "m" and "m" -> "m/m"; "m" and "1" -> "m"; temperatures ("degC") enter as differences
// -> "m/K"; "m" and "1/K" -> "m*K"; "1" and "m" -> "1/m".
std::string SensitivityUnit(const std::string& output_unit, const std::string& input_unit);

// ---------------------------------------------------------------------------------------------
// Per point.

struct GumOptions {
  double coverage_probability = 0.95;  // p of every coverage interval / region
  bool budgets = true;                 // fill PointUncertainty::budget
  int threads = 0;                     // 0: all hardware threads (results do not depend on it)
};

// One measured point: its label and the three readings (range [m], azimuth [rad], elevation [rad]).
struct PointReadings {
  std::string name;
  Eigen::Vector3d readings = Eigen::Vector3d::Zero();
};

// One row of an uncertainty budget (JCGM 100 8, 7.2.5-7.2.6) for the 3 coordinates of a point.
struct BudgetRow {
  std::string input;       // "range", "azimuth", "elevation", a parameter name,
                           // "environment.temperature", "pose.rx", ..., or "correlations"
  std::string group;       // "reading", "parameter", "environment", "pose", "thermal",
                           // or "correlation" for the correlation row
  std::string input_unit;  // unit of estimate and u ("" for the correlation row)
  double estimate = 0.0;
  double u = 0.0;  // standard uncertainty of the input (0 for the correlation row)
  Eigen::Vector3d sensitivity = Eigen::Vector3d::Zero();  // c = d y_axis / d input (part frame)
  std::string sensitivity_unit;  // e.g. "m/rad", "m/m", "m/K", "m/Pa" (SensitivityUnit)
  Eigen::Vector3d contribution = Eigen::Vector3d::Zero();  // c * u per axis, signed [m];
                                                           // correlation row: signed sqrt(|term|) per axis
  Eigen::Vector3d variance = Eigen::Vector3d::Zero();      // (c u)^2 per axis [m^2]; correlation
      // row: 2 sum_{i<j} c_i c_j u_i u_j r_ij (may be negative)
  Eigen::Vector3d share = Eigen::Vector3d::Zero();  // variance / u^2(y_axis), 0..1 (the
                                                    // correlation row may be negative); each axis sums to 1
  double share_total = 0.0;  // sum of variance over axes / trace(U_y); rows sorted by it
};

// Coverage region (JCGM 102 6.5.2.3): {y' : (y'-y)^T U_y^-1 (y'-y) <= k^2}, k^2 = chi^2_3(p).
struct CoverageEllipsoid {
  double k = 0.0;                                            // sqrt(chi^2_3(p))
  Eigen::Vector3d semi_axes = Eigen::Vector3d::Zero();       // k sqrt(eigenvalues of U_y), descending [m]
  Eigen::Matrix3d directions = Eigen::Matrix3d::Identity();  // column j: unit axis of semi_axes(j)
};

// Split of a covariance along the line of sight. Directions (tracker frame, from the estimate
// x of the point in the tracker frame, A = atan2(x_y, x_x), E = atan2(x_z, hypot(x_x, x_y))):
//   radial     r = x / |x|                            (along the beam)
//   horizontal h = (-sin A, cos A, 0)                 (transverse, horizontal, toward +A)
//   vertical   v = r x h = (-sin E cos A, -sin E sin A, cos E)  (transverse, toward +E)
// For the part-frame covariance the same three directions rotated by the pose estimate R are
// used. u_* = sqrt(d^T U d).
struct LineOfSightSplit {
  Eigen::Matrix3d directions = Eigen::Matrix3d::Identity();  // columns r, h, v in that frame
  double u_radial = 0.0;
  double u_horizontal = 0.0;
  double u_vertical = 0.0;
};

struct PointUncertainty {
  std::string name;
  Eigen::Vector3d readings = Eigen::Vector3d::Zero();  // range, azimuth, elevation as given
  // Tracker frame: output of the tracker model (readings, params, environment) before pose and
  // thermal. Its covariance has the contributions of readings, params and environment only.
  Eigen::Vector3d tracker = Eigen::Vector3d::Zero();
  Eigen::Matrix3d cov_tracker = Eigen::Matrix3d::Zero();
  Eigen::Vector3d u_tracker = Eigen::Vector3d::Zero();
  LineOfSightSplit los_tracker;
  // Part frame (= the output y of MeasurementModel: pose applied, at the reference temperature
  // when thermal is enabled; equal to the tracker frame when neither is enabled). All inputs.
  Eigen::Vector3d part = Eigen::Vector3d::Zero();
  Eigen::Matrix3d cov_part = Eigen::Matrix3d::Zero();
  Eigen::Vector3d u_part = Eigen::Vector3d::Zero();  // standard uncertainty per axis
  double k = 0.0;                                    // NormalCoverageFactor(p)
  Eigen::Vector3d U_part = Eigen::Vector3d::Zero();  // expanded, k * u_part
  LineOfSightSplit los_part;
  CoverageEllipsoid ellipsoid;       // of cov_part
  std::vector<BudgetRow> budget;     // part frame; empty if !options.budgets
  std::string correlation_handling;  // how correlated inputs enter the budget
  // Non-linearity (CheckSecondOrder; zero until it ran): the second-order variance per part-frame
  // coordinate (JCGM 100 5.1.2 note) and its ratio to the first-order u^2; gum_reliable = false
  // when a ratio exceeds the threshold: the linearised u is then not to be trusted here.
  Eigen::Vector3d second_order_variance = Eigen::Vector3d::Zero();
  Eigen::Vector3d second_order_ratio = Eigen::Vector3d::Zero();
  bool gum_reliable = true;
  // Whether the second-order terms describe the model over the inputs' spread (the rule of
  // SecondOrderDecides, docs/gum.md "Non-linearity"). false: the curvature changes within one
  // standard uncertainty (a pole, a kink or a singular direction nearby): gum_reliable is then
  // false and the ratio does not say by how much the GUM is off: Monte Carlo does.
  bool second_order_decided = true;
};

// Default threshold of CheckSecondOrder: second-order terms above 1 % of u^2 (u off by > 0.5 %).
inline constexpr double kSecondOrderThreshold = 0.01;

// The rule that says whether second-order terms can decide (docs/gum.md "Non-linearity"): the
// second-order variance of an output from its Hessian at the estimate (v_local, exact derivatives)
// and from central differences of the Jacobian over +-1 standard uncertainty of each input
// (v_span) must agree within a factor 2 in standard uncertainty (sqrt), unless both are
// negligible (at most threshold / 100 of the first-order variance var). For a quadratic model the
// two are equal; they part where the curvature itself changes within the inputs' spread.
bool SecondOrderDecides(double v_local, double v_span, double var, double threshold = kSecondOrderThreshold);

// Fills second_order_variance, second_order_ratio, second_order_decided and gum_reliable of
// `results` (from PropagatePoints for the same points): u2^2(y_a) = 1/2 ||F^T H_a F||_F^2 with
// the Hessian H_a over +-1 standard uncertainty of each independent input (central differences
// of the generated Jacobians: 2 (3 + S) evaluations per point) and, where those terms exceed a
// tenth of the threshold, at the point itself (exact: the model's generated Hessians, the
// environment, pose and thermal columns differenced), the two compared by SecondOrderDecides
// (docs/gum.md "Non-linearity").
void CheckSecondOrder(const MeasurementModel& model, std::span<const PointReadings> points,
                      std::span<PointUncertainty> results, double threshold = kSecondOrderThreshold,
                      int threads = 0);

// Propagates every point. Throws NumericalError "point '<name>': ..." for a singular point
// (range <= 0, on the standing axis) or a non-finite result.
std::vector<PointUncertainty> PropagatePoints(const MeasurementModel& model,
                                              std::span<const PointReadings> points,
                                              const GumOptions& options = {});
// The same into `results`, resized to the points' count; every field of a record is written
// (second_order_* reset as before CheckSecondOrder), so a scan's blocks reuse one array of records
// instead of constructing 65 536 new ones per block on one thread (issue 33).
void PropagatePoints(const MeasurementModel& model, std::span<const PointReadings> points,
                     const GumOptions& options, std::vector<PointUncertainty>& results);

// Lean path for maps: expanded uncertainty per axis (part frame, k = NormalCoverageFactor(p))
// for each reading triple, no budgets, no names (the singular-point message names the index).
std::vector<Eigen::Vector3d> ExpandedUncertaintyField(const MeasurementModel& model,
                                                      std::span<const Eigen::Vector3d> readings,
                                                      double coverage_probability = 0.95, int threads = 0);

// Lean path for the full covariance: U_y (3 x 3, part frame, m^2) of each reading triple at the
// shared estimates, JCGM 100 5.2.2 in matrix form, as PropagatePoints' cov_part (to rounding:
// the sums are formed in another order) without the per-point results around it. The points go
// through the model 4 at a time in SIMD lanes (MeasurementModel::EvaluateWithJacobians).
std::vector<Eigen::Matrix3d> CovarianceField(const MeasurementModel& model,
                                             std::span<const Eigen::Vector3d> readings, int threads = 0);

// What each source contributes to the map value |U| = k sqrt(trace U_y) (vlt map's per-source
// layers, docs/gum.md "Sources of a map"). The columns of [J_r U_r^1/2 | J_s F] (F the factor of
// the shared covariance, gum/internal.h) are grouped into sources: the three readings, each
// independent shared input with u > 0, and each block of correlated shared inputs (one source:
// the correlation makes its inputs' contributions inseparable). For source s at a node
//   U_s = k sqrt(sum over the three axes and the source's columns of (J F)^2),
// so that sum_s U_s^2 = |U|^2 exactly: the per-source maps add up in quadrature to the total.
struct UncertaintySource {
  std::string name;   // "range", "azimuth", "elevation", a shared input's name (SharedInputNames)
                      // or "correlations.<group>" for a correlated block ("#2", ... when a group
                      // falls into several blocks)
  std::string group;  // "reading", "parameter", "environment", "pose", "thermal" or "correlation"
};
std::vector<UncertaintySource> UncertaintySources(const MeasurementModel& model);
// U_s of every source (UncertaintySources order) at every reading triple: sources x points [m].
Eigen::MatrixXd ExpandedUncertaintyBySource(const MeasurementModel& model,
                                            std::span<const Eigen::Vector3d> readings,
                                            double coverage_probability = 0.95, int threads = 0);

// ---------------------------------------------------------------------------------------------
// Offline (plan) mode: the readings that would measure a nominal point given in the part frame
// (at the reference temperature), using the estimates of every shared input: undo thermal, undo
// the pose (x_tracker = R^T (x_part - t)), then invert the tracker model.
// back_face: return the back-face readings (A + pi, pi - E) of the same point. `name` is used in
// the NumericalError message for a point on the standing axis or at the origin.
Eigen::Vector3d ReadingsForPartPoint(const MeasurementModel& model, const Eigen::Vector3d& part,
                                     bool back_face = false, const std::string& name = "");

// ---------------------------------------------------------------------------------------------
// Tasks: quantities computed from several points, with the correlation between the points.

// Contribution of one group of inputs to the task covariance: "readings" (the independent
// reading noise of all points) or a shared group ("parameter", "environment", "pose",
// "thermal": its covariance with the correlations inside it). When correlation groups link inputs
// of different groups, the entry "correlation" holds the cross terms between groups (may be
// negative). The entries add up to the total.
struct TaskGroupContribution {
  std::string group;
  Eigen::VectorXd variance;  // per task quantity [unit^2]
  Eigen::VectorXd share;     // variance / total variance per quantity
};

struct TaskUncertainty {
  std::string name;
  TaskKind kind = TaskKind::kDistance;
  std::vector<std::string> quantities;  // e.g. {"distance"}, {"centre.x", ..., "radius"}
  std::vector<std::string> units;       // "m" or "1" (direction components)
  Eigen::VectorXd value;                // from the point estimates in the part frame
  Eigen::MatrixXd covariance;           // k x k
  Eigen::VectorXd u;                    // sqrt(diag(covariance))
  double k = 0.0;                       // NormalCoverageFactor(p)
  Eigen::VectorXd U;                    // k * u
  // false for a quantity whose derivative does not exist at the estimates (vlt/fits.h: flatness,
  // straightness, rms of points that fit exactly): its u and U are 0 and mean "no GUM value";
  // reports must print "n/a" (Monte Carlo still gives one).
  std::vector<bool> differentiable;
  std::vector<TaskGroupContribution> budget;  // by input group, sorted by summed share
  // Budget per individual shared input: variance per quantity of (G J_s)_col u_col (correlated
  // inputs counted without their cross terms; those are in the "correlations" row).
  std::vector<std::string> shared_input_names;
  Eigen::MatrixXd shared_input_variance;  // k x (S + 1): last column = correlation term
  // A task weighted by its points' covariance (TaskSpec::weighted): the fit's fixed weights (for
  // the Monte Carlo trials, vlt/fits.h TrialFitOptions), r^T W r and its degrees of freedom.
  std::shared_ptr<const FitWeights> weights;
  double chi2 = 0.0;
  int degrees_of_freedom = 0;
};

// Propagates to one task: task.points name entries of `points` (ResolveTaskPoints); the
// estimates and Jacobians are recomputed from their readings, point by point (memory O(N + S),
// never 3N x 3N). Throws InputError for unknown point names, NumericalError for a singular
// point or fit.
TaskUncertainty PropagateTask(const MeasurementModel& model, std::span<const PointReadings> points,
                              const TaskSpec& task, const GumOptions& options = {});
// The same with task.points already resolved to `indices` into `points` (a job resolves them when
// it is read: a scan's task over 10^6 points then copies no name).
TaskUncertainty PropagateTask(const MeasurementModel& model, std::span<const PointReadings> points,
                              const TaskSpec& task, std::span<const int> indices, const GumOptions& options);

// Low level, for any task function: value (k) and G = d value / d coordinates (k x 3n, columns
// 3j..3j+2 = point indices[j], part frame) already computed by the caller from the part-frame
// estimates of the points. Fills covariance, u, U and the budgets of the result; `result` keeps
// its name, kind, quantities, units and value. Accumulates G J_s point by point (k x S) and the
// reading terms G_j J_r,j U_r,j J_r,j^T G_j^T; memory O(k S) per chunk of points.
void PropagateTaskCovariance(const MeasurementModel& model, std::span<const PointReadings> points,
                             std::span<const int> indices, const Eigen::MatrixXd& g,
                             const GumOptions& options, TaskUncertainty& result);

// The covariance of points[indices] as a weighted fit takes it (vlt/fits.h PointCovariance): each
// point's readings block J_r U_r J_r^T, and the shared inputs' factor J_s F (3N x S, U_s = F F^T).
PointCovariance TaskPointCovariance(const MeasurementModel& model, std::span<const PointReadings> points,
                                    std::span<const int> indices, int threads = 0);

// Part-frame estimates of the points (MeasurementModel::Evaluate at the shared estimates).
std::vector<Eigen::Vector3d> PointEstimates(const MeasurementModel& model,
                                            std::span<const PointReadings> points, int threads = 0);

// ---------------------------------------------------------------------------------------------
// Custom models (no readings; every input is an UncertainInput): the JCGM 100 law of
// propagation for vector outputs, U_y = J U_x J^T, J from model.forward_jacobians at the
// estimates. `correlation` empty = independent, else num_params x num_params.
struct CustomOutput {
  std::string name;
  std::string unit;
  double estimate = 0.0;
  double u = 0.0;
  // Effective degrees of freedom (JCGM 100 G.4.1) and the coverage factor k = t_p(nu_eff) with
  // nu_eff truncated to the next lower integer (G.4.1 note 1, G.6.4); infinity and the normal k
  // when every input's degrees of freedom are infinite.
  double dof_effective = std::numeric_limits<double>::infinity();
  double k = 0.0;
  double U = 0.0;  // k u
  // Non-linearity (JCGM 100 5.1.2 note), as CheckSecondOrder does for points: the leading
  // second-order variance u2^2 = 1/2 ||F^T H F||_F^2 (H the Hessian of the output at the
  // estimates, exact: the model's generated Hessians, ModelInfo::hessians; for a model without
  // them Richardson-extrapolated central differences of its Jacobian at 10^-3 and 5 10^-4
  // standard uncertainties; F the factor of the input covariance), its ratio to u^2, and
  // gum_reliable = second_order_decided and the ratio
  // <= kSecondOrderThreshold (the terms over +-1 u only decide, SecondOrderDecides). For GUM H.1
  // sqrt(u^2 + u2^2) is the 34 nm of H.1.7; for JCGM 101 9.3 the 0.0750 mg of its table 7.
  double second_order_variance = 0.0;
  double second_order_ratio = 0.0;
  bool gum_reliable = true;
  bool second_order_decided = true;  // SecondOrderDecides (PointUncertainty::second_order_decided)
  std::vector<BudgetRow> budget;     // only .sensitivity(0), .contribution(0), .variance(0),
                                     // .share(0) are used (scalar output); sorted by share
};

struct CustomUncertainty {
  std::vector<CustomOutput> outputs;
  Eigen::MatrixXd covariance;   // num_outputs x num_outputs
  Eigen::MatrixXd correlation;  // of the outputs (identity where a u is 0)
  double k = 0.0;               // normal coverage factor (infinite degrees of freedom)
  // JCGM 102 6.5.2.3 coverage region of the output vector (>= 2 outputs): k = sqrt(chi2_m(p)).
  double region_k = 0.0;
  std::string correlation_handling;
};

// Degrees of freedom of the inputs for the effective degrees of freedom of each output.
//  - dof[i]: nu_i of input i (JCGM 100 G.3.3 Type B from the relative uncertainty of u, G.3.2
//    n - 1 for a Type A mean); empty or infinity = known exactly (G.4.2).
//  - components: sets of inputs that count as ONE component of the Welch-Satterthwaite sum,
//    with the smallest nu of its members, its variance sum_{i,j} c_i c_j u_i u_j r_ij: the inputs
//    of the same simultaneous observations (nu = n - 1; the per-set evaluation of JCGM 100 H.2.4
//    has the same nu). Other inputs are components of their own, also when `correlation`
//    correlates them: their cross terms enter u_c but not the sum (the formula assumes
//    independent components; merging would make nu_eff jump with a negligible r;
//    docs/custom-models.md).
struct InputDegreesOfFreedom {
  std::vector<double> dof;
  std::vector<std::vector<int>> components;
};

CustomUncertainty PropagateCustom(const ModelInfo& model, std::span<const UncertainInput> inputs,
                                  const Eigen::MatrixXd& correlation = {}, const GumOptions& options = {},
                                  const InputDegreesOfFreedom& degrees_of_freedom = {});

}  // namespace vlt
