// vlt/fits.h — the task quantities: distance between two points, the two-face difference of a
// point measured in both faces, and least-squares features (plane, sphere, circle, line,
// cylinder, cone), each with its Jacobian with respect to the point coordinates.
//
// One definition of every task serves both engines: the GUM engine calls with
// options.jacobian = true and propagates G = d outputs / d point coordinates; the Monte Carlo
// engine refits every trial with options.jacobian = false. Definitions, sign conventions and
// parametrisations: docs/tasks.md.
//
// Jacobians are exact derivatives of the fitted values (implicit function theorem on the fit's
// stationarity conditions / first-order eigenvector perturbation), never finite differences.
// Memory and time are O(N) for N points (the Jacobian is k x 3N with k <= 10 outputs).
//
// Everything is SI: coordinates and lengths in m, unit vectors dimensionless ("1").
#pragma once

#include <memory>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "vlt/tasks.h"

namespace vlt {

// The covariance of a task's N points (3N x 3N, SI, point-major: rows 3i..3i+2 are point i's x,
// y, z), for a fit weighted by it: V = blockdiag(blocks) + shared shared^T, as the GUM engine
// has it (each point's own readings, then the inputs the points share through a factor of their
// covariance), or `dense` when given (a network adjustment's joint covariance).
struct PointCovariance {
  std::vector<Eigen::Matrix3d> blocks;  // N, each symmetric positive semi-definite [m^2]
  Eigen::MatrixXd shared;               // 3N x r [m]
  Eigen::MatrixXd dense;                // 3N x 3N [m^2]; when non-empty, blocks and shared are unused
};

// The fixed weight matrix W = V_d^-1 of a covariance-weighted fit (docs/tasks.md "Fits weighted by
// the points' covariance"): V_d = D V D^T is the covariance of the fit's residuals, D their
// derivative with respect to the points at the ordinary fit to the estimates. Made by the first
// weighted fit (FitResult::weights) and handed to every Monte Carlo trial (FitOptions::weights),
// so that each trial's estimator is the one the GUM engine differentiates. Opaque (tasks/).
class FitWeights;

// One output quantity of a task.
struct TaskOutput {
  std::string_view name;         // e.g. "radius", "normal_z"
  std::string_view unit;         // "m" or "1"
  std::string_view description;  // one sentence, with the sign convention where there is one
};

// The outputs of each kind, in the order of FitResult::values (static storage):
//   distance: distance
//   plane:    centroid_x, centroid_y, centroid_z, normal_x, normal_y, normal_z, flatness, rms
//   sphere:   centre_x, centre_y, centre_z, radius, rms
//   circle:   centre_x, centre_y, centre_z, radius, normal_x, normal_y, normal_z, rms
//   line:     point_x, point_y, point_z, direction_x, direction_y, direction_z, straightness, rms
//   two_face: dx, dy, dz
//   cylinder: point_x, point_y, point_z, direction_x, direction_y, direction_z, radius,
//             cylindricity, rms
//   cone:     point_x, ..., direction_z, radius, half_angle, form, rms
//   best_fit, rps: tx, ty, tz, rx, ry, rz, rms      (best_fit_scale: ..., rms, scale)
//   deviation: deviation, dx, dy, dz              (position: ..., dz, position)
//   profile: min_deviation, max_deviation, profile
//   flatness: flatness, flatness_least_squares     (straightness, roundness, cylindricity alike)
std::span<const TaskOutput> TaskOutputs(TaskKind kind);

struct FitOptions {
  // Compute FitResult::jacobian (GUM). Off for Monte Carlo trials.
  bool jacobian = false;
  // Threads for the Jacobian's columns of a plane or sphere fit (a scan's plane over 10^6 points:
  // 8 x 3N values); 0: all. Each column is computed alone: the same bits for any count.
  int threads = 1;
  // Sign of the plane/circle normal and of the line/cylinder/cone direction: chosen so that
  // dot(normal, orientation) >= 0. When zero (default), the component of largest magnitude is
  // made positive (ties: the first of x, y, z). A Monte Carlo engine should pass the normal /
  // direction of the fit to the estimates, so that no trial flips sign. A cylinder or cone fit
  // also starts its axis along it (else across the points' three principal directions).
  Eigen::Vector3d orientation = Eigen::Vector3d::Zero();
  // best_fit, best_fit_scale, rps, deviation, position, profile: the nominal geometry
  // (TaskSpec::nominal); required.
  std::shared_ptr<const NominalGeometry> nominal;
  // best_fit: each angle rx, ry, rz is returned within pi of these (the angles of the fit to the
  // estimates, so that no Monte Carlo trial of a rotation near 180 degrees jumps by 2 pi).
  std::optional<Eigen::Vector3d> reference_angles;
  // A fit weighted by the points' covariance (generalised least squares): minimises r^T W r over
  // the fit's residuals r, W = (D V D^T)^-1, instead of r^T r. `weights` when given (a Monte Carlo
  // trial: the weights of the fit to the estimates), else made from `covariance` at this fit's
  // ordinary solution. Plane, sphere, circle, line, cylinder, cone, best_fit, best_fit_scale, rps
  // and the deviations and profiles over them; any other kind throws InputError.
  std::shared_ptr<const PointCovariance> covariance;
  std::shared_ptr<const FitWeights> weights;
};

// True for the kinds a fit weighted by the points' covariance applies to (FitOptions::covariance).
bool Weightable(TaskKind kind);

// The options a task's own definition implies: its nominal geometry (alignment kinds).
FitOptions TaskFitOptions(const TaskSpec& task, bool jacobian);
// The options of a Monte Carlo trial of `task` (no Jacobian): TaskFitOptions, and the normal /
// direction (plane, circle, line, cylinder, cone) or the angles (best_fit) of the fit to the estimates, whose
// outputs are `at_estimates` (TaskOutputs order), so that no trial flips a sign or turns by 2 pi.
// A weighted task (TaskSpec::weighted) passes the weights of that fit (FitResult::weights).
FitOptions TrialFitOptions(const TaskSpec& task, const Eigen::VectorXd& at_estimates,
                           std::shared_ptr<const FitWeights> weights = nullptr);

struct FitResult {
  TaskKind kind = TaskKind::kDistance;
  std::span<const TaskOutput> outputs;  // = TaskOutputs(kind)
  Eigen::VectorXd values;               // one per output, SI
  // d values / d point coordinates, outputs.size() x 3N, column 3*i + c is coordinate c (x, y, z)
  // of point i (the column order of the points argument). Empty unless options.jacobian.
  Eigen::MatrixXd jacobian;
  // false for an output whose derivative does not exist at this point set: flatness, straightness
  // and rms of a point set that fits exactly (all residuals zero, e.g. nominal points of a plan).
  // Its Jacobian row is then zero; the GUM engine must not report a GUM uncertainty for it
  // (Monte Carlo can). Ties of the extreme residuals are resolved by the first point reaching
  // the extreme (a one-sided derivative), see docs/tasks.md.
  std::vector<bool> differentiable;
  int iterations = 0;  // Levenberg-Marquardt + Newton iterations (sphere, circle, cylinder, cone), else 0
  // A weighted fit: the weights it used (FitOptions::weights), and r^T W r at its solution with
  // its degrees of freedom (residual rows less parameters; chi-squared when the covariance
  // accounts for the form error too). Else null and 0.
  std::shared_ptr<const FitWeights> weights;
  double chi2 = 0.0;
  int degrees_of_freedom = 0;
};

// Each function throws InputError "<where>: <kind> needs at least M points, got N" (distance,
// two_face: exactly 2) or "<where>: <kind>: point i has a non-finite coordinate", and
// NumericalError "<where>: <kind>: <reason>" when the feature is undefined for the points
// (coincident points, collinear points for a plane or circle, coplanar points for a sphere, no
// preferred direction) or the fit does not converge. Never NaN. `points` is 3 x N, one point per
// column (a std::span<const Eigen::Vector3d> maps to it with Eigen::Map<const Eigen::Matrix3Xd>).

// |p1 - p0| of exactly two points.
FitResult FitDistance(const Eigen::Ref<const Eigen::Matrix3Xd>& points, const FitOptions& options = {},
                      std::string_view where = "task");

// Two-face difference p1 - p0 (dx, dy, dz; second point minus first) of exactly two points: the
// same nominal point measured in the front face (first) and in the back face (second); the order
// is the caller's, the faces are not checked. Linear in the points, G = [-I, I]: differentiable
// everywhere, also when the two points coincide (where FitDistance refuses). The B89.4.19
// two-face error is |p1 - p0| (docs/tasks.md: why the vector is reported instead).
FitResult FitTwoFace(const Eigen::Ref<const Eigen::Matrix3Xd>& points, const FitOptions& options = {},
                     std::string_view where = "task");

// Total least squares plane (minimises the sum of squared orthogonal distances): through the
// centroid, normal = eigenvector of the smallest eigenvalue of the centred scatter matrix.
// flatness = max - min signed orthogonal residual; rms = sqrt(mean squared residual).
FitResult FitPlane(const Eigen::Ref<const Eigen::Matrix3Xd>& points, const FitOptions& options = {},
                   std::string_view where = "task");

// Least-squares sphere (minimises sum (|p_i - centre| - radius)^2; algebraic start, then
// Levenberg-Marquardt). rms = sqrt(mean squared radial residual).
FitResult FitSphere(const Eigen::Ref<const Eigen::Matrix3Xd>& points, const FitOptions& options = {},
                    std::string_view where = "task");

// 3-D circle in two steps: the total least squares plane (as FitPlane), then the least-squares
// circle of the points projected into that plane (minimises sum (|a_i - centre| - radius)^2 in
// the plane). normal = the plane's normal; rms = in-plane radial residual.
FitResult FitCircle(const Eigen::Ref<const Eigen::Matrix3Xd>& points, const FitOptions& options = {},
                    std::string_view where = "task");

// Total least squares line: through the centroid, direction = eigenvector of the largest
// eigenvalue of the centred scatter matrix. straightness = 2 x the largest perpendicular distance
// of a point from the fitted line (diameter of the cylinder about the least-squares line that
// holds every point); rms = sqrt(mean squared perpendicular distance).
FitResult FitLine(const Eigen::Ref<const Eigen::Matrix3Xd>& points, const FitOptions& options = {},
                  std::string_view where = "task");

// Geometric least-squares cylinder (>= 5 points): minimises sum (|p_i - axis| - radius)^2 over
// the axis and the radius (algebraic circle starts across each principal direction of the points,
// or along options.orientation when given, then Levenberg-Marquardt and Newton steps with the
// full Hessian). Outputs: the axis point nearest the centroid, the unit direction (sign as for a
// line), radius, cylindricity = max - min radial residual, rms [m, 1, m, m, m]. NumericalError
// when the points do not determine a cylinder (one cross-section, a line of points).
FitResult FitCylinder(const Eigen::Ref<const Eigen::Matrix3Xd>& points, const FitOptions& options = {},
                      std::string_view where = "task");

// Geometric least-squares cone (>= 6 points): minimises the sum of squared orthogonal distances
// e_i = (rho_i - R - t_i tan psi) cos psi (rho_i, t_i: radial and axial coordinates of point i
// about the axis point). Outputs: the axis point nearest the centroid, the unit direction (sign
// as for a line), the radius R there, the half-angle psi (positive when the radius grows along
// the direction) [rad], form = max - min residual, rms.
FitResult FitCone(const Eigen::Ref<const Eigen::Matrix3Xd>& points, const FitOptions& options = {},
                  std::string_view where = "task");

// Best fit of the measured points (3 x N, N >= 3, not collinear) to nominal.positions: the
// rotation R, translation t (and with nominal.scale the scale s) minimising
// sum |s R x_i + t - n_i|^2, in closed form (Kabsch / Umeyama: the SVD of the cross-covariance,
// det R = +1); with nominal.holds (kind rps) the reference point system minimising
// sum r_i^T W_i r_i, W_i = diag(held axes), by Gauss-Newton steps from that best fit. Outputs t
// [m], the fixed-axis angles rx, ry, rz of R = Rz(rz) Ry(ry) Rx(rx) [rad], rms [m] (best fit:
// sqrt(sum |r_i|^2 / N); rps: over the held components), s [1] (best_fit_scale). The Jacobian is
// exact: the implicit function theorem on the stationarity conditions with the full Hessian
// (residual terms included), rotations perturbed on the left (R = exp([w]x) R^).
FitResult FitBestFit(const Eigen::Ref<const Eigen::Matrix3Xd>& points, const FitOptions& options = {},
                     std::string_view where = "task");

// Deviation of point nominal.point in the part frame of the best fit of the first
// nominal.alignment_points points: d = s R x + t - n. Outputs: deviation = d . normal (along the
// nominal normal, positive on the side the normal points to), dx, dy, dz and, with
// nominal.position (kind position), position = 2 |d - (d . normal) normal| (the diameter of the
// ISO 1101 position zone about the nominal axis through n; for a hole, the normal is its axis) [m].
FitResult FitDeviation(const Eigen::Ref<const Eigen::Matrix3Xd>& points, const FitOptions& options = {},
                       std::string_view where = "task");

// The extreme deviations along their nominal normals of the points nominal.profile, in the part
// frame of the best fit (or RPS) of the first nominal.alignment_points points: min_deviation,
// max_deviation and profile = 2 max |deviation| (the width of the ISO 1101 surface-profile zone
// centred on nominal that holds every point) [m]. Like flatness, the extremes have one-sided
// derivatives (ties: the first point reaching the extreme); profile is not differentiable where
// every deviation is zero.
FitResult FitProfile(const Eigen::Ref<const Eigen::Matrix3Xd>& points, const FitOptions& options = {},
                     std::string_view where = "task");

// Form by the minimum-zone (Chebyshev) definition of ISO 1101 (kind flatness, straightness,
// roundness or cylindricity): the narrowest zone of two parallel planes (flatness, ISO 12781-1), a
// cylinder about a line (straightness of a line in space, ISO 12780-1: its diameter), two concentric
// circles in the plane of the least-squares circle (roundness, ISO 12181-1) or two coaxial cylinders
// (cylindricity, ISO 12180-1) that holds every point, and the same form referenced to the
// least-squares feature (>= the minimum zone). Sequential linear programming (Clp) from the
// least-squares feature to a stationary zone (docs/tasks.md "Form by minimum zone"). Neither output
// is differentiable (FitResult::differentiable false, zero Jacobian rows): their uncertainty is
// Monte Carlo's. Refuses as the least-squares fit of the feature does.
FitResult FitMinimumZone(TaskKind kind, const Eigen::Ref<const Eigen::Matrix3Xd>& points,
                         const FitOptions& options = {}, std::string_view where = "task");

// Dispatches on kind.
FitResult FitTask(TaskKind kind, const Eigen::Ref<const Eigen::Matrix3Xd>& points,
                  const FitOptions& options = {}, std::string_view where = "task");

}  // namespace vlt
