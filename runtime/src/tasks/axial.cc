// tasks/axial.cc — the geometric least-squares cylinder and cone with exact Jacobians w.r.t. the
// points (docs/tasks.md "Cylinder and cone").
//
// Both are one surface: points at axial position t and radial distance rho from an axis through
// x0 along the unit direction u, with radius R + t tan(psi) (psi = 0: the cylinder). The
// orthogonal distance of a point from it (ISO 10360-6 / Forbes, NPL DITC 140/89, "Least squares
// best fit geometric elements") is
//   e = (rho - R - t tan psi) cos psi = rho cos psi - t sin psi - R cos psi,
//   d = p - x0,  t = d . u,  rho = |d - t u|.
// The fit minimises F = 1/2 sum e_i^2 over theta = (alpha, beta, R[, psi]) about the current
// frame: axis point x0 + B alpha, direction (u + B beta)/sqrt(1 + |beta|^2), B = [b1 b2] an
// orthonormal basis perpendicular to u. After every step the frame moves to the new axis and its
// axis point to the foot of the centroid (R follows along the cone), so theta = 0 always.
//
// Derivatives: implicit function theorem on g(theta, points) = sum e_i de_i/dtheta = 0,
// dtheta/dp_j = -H^-1 (de_j/dtheta de_j/dp^T + e_j d2e_j/dtheta dp) with the FULL Hessian
// H = sum (de/dtheta de/dtheta^T + e d2e/dtheta2), so the Jacobian is exact for non-zero
// residuals (tests/test_axial_fits.cc: central differences of the whole fit).
#include "tasks/axial.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "tasks/fit_support.h"
#include "vlt/error.h"

namespace vlt::tasks_internal {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using Basis = Eigen::Matrix<double, 3, 2>;
using Points = Eigen::Ref<const Eigen::Matrix3Xd>;
// theta = (alpha_1, alpha_2, beta_1, beta_2, R, psi); a cylinder uses the first five.
using Theta = Eigen::Matrix<double, 6, 1>;
using ThetaMatrix = Eigen::Matrix<double, 6, 6>;

constexpr TaskOutput kCylinderOutputs[] = {
    {"point_x", "m", "x of the axis point nearest the centroid of the points"},
    {"point_y", "m", "y of that axis point"},
    {"point_z", "m", "z of that axis point"},
    {"direction_x", "1", "x of the unit axis direction (sign: see FitOptions::orientation)"},
    {"direction_y", "1", "y of the unit axis direction"},
    {"direction_z", "1", "z of the unit axis direction"},
    {"radius", "m", "radius of the least-squares cylinder"},
    {"cylindricity", "m",
     "max - min radial residual: radial separation of the two cylinders coaxial with the least-squares one "
     "that hold every point"},
    {"rms", "m", "root mean square radial residual |p - axis| - radius"},
};
constexpr TaskOutput kConeOutputs[] = {
    {"point_x", "m", "x of the axis point nearest the centroid of the points"},
    {"point_y", "m", "y of that axis point"},
    {"point_z", "m", "z of that axis point"},
    {"direction_x", "1", "x of the unit axis direction (sign: see FitOptions::orientation)"},
    {"direction_y", "1", "y of the unit axis direction"},
    {"direction_z", "1", "z of the unit axis direction"},
    {"radius", "m", "radius of the cone at the axis point (point_x, point_y, point_z)"},
    {"half_angle", "rad", "apex half-angle psi; positive when the radius grows along the direction"},
    {"form", "m",
     "max - min orthogonal residual: width of the zone between the two cones offset from the least-squares "
     "one that holds every point"},
    {"rms", "m", "root mean square orthogonal residual"},
};

// A residual statistic smaller than this fraction of the radius is "zero": exact fit.
constexpr double kExactFit = 1e-10;
// The points must determine the surface: the full Hessian's smallest eigenvalue at least this
// fraction of its largest, in normalised coordinates (a strict minimum).
constexpr double kDetermined = 1e-10;
// One cross-section does not determine an axis. Points whose rms distance from their own best
// plane is below this fraction of their rms distance from the centroid lie in one plane to
// rounding ...
constexpr double kFlat = 1e-9;
// ... and a measured one does so to within its noise: when, in that plane, the points lie on a
// section (SeenInTheirPlane: its rms residual at most kSectionCircle of its radius) and their
// distance from the plane is not more than kSectionNoise times that residual, the axis's tilt
// would be fitted to the noise (its uncertainty ~ noise / axial spread ~ 0.1 rad or worse, where a
// first-order GUM means nothing; noisy rings of 20-50 mm bores were fitted with axes tilted by
// 0.03-1.6 rad). A 10 mm band of a 200 mm bore measured with 25 um noise has 2.9 mm against
// 25 um; a cone band's radius changing along it is part of its section.
constexpr double kSectionNoise = 10.0;
constexpr double kSectionCircle = 0.01;
// A candidate whose radius passes this many times the points' extent, or whose half-angle passes
// 85 degrees, has run off to a plane: not a cylinder or cone of these points.
constexpr double kRunaway = 1e6;
constexpr double kSteepest = 1.4835;  // 85 degrees

Basis Perpendicular(const Vector3d& u) {
  const Vector3d a = u.unitOrthogonal();
  Basis b;
  b << a, u.cross(a);
  return b;
}

// The surface about which theta = 0: axis point, direction, its perpendicular basis, radius at
// the axis point, half-angle (0 for a cylinder).
struct Frame {
  Vector3d x0 = Vector3d::Zero();
  Vector3d u = Vector3d::UnitZ();
  Basis b = Perpendicular(Vector3d::UnitZ());
  double radius = 0.0;
  double half_angle = 0.0;
  double cos_psi = 1.0, sin_psi = 0.0;  // of half_angle, computed once per frame (SetHalfAngle)

  void SetHalfAngle(double psi) {
    half_angle = psi;
    cos_psi = std::cos(psi);
    sin_psi = std::sin(psi);
  }

  // Slide the axis point to the foot of `centroid` on the axis; the radius follows the cone.
  void Recentre(const Vector3d& centroid) {
    const double s = u.dot(centroid - x0);
    x0 += s * u;
    radius += s * sin_psi / cos_psi;
  }
};

// e of one point and its first derivatives at theta = 0.
struct AxialResidual {
  double e = 0.0;
  double rho = 0.0;  // radial distance from the axis
  double t = 0.0;    // axial position from x0
  Vector3d n;        // unit radial direction (d - t u)/rho
  Vector3d d;        // p - x0
  Theta d_theta;     // de/dtheta
  Vector3d d_point;  // de/dp
};

AxialResidual Residual(const Frame& f, const Vector3d& p) {
  AxialResidual r;
  r.d = p - f.x0;
  r.t = r.d.dot(f.u);
  const Vector3d w = r.d - r.t * f.u;
  r.rho = w.norm();
  r.n = r.rho > 0.0 ? Vector3d(w / r.rho) : Vector3d::Zero();
  const double c = f.cos_psi, s = f.sin_psi;
  r.e = c * r.rho - s * r.t - c * f.radius;
  const Eigen::Vector2d bn = f.b.transpose() * r.n;
  r.d_theta.head<2>() = -c * bn;                          // de/dd = c n - s u, dd/dalpha = -B
  r.d_theta.segment<2>(2) = -(c * r.t + s * r.rho) * bn;  // de/du = -c t d/rho - s d, du/dbeta = B
  r.d_theta(4) = -c;                                      // de/dR
  r.d_theta(5) = -(r.rho - f.radius) * s - r.t * c;       // de/dpsi
  r.d_point = c * r.n - s * f.u;
  return r;
}

// Second derivatives of e at theta = 0: d2e/dtheta2 (6 x 6) and d2e/dtheta dp (6 x 3). With
// H_dd, H_du, H_uu the second derivatives of rho = sqrt(|d|^2 - (d.u)^2) in (d, u):
//   H_dd = (I - u u^T - n n^T)/rho,  H_du = -(t I + u d^T - (t/rho) n d^T)/rho,
//   H_uu = -(1 + t^2/rho^2) d d^T/rho,
// e_dd = c H_dd, e_du = c H_du - s I, e_uu = c H_uu; the direction's second-order term
// d2u/dbeta_k dbeta_l = -delta_kl u adds -(de/du . u) I to the (beta, beta) block.
struct AxialCurvature {
  ThetaMatrix theta_theta;
  Eigen::Matrix<double, 6, 3> theta_point;
};

AxialCurvature Curvature(const Frame& f, const AxialResidual& r) {
  const double c = f.cos_psi, s = f.sin_psi;
  const Vector3d& u = f.u;
  const Basis& b = f.b;
  const double rho = r.rho, t = r.t;
  const Matrix3d h_dd = (Matrix3d::Identity() - u * u.transpose() - r.n * r.n.transpose()) / rho;
  const Matrix3d h_du =
      -(t * Matrix3d::Identity() + u * r.d.transpose() - (t / rho) * r.n * r.d.transpose()) / rho;
  const Matrix3d h_uu = -(1.0 + t * t / (rho * rho)) * r.d * r.d.transpose() / rho;
  const Matrix3d e_dd = c * h_dd;
  const Matrix3d e_du = c * h_du - s * Matrix3d::Identity();
  const Matrix3d e_uu = c * h_uu;
  const double e_u_dot_u = -c * t * t / rho - s * t;
  const Eigen::Vector2d bn = b.transpose() * r.n;

  AxialCurvature k;
  k.theta_theta.setZero();
  k.theta_theta.block<2, 2>(0, 0) = b.transpose() * e_dd * b;
  k.theta_theta.block<2, 2>(0, 2) = -b.transpose() * e_du * b;
  k.theta_theta.block<2, 2>(2, 2) = b.transpose() * e_uu * b - e_u_dot_u * Eigen::Matrix2d::Identity();
  k.theta_theta.block<2, 1>(0, 5) = s * bn;                  // d/dalpha of de/dpsi
  k.theta_theta.block<2, 1>(2, 5) = (s * t - c * rho) * bn;  // d/dbeta of de/dpsi
  k.theta_theta(4, 5) = s;
  k.theta_theta(5, 5) = -(rho - f.radius) * c + t * s;
  k.theta_theta.block<2, 2>(2, 0) = k.theta_theta.block<2, 2>(0, 2).transpose();
  k.theta_theta.block<1, 5>(5, 0) = k.theta_theta.block<5, 1>(0, 5).transpose();

  k.theta_point.topRows<2>() = -b.transpose() * e_dd;
  k.theta_point.middleRows<2>(2) = b.transpose() * e_du.transpose();
  k.theta_point.row(4).setZero();
  k.theta_point.row(5) = (-s * r.n - c * u).transpose();
  return k;
}

// A least-squares cylinder (P = 5) or cone (P = 6) under way.
template <int P>
class AxialSolver {
 public:
  using Vec = Eigen::Matrix<double, P, 1>;
  using Mat = Eigen::Matrix<double, P, P>;

  // `points` are normalised (Normalise below): centroid at the origin, rms distance 1, so that
  // every tolerance is relative.
  AxialSolver(const Points& points, TaskKind kind, std::string_view where)
      : points_(points), kind_(kind), where_(where) {}

  // The best of the fits started from each candidate direction. Each start first gets a few
  // Levenberg-Marquardt iterations (a wrong axis has large residuals and converges only
  // linearly, ~0.85 per iteration); the one with the lowest sum of squares then runs to
  // convergence.
  Frame Solve(const std::vector<Vector3d>& directions) {
    constexpr int kRace = 20, kToConvergence = 200;
    std::optional<Frame> best;
    double best_cost = std::numeric_limits<double>::infinity();
    for (const Vector3d& direction : directions) {
      std::optional<Frame> frame = AlgebraicStart(direction);
      if (!frame || LevenbergMarquardt(*frame, kRace) == Progress::kFailed) continue;
      const double cost = Cost(*frame);
      if (cost < best_cost) best = *frame, best_cost = cost;
    }
    if (!best || LevenbergMarquardt(*best, kToConvergence) != Progress::kConverged) {
      Fail(where_, kind_,
           "least-squares fit did not converge from any start direction (one cross-section or points "
           "along a line do not determine a " +
               std::string(TaskKindName(kind_)) + ")");
    }
    CheckDetermined(NewtonSteps(*best));
    if (RunAway(*best)) {
      Fail(
          where_, kind_,
          "the fit runs off to a plane (a radius beyond 1e6 times the points' size or a half-angle beyond 85 "
          "degrees): not a " +
              std::string(TaskKindName(kind_)) + " of these points");
    }
    return *best;
  }

 private:
  Vector3d q(long i) const { return points_.col(i); }
  long n() const { return points_.cols(); }

  // The circle (cylinder) or the circle whose radius changes linearly along the axis (cone) of
  // the points seen along `direction`, as a linear least-squares problem in the plane
  // perpendicular to it: with a the in-plane and t the axial coordinate, |a - c| = R + k t gives
  //   |a|^2 = 2 c . a + K0 + K1 t + K2 t^2,  K0 = R^2 - |c|^2, K1 = 2 R k  (K2 = k^2 unused).
  std::optional<Frame> AlgebraicStart(const Vector3d& direction) const {
    constexpr int kUnknowns = P == 5 ? 3 : 5;
    using Row = Eigen::Matrix<double, kUnknowns, 1>;
    using Normal = Eigen::Matrix<double, kUnknowns, kUnknowns>;
    Frame f;
    f.u = direction.normalized();
    f.b = Perpendicular(f.u);
    Normal ata = Normal::Zero();
    Row atb = Row::Zero();
    for (long i = 0; i < n(); ++i) {
      const Eigen::Vector2d a = f.b.transpose() * q(i);
      const double t = f.u.dot(q(i));
      Row row;
      row.template head<2>() = 2.0 * a;
      row(2) = 1.0;
      if constexpr (P == 6) row(3) = t, row(4) = t * t;
      ata.noalias() += row * row.transpose();
      atb += row * a.squaredNorm();
    }
    const Eigen::SelfAdjointEigenSolver<Normal> conditioning(ata, Eigen::EigenvaluesOnly);
    if (!(conditioning.eigenvalues()(0) > 1e-12 * conditioning.eigenvalues()(kUnknowns - 1))) return {};
    const Row x = ata.ldlt().solve(atb);
    const Eigen::Vector2d centre = x.template head<2>();
    const double r2 = x(2) + centre.squaredNorm();
    if (!(r2 > 0.0)) return {};
    f.radius = std::sqrt(r2);
    if constexpr (P == 6) f.SetHalfAngle(std::atan(x(3) / (2.0 * f.radius)));
    f.x0 = f.b * centre;
    return f;
  }

  double Cost(const Frame& f) const {
    double sum = 0.0;
    for (long i = 0; i < n(); ++i) sum += Eigen::numext::abs2(Residual(f, q(i)).e);
    return sum;
  }

  // theta applied to the frame, which then moves to the new axis (theta = 0 again).
  static Frame Moved(const Frame& f, const Vec& step) {
    Frame moved = f;
    moved.x0 += f.b * step.template head<2>();
    moved.u = (f.u + f.b * step.template segment<2>(2)).normalized();
    moved.b = Perpendicular(moved.u);
    moved.radius += step(4);
    if constexpr (P == 6) moved.SetHalfAngle(f.half_angle + step(5));
    moved.Recentre(Vector3d::Zero());
    return moved;
  }

  bool RunAway(const Frame& f) const {
    return !f.x0.allFinite() || !f.u.allFinite() || !(std::abs(f.radius) < kRunaway) ||
           !(std::abs(f.half_angle) < kSteepest);
  }

  enum class Progress { kConverged, kUnfinished, kFailed };

  // Levenberg-Marquardt on e_i (Gauss-Newton steps, damped when they fail), at most
  // `max_iterations`; kFailed when the candidate runs off (to a plane).
  Progress LevenbergMarquardt(Frame& f, int max_iterations) {
    double current = Cost(f), damping = 1e-6;
    for (int iteration = 0; iteration < max_iterations; ++iteration, ++iterations_) {
      Mat jtj = Mat::Zero();
      Vec jte = Vec::Zero();
      for (long i = 0; i < n(); ++i) {
        const AxialResidual r = Residual(f, q(i));
        const Vec row = r.d_theta.template head<P>();
        jtj.noalias() += row * row.transpose();
        jte += row * r.e;
      }
      bool accepted = false;
      Vec step = Vec::Zero();
      while (damping < 1e12) {
        Mat damped = jtj;
        damped.diagonal() *= 1.0 + damping;
        step = -damped.ldlt().solve(jte);
        const Frame trial = Moved(f, step);
        const double cost = Cost(trial);
        if (!RunAway(trial) && std::isfinite(cost) && cost <= current) {
          f = trial, current = cost, accepted = true;
          damping = std::max(damping * 0.1, 1e-12);
          break;
        }
        damping *= 10.0;
      }
      // Stop where Newton's steps converge quadratically (1e-9 relative: the cost itself cannot
      // resolve steps much below sqrt(eps)), or when no step lowers the cost.
      if (!accepted || step.norm() <= 1e-9 * (1.0 + std::abs(f.radius))) {
        return RunAway(f) ? Progress::kFailed : Progress::kConverged;
      }
    }
    return RunAway(f) ? Progress::kFailed : Progress::kUnfinished;
  }

  // The gradient g = sum e de/dtheta, the full Hessian and the rounding level of g's components.
  struct Stationarity {
    Vec g = Vec::Zero();
    Mat h = Mat::Zero();
    Vec rounding = Vec::Zero();
  };

  Stationarity Evaluate(const Frame& f) const {
    constexpr double kEps = std::numeric_limits<double>::epsilon();
    Stationarity s;
    Vec terms = Vec::Zero(), residuals = Vec::Zero();
    for (long i = 0; i < n(); ++i) {
      const AxialResidual r = Residual(f, q(i));
      if (!(r.rho > 1e-12 * std::abs(f.radius))) Fail(where_, kind_, "a point lies on the fitted axis");
      const Vec de = r.d_theta.template head<P>();
      const AxialCurvature k = Curvature(f, r);
      s.g += r.e * de;
      s.h.noalias() += de * de.transpose() + r.e * k.theta_theta.template topLeftCorner<P, P>();
      // Each e carries rounding ~eps (rho + |t| + R); the sum adds ~sqrt(N) eps sum |e de|.
      terms += (r.rho + std::abs(r.t) + std::abs(f.radius)) * de.cwiseAbs();
      residuals += std::abs(r.e) * de.cwiseAbs();
    }
    s.rounding = 16.0 * kEps * (terms + std::sqrt(static_cast<double>(n())) * residuals);
    return s;
  }

  // Newton steps on g = 0 with the full Hessian, which converge quadratically from where LM
  // stopped. As for the sphere (fits.cc), they stop on the gradient, not on the step: once every
  // component of g is at its rounding level the step computed there is still applied and the
  // loop ends, so the estimate is the stationary point to rounding whatever path LM took, and
  // the fitted values are a smooth function of the points, as the Jacobian assumes.
  // Returns the Hessian of the last step (at rounding level of the estimate) for CheckDetermined.
  Mat NewtonSteps(Frame& f) {
    constexpr int kMaxNewton = 12;
    for (int newton = 0; newton < kMaxNewton; ++newton) {
      ++iterations_;
      const Stationarity s = Evaluate(f);
      const bool at_rounding = (s.g.cwiseAbs().array() <= s.rounding.array()).all();
      const Eigen::LDLT<Mat> ldlt(s.h);
      const Vec step = -ldlt.solve(s.g);
      if (ldlt.info() != Eigen::Success || !step.allFinite()) break;
      f = Moved(f, step);
      if (at_rounding) return s.h;
    }
    Fail(where_, kind_,
         "least-squares fit did not converge (gradient not at rounding level after " +
             std::to_string(kMaxNewton) + " Newton steps)");
  }

  // A strict minimum that the points determine: the normalised Hessian is well conditioned.
  void CheckDetermined(const Mat& hessian) const {
    const Eigen::SelfAdjointEigenSolver<Mat> curvature(hessian, Eigen::EigenvaluesOnly);
    if (!(curvature.eigenvalues()(0) > kDetermined * curvature.eigenvalues()(P - 1))) {
      Fail(where_, kind_,
           "the points do not determine the surface (one cross-section, points along a line, or too "
           "short an arc)");
    }
  }

 public:
  int iterations_ = 0;

 private:
  const Points& points_;
  const TaskKind kind_;
  const std::string_view where_;
};

// Candidate axis directions: the orientation given (a Monte Carlo trial starts from the fit to
// the estimates), else the three principal directions of the points (a long cylinder lies along
// the largest, a short bore across the smallest; a cone's axis is one of them by symmetry).
// Of the points' scatter, relative to their largest coordinate difference (no overflow at 1e200 m,
// no underflow at 1e-200 m); all-zero variances when the points coincide.
Eigen::SelfAdjointEigenSolver<Matrix3d> PrincipalDirections(const Points& points) {
  const Vector3d mean = points.rowwise().mean();
  const double largest = (points.colwise() - mean).cwiseAbs().maxCoeff();
  Matrix3d scatter = Matrix3d::Zero();
  if (largest > 0.0 && std::isfinite(largest)) {
    for (long i = 0; i < points.cols(); ++i) {
      const Vector3d d = (points.col(i) - mean) / largest;
      scatter.noalias() += d * d.transpose();
    }
  }
  return Eigen::SelfAdjointEigenSolver<Matrix3d>(scatter);
}

// When two principal variances are within a factor of 10 the principal directions say little
// about the axis (a cylinder about 1.2 diameters long has equal variances along and across it: its
// principal directions are any), so ten more directions join, the diagonals of the principal frame
// (its cube's six face diagonals and four body diagonals): no axis is then farther than 28 degrees
// from a start.
std::vector<Vector3d> StartDirections(const Points& points, const FitOptions& options) {
  if (options.orientation.squaredNorm() > 0.0) return {options.orientation.normalized()};
  const Eigen::SelfAdjointEigenSolver<Matrix3d> principal = PrincipalDirections(points);
  const Matrix3d& v = principal.eigenvectors();
  std::vector<Vector3d> directions = {v.col(2), v.col(0), v.col(1)};
  const Vector3d variance = principal.eigenvalues().cwiseMax(0.0);
  const bool separated = variance(1) > 10.0 * variance(0) ? variance(2) > 10.0 * variance(1) : false;
  if (!separated) {
    for (int a = 0; a < 3; ++a) {
      directions.push_back((v.col(a) + v.col((a + 1) % 3)).normalized());
      directions.push_back((v.col(a) - v.col((a + 1) % 3)).normalized());
    }
    for (const double sy : {1.0, -1.0})
      for (const double sz : {1.0, -1.0})
        directions.push_back((v.col(0) + sy * v.col(1) + sz * v.col(2)).normalized());
  }
  return directions;
}

// How normalised points sit in their own best plane (its normal: their smallest principal
// direction): their rms distance from it, and the rms residual of the section that fits them
// there — a circle whose radius may change linearly with the distance from the plane (so that a
// cone band is a section too), the cone's algebraic start with the plane's normal as its axis.
// A long cylinder or a cone seen side-on is no section: its rms residual exceeds kSectionCircle
// of the radius.
struct PlaneOfThePoints {
  double thickness = 0.0;
  bool on_a_section = false;
  double section_rms = 0.0;
};

PlaneOfThePoints SeenInTheirPlane(const Eigen::Matrix3Xd& q) {
  using Row = Eigen::Matrix<double, 5, 1>;
  using Normal = Eigen::Matrix<double, 5, 5>;
  const double n = static_cast<double>(q.cols());
  const Eigen::SelfAdjointEigenSolver<Matrix3d> principal(q * q.transpose() / n);
  PlaneOfThePoints seen;
  // From the distances themselves, not from the eigenvalue: a 3 x 3 eigenvalue carries an absolute
  // rounding of ~eps times the largest, whose root (1e-8) would hide an exact ring's thickness.
  const Vector3d normal = principal.eigenvectors().col(0);
  seen.thickness = std::sqrt((normal.transpose() * q).squaredNorm() / n);
  Basis plane;
  plane << principal.eigenvectors().col(1), principal.eigenvectors().col(2);
  // |a - c| = R + k t: |a|^2 = 2 c . a + K0 + K1 t + K2 t^2 (AxialSolver::AlgebraicStart), solved
  // rank-revealing: with two rings t^2 is a constant, one column too many. Its residual, divided
  // by twice the point's radius |a - c|, is to first order the geometric one, whichever of the
  // equivalent coefficient sets the solve picks: exactly zero for exact points.
  Normal ata = Normal::Zero();
  Row atb = Row::Zero();
  for (long i = 0; i < q.cols(); ++i) {
    const Eigen::Vector2d a = plane.transpose() * q.col(i);
    const double t = normal.dot(q.col(i));
    Row row;
    row << 2.0 * a.x(), 2.0 * a.y(), 1.0, t, t * t;
    ata.noalias() += row * row.transpose();
    atb += row * a.squaredNorm();
  }
  const Row x = Eigen::CompleteOrthogonalDecomposition<Normal>(ata).solve(atb);
  if (!x.allFinite()) return seen;
  double sum = 0.0, radii = 0.0;
  for (long i = 0; i < q.cols(); ++i) {
    const Eigen::Vector2d a = plane.transpose() * q.col(i);
    const double t = normal.dot(q.col(i));
    Row row;
    row << 2.0 * a.x(), 2.0 * a.y(), 1.0, t, t * t;
    const double radius = (a - x.head<2>()).norm();
    radii += radius;
    if (radius > 0.0) sum += Eigen::numext::abs2((a.squaredNorm() - row.dot(x)) / (2.0 * radius));
  }
  const double radius = radii / n;
  seen.section_rms = std::sqrt(sum / n);
  seen.on_a_section =
      std::isfinite(seen.section_rms) && radius > 0.0 && seen.section_rms <= kSectionCircle * radius;
  return seen;
}

[[noreturn]] void FailOneSection(TaskKind kind, std::string_view where, const std::string& why) {
  Fail(where, kind,
       "the points lie in one plane (one cross-section" + why +
           "): they do not determine the axis; a circle task fits one section");
}

// The fit, its direction signed by FitOptions::orientation (a cone's half-angle changes sign with
// it: e is unchanged by (u, psi) -> (-u, -psi)).
template <int P>
struct AxialFit {
  Frame frame;
  int iterations = 0;
};

template <int P>
AxialFit<P> FitAxial(const Points& points, TaskKind kind, const FitOptions& options, std::string_view where) {
  AxialFit<P> fit;
  AxialSolver<P> solver(points, kind, where);
  try {
    fit.frame = solver.Solve(StartDirections(points, options));
  } catch (const NumericalError&) {
    // A trial whose start direction fails is retried from the principal directions.
    if (options.orientation.squaredNorm() == 0.0) throw;
    FitOptions unoriented = options;
    unoriented.orientation = Vector3d::Zero();
    fit.frame = solver.Solve(StartDirections(points, unoriented));
  }
  fit.iterations = solver.iterations_;
  Frame& f = fit.frame;
  if (OrientationSign(f.u, options) < 0.0) {
    f.u = -f.u;
    f.SetHalfAngle(-f.half_angle);
  }
  f.b = Perpendicular(f.u);
  f.Recentre(points.rowwise().mean());
  return fit;
}

// Outputs and Jacobian of a fitted surface. Outputs: axis point x0 (the foot of the centroid
// c), u, radius at x0, [psi], form, rms. At theta = 0 with c - x0 = v perpendicular to u:
//   d x0 = B dalpha + u (B^T v)^T dbeta + u u^T dc,   d u = B dbeta,
//   d R_out = dR + tan(psi) ((B^T v)^T dbeta + u^T dc),   dc/dp_j = I/N,
// dtheta/dp_j = -H^-1 (de_j/dtheta de_j/dp^T + e_j d2e_j/dtheta dp); form = e_max - e_min and
// rms by the envelope theorem (d sum e^2/dp_j is the partial derivative at the optimum).
template <int P>
FitResult AxialResult(TaskKind kind, const Points& points, const AxialFit<P>& fit,
                      const FitOptions& options) {
  using Mat = Eigen::Matrix<double, P, P>;
  const Frame& f = fit.frame;
  const long n = points.cols();
  const double nd = static_cast<double>(n);
  std::vector<AxialResidual> residuals;
  residuals.reserve(static_cast<std::size_t>(n));
  long i_max = 0, i_min = 0;
  double sum_sq = 0.0;
  Mat h = Mat::Zero();
  for (long i = 0; i < n; ++i) {
    residuals.push_back(Residual(f, points.col(i)));
    const AxialResidual& r = residuals.back();
    if (r.e > residuals[static_cast<std::size_t>(i_max)].e) i_max = i;
    if (r.e < residuals[static_cast<std::size_t>(i_min)].e) i_min = i;
    sum_sq += r.e * r.e;
    if (options.jacobian) {
      const auto de = r.d_theta.template head<P>();
      h.noalias() += de * de.transpose() + r.e * Curvature(f, r).theta_theta.template topLeftCorner<P, P>();
    }
  }
  const double rms = std::sqrt(sum_sq / nd);
  const double form =
      residuals[static_cast<std::size_t>(i_max)].e - residuals[static_cast<std::size_t>(i_min)].e;

  FitResult result = MakeResult(kind, n, options);
  result.iterations = fit.iterations;
  const int form_row = P == 5 ? 7 : 8, rms_row = form_row + 1;
  result.values.head<3>() = f.x0;
  result.values.segment<3>(3) = f.u;
  result.values(6) = f.radius;
  if constexpr (P == 6) result.values(7) = f.half_angle;
  result.values(form_row) = form;
  result.values(rms_row) = rms;
  const bool exact = rms <= kExactFit * std::abs(f.radius);
  result.differentiable[static_cast<std::size_t>(form_row)] = !exact;
  result.differentiable[static_cast<std::size_t>(rms_row)] = !exact;
  if (!options.jacobian) return result;

  const Eigen::LDLT<Mat> hessian(h);
  const Vector3d v = points.rowwise().mean() - f.x0;
  const Eigen::RowVector2d bv = (f.b.transpose() * v).transpose();
  const double tan_psi = std::tan(f.half_angle);
  const auto& d_max = residuals[static_cast<std::size_t>(i_max)].d_theta;
  const auto& d_min = residuals[static_cast<std::size_t>(i_min)].d_theta;
  const Eigen::Matrix<double, 1, P> d_form = (d_max - d_min).template head<P>().transpose();
  for (long j = 0; j < n; ++j) {
    const AxialResidual& r = residuals[static_cast<std::size_t>(j)];
    const Eigen::Matrix<double, P, 3> m = r.d_theta.template head<P>() * r.d_point.transpose() +
                                          r.e * Curvature(f, r).theta_point.template topRows<P>();
    const Eigen::Matrix<double, P, 3> dtheta = -hessian.solve(m);
    auto block = result.jacobian.middleCols<3>(3 * j);
    block.topRows<3>() = f.b * dtheta.template topRows<2>() + f.u * (bv * dtheta.template middleRows<2>(2)) +
                         f.u * f.u.transpose() / nd;
    block.middleRows<3>(3) = f.b * dtheta.template middleRows<2>(2);
    block.row(6) = dtheta.row(4) + tan_psi * (bv * dtheta.template middleRows<2>(2) + f.u.transpose() / nd);
    if constexpr (P == 6) block.row(7) = dtheta.row(5);
    if (exact) continue;
    Eigen::RowVector3d d_form_j = d_form * dtheta;
    if (j == i_max) d_form_j += r.d_point.transpose();
    if (j == i_min) d_form_j -= r.d_point.transpose();
    block.row(form_row) = d_form_j;
    block.row(rms_row) = r.e * r.d_point.transpose() / (nd * rms);
  }
  return result;
}

// The fit runs on q = (p - m)/s, m the centroid and s the rms distance from it (computed relative
// to the largest coordinate difference: no overflow at 1e200 m, no underflow at 1e-200 m), so
// that every tolerance is relative and no square overflows. m and s are constants of the
// evaluation: the fit is equivariant under p -> m + s q, so the outputs map back exactly and the
// Jacobian's rows of lengths are unchanged (d(s x)/dp = dx/dq) while those of unit vectors and
// angles are divided by s.
struct Normalisation {
  Vector3d mean;
  double scale = 0.0;
  Eigen::Matrix3Xd q;
};

Normalisation Normalise(const Points& points, TaskKind kind, std::string_view where) {
  Normalisation norm;
  norm.mean = (points / static_cast<double>(points.cols())).rowwise().sum();  // no overflow at 1e308
  const double largest = (points.colwise() - norm.mean).cwiseAbs().maxCoeff();
  // Below 1e-290 m the Jacobian's 1/scale would overflow: coincident to machine precision.
  if (!(largest > 1e-290) || !std::isfinite(largest)) Fail(where, kind, "all points coincide");
  double sum = 0.0;
  for (long i = 0; i < points.cols(); ++i) sum += ((points.col(i) - norm.mean) / largest).squaredNorm();
  norm.scale = largest * std::sqrt(sum / static_cast<double>(points.cols()));
  norm.q = (points.colwise() - norm.mean) / norm.scale;
  return norm;
}

void InCallerCoordinates(const Normalisation& norm, FitResult& result) {
  result.values.head<3>() = norm.mean + norm.scale * result.values.head<3>();
  for (std::size_t k = 6; k < result.outputs.size(); ++k) {
    const bool length = result.outputs[k].unit == "m";
    const Eigen::Index row = static_cast<Eigen::Index>(k);
    if (length) result.values(row) *= norm.scale;
    if (!length && result.jacobian.size() > 0) result.jacobian.row(row) /= norm.scale;
  }
  if (result.jacobian.size() > 0) result.jacobian.middleRows<3>(3) /= norm.scale;
}

}  // namespace

std::span<const TaskOutput> AxialOutputs(TaskKind kind) {
  if (kind == TaskKind::kCylinder) return kCylinderOutputs;
  if (kind == TaskKind::kCone) return kConeOutputs;
  return {};
}

FitResult FitAxialSurface(TaskKind kind, const Points& points, const FitOptions& options,
                          std::string_view where) {
  CheckPoints(points, kind, kind == TaskKind::kCylinder ? 5 : 6, false, where);
  const Normalisation norm = Normalise(points, kind, where);
  // One cross-section, exact or measured (its spread out of its plane at the noise level of the
  // section). Judged on the point set of the estimates (no orientation given); a Monte Carlo
  // trial, which starts from that fit's axis, is not judged again, so that no trial of an
  // accepted set fails at random.
  const PlaneOfThePoints seen = SeenInTheirPlane(norm.q);
  if (!(seen.thickness > kFlat)) FailOneSection(kind, where, "");
  if (options.orientation.squaredNorm() == 0.0 && seen.on_a_section &&
      !(seen.thickness > kSectionNoise * seen.section_rms)) {
    char why[160];
    std::snprintf(why, sizeof why,
                  ", measured: %.3g µm out of their plane against a scatter of %.3g µm about it",
                  seen.thickness * norm.scale * 1e6, seen.section_rms * norm.scale * 1e6);
    FailOneSection(kind, where, why);
  }
  FitResult result = kind == TaskKind::kCylinder
                         ? AxialResult<5>(kind, norm.q, FitAxial<5>(norm.q, kind, options, where), options)
                         : AxialResult<6>(kind, norm.q, FitAxial<6>(norm.q, kind, options, where), options);
  InCallerCoordinates(norm, result);
  return result;
}

}  // namespace vlt::tasks_internal
