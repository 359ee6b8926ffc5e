// tasks/fits.cc — distance, two-face difference and least-squares features with exact
// Jacobians w.r.t. the points.
//
// Derivatives (docs/tasks.md, "Jacobians"):
//  - Centroid-based fits (plane, line, and the plane of a circle): the centred scatter matrix
//    S = sum d_i d_i^T (d_i = p_i - centroid) has eigenpairs (lambda_k, v_k). First-order
//    perturbation of a simple eigenvector: dv_a = sum_{k != a} v_k v_k^T dS v_a / (lambda_a -
//    lambda_k); because sum d_i = 0 the centroid drops out of dS and moving point j gives
//    dS v_a = (v_a . d_j) dp_j + d_j (v_a . dp_j).
//  - Geometric sphere / circle: implicit function theorem on the stationarity condition
//    g(theta, points) = sum e_i de_i/dtheta = 0 of F = 1/2 sum e_i^2, e_i = |a_i - c| - R:
//    dtheta/da_j = -H^-1 dg/da_j with the FULL Hessian H (not the Gauss-Newton approximation),
//    so the derivatives are exact for non-zero residuals too.
//  - rms values use the envelope theorem: at the optimum d(sum e^2)/dp_j is the partial
//    derivative only.
#include "vlt/fits.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>

#include <Eigen/Dense>

#include "parallel/pool.h"
#include "tasks/alignment.h"
#include "tasks/axial.h"
#include "tasks/fit_support.h"
#include "tasks/minimum_zone.h"
#include "tasks/weighted.h"
#include "vlt/error.h"

namespace vlt {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using Points = Eigen::Ref<const Eigen::Matrix3Xd>;

constexpr TaskOutput kDistanceOutputs[] = {
    {"distance", "m", "distance |p2 - p1| between the two points"},
};
constexpr TaskOutput kTwoFaceOutputs[] = {
    {"dx", "m", "x of p2 - p1: back-face point (second) minus front-face point (first)"},
    {"dy", "m", "y of p2 - p1"},
    {"dz", "m", "z of p2 - p1"},
};
constexpr TaskOutput kPlaneOutputs[] = {
    {"centroid_x", "m", "x of the centroid of the points (a point of the least-squares plane)"},
    {"centroid_y", "m", "y of the centroid of the points"},
    {"centroid_z", "m", "z of the centroid of the points"},
    {"normal_x", "1", "x of the unit normal (sign: see FitOptions::orientation)"},
    {"normal_y", "1", "y of the unit normal"},
    {"normal_z", "1", "z of the unit normal"},
    {"flatness", "m", "max - min signed orthogonal distance of the points from the plane"},
    {"rms", "m", "root mean square orthogonal distance of the points from the plane"},
};
constexpr TaskOutput kSphereOutputs[] = {
    {"centre_x", "m", "x of the centre of the least-squares sphere"},
    {"centre_y", "m", "y of the centre"},
    {"centre_z", "m", "z of the centre"},
    {"radius", "m", "radius of the least-squares sphere"},
    {"rms", "m", "root mean square radial residual |p - centre| - radius"},
};
constexpr TaskOutput kCircleOutputs[] = {
    {"centre_x", "m", "x of the centre of the least-squares circle (in the least-squares plane)"},
    {"centre_y", "m", "y of the centre"},
    {"centre_z", "m", "z of the centre"},
    {"radius", "m", "radius of the least-squares circle of the points projected on the plane"},
    {"normal_x", "1", "x of the unit normal of the circle's plane (sign: FitOptions::orientation)"},
    {"normal_y", "1", "y of the unit normal"},
    {"normal_z", "1", "z of the unit normal"},
    {"rms", "m", "root mean square in-plane radial residual"},
};
constexpr TaskOutput kLineOutputs[] = {
    {"point_x", "m", "x of the centroid of the points (a point of the least-squares line)"},
    {"point_y", "m", "y of the centroid"},
    {"point_z", "m", "z of the centroid"},
    {"direction_x", "1", "x of the unit direction (sign: see FitOptions::orientation)"},
    {"direction_y", "1", "y of the unit direction"},
    {"direction_z", "1", "z of the unit direction"},
    {"straightness", "m", "2 x the largest perpendicular distance of a point from the line"},
    {"rms", "m", "root mean square perpendicular distance of the points from the line"},
};

// Relative thresholds. A width ratio below 1e-9 (eigenvalue ratio 1e-18) means the points span
// one dimension less than the feature needs: no measurement is that flat/straight relative to
// its extent, so it is a degenerate point set, not a good one. A relative eigenvalue gap below
// 1e-12 makes the fitted direction undefined to worse than 1e-4 rad for 1e-16 rounding.
constexpr double kRankRatio = 1e-18;
constexpr double kGapRatio = 1e-12;
// A residual statistic smaller than this fraction of the extent is "zero": exact fit.
constexpr double kExactFit = 1e-10;

}  // namespace

namespace tasks_internal {

[[noreturn]] void Fail(std::string_view where, TaskKind kind, const std::string& reason) {
  std::string message(where);
  message.append(": ").append(TaskKindName(kind)).append(": ").append(reason);
  throw NumericalError(message);
}

void CheckPoints(const Points& points, TaskKind kind, int minimum, bool exact, std::string_view where) {
  const long n = points.cols();
  if (exact ? n != minimum : n < minimum) {
    std::string message(where);
    message.append(": ")
        .append(TaskKindName(kind))
        .append(exact ? " needs exactly " : " needs at least ")
        .append(std::to_string(minimum))
        .append(" points, got ")
        .append(std::to_string(n));
    throw InputError(message);
  }
  for (long i = 0; i < n; ++i) {
    if (!points.col(i).allFinite()) {
      std::string message(where);
      message.append(": ")
          .append(TaskKindName(kind))
          .append(": point ")
          .append(std::to_string(i))
          .append(" has a non-finite coordinate");
      throw InputError(message);
    }
  }
}

FitResult MakeResult(TaskKind kind, long num_points, const FitOptions& options) {
  FitResult r;
  r.kind = kind;
  r.outputs = TaskOutputs(kind);
  const long k = static_cast<long>(r.outputs.size());
  r.values = Eigen::VectorXd::Zero(k);
  r.differentiable.assign(static_cast<std::size_t>(k), true);
  if (options.jacobian) r.jacobian = Eigen::MatrixXd::Zero(k, 3 * num_points);
  return r;
}

double OrientationSign(const Vector3d& v, const FitOptions& options) {
  if (options.orientation.squaredNorm() > 0.0) return v.dot(options.orientation) < 0.0 ? -1.0 : 1.0;
  int largest = 0;
  for (int c = 1; c < 3; ++c) {
    if (std::abs(v(c)) > std::abs(v(largest))) largest = c;
  }
  return v(largest) < 0.0 ? -1.0 : 1.0;
}

}  // namespace tasks_internal

namespace {

using tasks_internal::CheckPoints;
using tasks_internal::Fail;
using tasks_internal::MakeResult;
using tasks_internal::OrientationSign;

// Points per work item of a fit's Jacobian (FitOptions::threads): a scan's plane over 10^5 points
// offers 196 items, 8 for each of 16 threads (issue 33).
constexpr std::size_t kJacobianChunk = 512;

// Centroid and eigen-decomposition of the centred scatter matrix (two passes for accuracy).
struct Scatter {
  Vector3d centroid;
  Vector3d lambda;   // ascending
  Matrix3d vectors;  // column k belongs to lambda(k)
};

Scatter ComputeScatter(const Points& points) {
  Scatter s;
  const double n = static_cast<double>(points.cols());
  s.centroid = points.rowwise().sum() / n;
  Matrix3d scatter = Matrix3d::Zero();
  for (long i = 0; i < points.cols(); ++i) {
    const Vector3d d = points.col(i) - s.centroid;
    scatter.noalias() += d * d.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Matrix3d> eig(scatter);
  s.lambda = eig.eigenvalues();
  s.vectors = eig.eigenvectors();
  return s;
}

// d v / d p_j = sum_{k != a} v_k v_k^T (t_j I + d_j v^T) / (lambda_a - lambda_k) with
// t_j = v . d_j, where v = +-v_a is the ORIENTED eigenvector (the sign enters twice in
// (t_j I + d_j v^T) and once in v, so the formula holds for either sign; v_k v_k^T is sign-free).
Matrix3d EigenvectorDerivative(const Scatter& s, int a, const Vector3d& v, const Vector3d& d_j) {
  const Matrix3d ds_v = v.dot(d_j) * Matrix3d::Identity() + d_j * v.transpose();
  Matrix3d result = Matrix3d::Zero();
  for (int k = 0; k < 3; ++k) {
    if (k == a) continue;
    const Vector3d vk = s.vectors.col(k);
    result.noalias() += vk * (vk.transpose() * ds_v) / (s.lambda(a) - s.lambda(k));
  }
  return result;
}

// The least-squares plane shared by FitPlane and FitCircle.
struct PlaneFit {
  Scatter scatter;
  Vector3d normal;  // oriented
  double extent;    // sqrt(largest eigenvalue / N), m
};

PlaneFit FitPlaneCore(const Points& points, TaskKind kind, const FitOptions& options,
                      std::string_view where) {
  PlaneFit p;
  p.scatter = ComputeScatter(points);
  const Vector3d& l = p.scatter.lambda;
  if (!(l(2) > 0.0)) Fail(where, kind, "all points coincide");
  if (l(1) <= kRankRatio * l(2)) Fail(where, kind, "points are collinear, the plane is undefined");
  if (l(1) - l(0) <= kGapRatio * l(2)) {
    Fail(where, kind, "points have no preferred plane (scatter isotropic across two directions)");
  }
  const Vector3d v = p.scatter.vectors.col(0);
  p.normal = OrientationSign(v, options) * v;
  p.extent = std::sqrt(l(2) / static_cast<double>(points.cols()));
  return p;
}

// Least-squares hypersphere in D = 2 (circle) or 3 (sphere) dimensions.
template <int D>
struct HypersphereFit {
  using Vec = Eigen::Matrix<double, D, 1>;
  using Hessian = Eigen::Matrix<double, D + 1, D + 1>;
  Vec centre;
  double radius = 0.0;
  double sum_sq = 0.0;  // sum of squared radial residuals
  int iterations = 0;
  Eigen::LDLT<Hessian> hessian;  // full Hessian of 1/2 sum e^2 at the optimum
};

// Residual e, unit vector u = (a - c)/rho and rho of one point.
template <int D>
struct RadialResidual {
  Eigen::Matrix<double, D, 1> u;
  double rho;
  double e;
};

template <int D>
RadialResidual<D> Radial(const Eigen::Matrix<double, D, 1>& a, const Eigen::Matrix<double, D, 1>& c,
                         double radius) {
  RadialResidual<D> r;
  const Eigen::Matrix<double, D, 1> d = a - c;
  r.rho = d.norm();
  r.u = r.rho > 0.0 ? Eigen::Matrix<double, D, 1>(d / r.rho) : Eigen::Matrix<double, D, 1>::Zero();
  r.e = r.rho - radius;
  return r;
}

// A least-squares hypersphere fit under way: centre c and radius in normalised coordinates
// q = (a - mean) / scale, so that every tolerance is relative. get(i) returns point i as
// Eigen::Matrix<double, D, 1>.
template <int D, class Get>
struct HypersphereSolver {
  using Vec = Eigen::Matrix<double, D, 1>;
  using Theta = Eigen::Matrix<double, D + 1, 1>;
  using Hessian = Eigen::Matrix<double, D + 1, D + 1>;

  const long n;
  const Get& get;
  const TaskKind kind;
  const std::string_view where;
  const char* const degenerate = D == 3 ? "points are coplanar, the sphere is undefined"
                                        : "projected points are collinear, the circle is undefined";
  Vec mean = Vec::Zero();
  double scale = 0.0;
  Vec c;
  double radius = 0.0;
  int iterations = 0;

  HypersphereSolver(long n, const Get& get, TaskKind kind, std::string_view where)
      : n(n), get(get), kind(kind), where(where) {}

  Vec q(long i) const { return (get(i) - mean) / scale; }

  // Work in normalised coordinates q = (a - mean) / scale so that every tolerance is relative.
  void Normalise() {
    for (long i = 0; i < n; ++i) mean += get(i);
    mean /= static_cast<double>(n);
    for (long i = 0; i < n; ++i) scale += (get(i) - mean).squaredNorm();
    scale = std::sqrt(scale / static_cast<double>(n));
    if (!(scale > 0.0)) Fail(where, kind, "all points coincide");
  }

  // Algebraic start (Kåsa): |q|^2 = 2 c.q + k, linear least squares in (c, k), k = R^2 - |c|^2.
  void AlgebraicStart() {
    Hessian ata = Hessian::Zero();
    Theta atb = Theta::Zero();
    for (long i = 0; i < n; ++i) {
      Theta row;
      row.template head<D>() = 2.0 * q(i);
      row(D) = 1.0;
      ata.noalias() += row * row.transpose();
      atb += row * q(i).squaredNorm();
    }
    const Eigen::SelfAdjointEigenSolver<Hessian> conditioning(ata);
    if (conditioning.eigenvalues()(0) <= 1e-12 * conditioning.eigenvalues()(D)) {
      Fail(where, kind, degenerate);
    }
    const Theta x = ata.ldlt().solve(atb);
    c = x.template head<D>();
    const double r2 = x(D) + c.squaredNorm();
    if (!(r2 > 0.0)) Fail(where, kind, degenerate);
    radius = std::sqrt(r2);
  }

  double Cost(const Vec& cc, double rr) const {
    double s = 0.0;
    for (long i = 0; i < n; ++i) s += Eigen::numext::abs2((q(i) - cc).norm() - rr);
    return s;
  }

  // Levenberg-Marquardt on e_i = |q_i - c| - R (Gauss-Newton steps, damped when they fail).
  void LevenbergMarquardt() {
    double current = Cost(c, radius);
    double damping = 1e-6;
    bool converged = false;
    for (; iterations < 200; ++iterations) {
      Hessian jtj = Hessian::Zero();
      Theta jte = Theta::Zero();
      for (long i = 0; i < n; ++i) {
        const RadialResidual<D> r = Radial<D>(q(i), c, radius);
        Theta row;
        row.template head<D>() = -r.u;
        row(D) = -1.0;
        jtj.noalias() += row * row.transpose();
        jte += row * r.e;
      }
      bool accepted = false;
      Theta step = Theta::Zero();
      while (damping < 1e12) {
        Hessian damped = jtj;
        damped.diagonal() *= 1.0 + damping;
        step = -damped.ldlt().solve(jte);
        const Vec c_try = c + step.template head<D>();
        const double r_try = radius + step(D);
        const double trial = Cost(c_try, r_try);
        if (std::isfinite(trial) && trial <= current) {
          c = c_try;
          radius = r_try;
          current = trial;
          damping = std::max(damping * 0.1, 1e-12);
          accepted = true;
          break;
        }
        damping *= 10.0;
      }
      // Stop when the accepted step is at rounding level, or no step can lower the cost (the
      // cost is already at its minimum to rounding).
      if (!accepted || step.norm() <= 1e-14 * (1.0 + c.norm() + std::abs(radius))) {
        converged = true;
        ++iterations;
        break;
      }
    }
    if (!converged || !std::isfinite(radius) || !c.allFinite()) {
      Fail(where, kind, "least-squares fit did not converge");
    }
  }

  // Near the minimum the cost cannot resolve steps below ~sqrt(eps) (its changes drop under its
  // rounding), so where LM stops depends on its path, to ~1e-8 relative. Finish with Newton
  // steps on the stationarity condition g = 0 with the FULL Hessian of F = 1/2 sum e^2
  //   g = -(sum e u; sum e),  H_cc = sum u u^T + e (I - u u^T)/rho,  H_cR = sum u,  H_RR = N,
  // which converge quadratically from there. Stop on the gradient, not on the step size: once
  // |g| is at the rounding level of its terms (each e_i carries rounding ~eps (rho_i + R), the
  // sum adds ~sqrt(N) eps sum |e_i|), the step computed there is still applied and the loop
  // ends, so the estimate is the stationary point to rounding whatever path LM took and the
  // fitted values are a smooth function of the points, as the Jacobian assumes.
  void NewtonSteps() {
    constexpr double kEps = std::numeric_limits<double>::epsilon();
    constexpr int kMaxNewton = 12;
    bool stationary = false;
    for (int newton = 0; newton < kMaxNewton; ++newton) {
      ++iterations;
      Hessian h = Hessian::Zero();
      Theta g = Theta::Zero();
      double terms = 0.0, residuals = 0.0;
      for (long i = 0; i < n; ++i) {
        const RadialResidual<D> r = Radial<D>(q(i), c, radius);
        if (!(r.rho > 0.0)) Fail(where, kind, "a point lies at the fitted centre");
        AddRadialCurvature(r, h);
        g.template head<D>() -= r.e * r.u;
        g(D) -= r.e;
        terms += r.rho + std::abs(radius);
        residuals += std::abs(r.e);
      }
      h.template bottomLeftCorner<1, D>() = h.template topRightCorner<D, 1>().transpose();
      h(D, D) = static_cast<double>(n);
      const double tolerance = 16.0 * kEps * (terms + std::sqrt(static_cast<double>(n)) * residuals);
      const bool at_rounding = g.template lpNorm<Eigen::Infinity>() <= tolerance;
      const Eigen::LDLT<Hessian> ldlt(h);
      const Theta step = -ldlt.solve(g);
      if (ldlt.info() != Eigen::Success || !step.allFinite()) break;
      c += step.template head<D>();
      radius += step(D);
      if (at_rounding) {
        stationary = true;
        break;
      }
    }
    if (!stationary || !std::isfinite(radius) || !c.allFinite()) {
      Fail(where, kind,
           "least-squares fit did not converge (gradient not at rounding level after " +
               std::to_string(kMaxNewton) + " Newton steps)");
    }
  }

  // H_cc += u u^T + e (I - u u^T)/rho and H_cR += u for one point.
  static void AddRadialCurvature(const RadialResidual<D>& r, Hessian& h) {
    const Eigen::Matrix<double, D, D> uu = r.u * r.u.transpose();
    h.template topLeftCorner<D, D>() += uu + r.e * (Eigen::Matrix<double, D, D>::Identity() - uu) / r.rho;
    h.template topRightCorner<D, 1>() += r.u;
  }

  // The fit in original coordinates, with its full Hessian there.
  HypersphereFit<D> Fit() const {
    HypersphereFit<D> fit;
    fit.centre = mean + scale * c;
    fit.radius = scale * radius;
    fit.iterations = iterations;
    // Full Hessian of 1/2 sum e^2 in original coordinates: H_cc = sum u u^T + e (I - u u^T)/rho,
    // H_cR = sum u, H_RR = N.
    Hessian h = Hessian::Zero();
    double sum_sq = 0.0;
    for (long i = 0; i < n; ++i) {
      const RadialResidual<D> r = Radial<D>(get(i), fit.centre, fit.radius);
      if (!(r.rho > 1e-12 * fit.radius)) Fail(where, kind, "a point lies at the fitted centre");
      AddRadialCurvature(r, h);
      sum_sq += r.e * r.e;
    }
    h.template bottomLeftCorner<1, D>() = h.template topRightCorner<D, 1>().transpose();
    h(D, D) = static_cast<double>(n);
    const Eigen::SelfAdjointEigenSolver<Hessian> curvature(h, Eigen::EigenvaluesOnly);
    if (!(curvature.eigenvalues()(0) > 1e-10 * curvature.eigenvalues()(D))) {
      Fail(where, kind, "the fit is not a strict minimum (ill-conditioned point set)");
    }
    fit.hessian.compute(h);
    fit.sum_sq = sum_sq;
    return fit;
  }
};

template <int D, class Get>
HypersphereFit<D> FitHypersphere(long n, const Get& get, TaskKind kind, std::string_view where) {
  HypersphereSolver<D, Get> solver(n, get, kind, where);
  solver.Normalise();
  solver.AlgebraicStart();
  solver.LevenbergMarquardt();
  solver.NewtonSteps();
  return solver.Fit();
}

// d(centre, radius)/d a_j = H^-1 [ (u_j; 1) u_j^T + e_j ((I - u_j u_j^T)/rho_j; 0) ].
template <int D>
Eigen::Matrix<double, D + 1, D> HypersphereSensitivity(const HypersphereFit<D>& fit,
                                                       const RadialResidual<D>& r) {
  Eigen::Matrix<double, D + 1, D> rhs;
  rhs.template topRows<D>() =
      r.u * r.u.transpose() + r.e * (Eigen::Matrix<double, D, D>::Identity() - r.u * r.u.transpose()) / r.rho;
  rhs.template bottomRows<1>() = r.u.transpose();
  return fit.hessian.solve(rhs);
}

}  // namespace

std::span<const TaskOutput> TaskOutputs(TaskKind kind) {
  switch (kind) {
    case TaskKind::kDistance: return kDistanceOutputs;
    case TaskKind::kPlane: return kPlaneOutputs;
    case TaskKind::kSphere: return kSphereOutputs;
    case TaskKind::kCircle: return kCircleOutputs;
    case TaskKind::kLine: return kLineOutputs;
    case TaskKind::kTwoFace: return kTwoFaceOutputs;
    case TaskKind::kCylinder:
    case TaskKind::kCone: return tasks_internal::AxialOutputs(kind);
    case TaskKind::kBestFit:
    case TaskKind::kBestFitScale:
    case TaskKind::kRps:
    case TaskKind::kFeatures:
    case TaskKind::kDeviation:
    case TaskKind::kPosition:
    case TaskKind::kProfile: return tasks_internal::AlignmentOutputs(kind);
    case TaskKind::kFlatness:
    case TaskKind::kStraightness:
    case TaskKind::kRoundness:
    case TaskKind::kCylindricity: return tasks_internal::FormOutputs(kind);
  }
  return {};
}

FitResult FitDistance(const Points& points, const FitOptions& options, std::string_view where) {
  CheckPoints(points, TaskKind::kDistance, 2, true, where);
  FitResult r = MakeResult(TaskKind::kDistance, 2, options);
  const Vector3d d = points.col(1) - points.col(0);
  const double length = d.norm();
  if (!(length > 1e-15 * (points.col(0).norm() + points.col(1).norm()))) {
    Fail(where, TaskKind::kDistance, "the two points coincide");
  }
  r.values(0) = length;
  if (options.jacobian) {
    const Vector3d u = d / length;
    r.jacobian.block<1, 3>(0, 0) = -u.transpose();
    r.jacobian.block<1, 3>(0, 3) = u.transpose();
  }
  return r;
}

FitResult FitTwoFace(const Points& points, const FitOptions& options, std::string_view where) {
  CheckPoints(points, TaskKind::kTwoFace, 2, true, where);
  FitResult r = MakeResult(TaskKind::kTwoFace, 2, options);
  // Linear: no degenerate configuration, coincident points included (the usual case).
  r.values = points.col(1) - points.col(0);
  if (options.jacobian) {
    r.jacobian.block<3, 3>(0, 0) = -Matrix3d::Identity();
    r.jacobian.block<3, 3>(0, 3) = Matrix3d::Identity();
  }
  return r;
}

FitResult FitPlane(const Points& points, const FitOptions& options, std::string_view where) {
  CheckPoints(points, TaskKind::kPlane, 3, false, where);
  if (tasks_internal::Weighted(options))
    return tasks_internal::FitWeightedFeature(TaskKind::kPlane, points, options, where);
  const long n = points.cols();
  const double nd = static_cast<double>(n);
  const PlaneFit plane = FitPlaneCore(points, TaskKind::kPlane, options, where);
  const Vector3d& c = plane.scatter.centroid;
  const Vector3d& normal = plane.normal;

  long i_max = 0, i_min = 0;
  double r_max = -INFINITY, r_min = INFINITY, sum_sq = 0.0;
  for (long i = 0; i < n; ++i) {
    const double r = normal.dot(points.col(i) - c);
    if (r > r_max) r_max = r, i_max = i;
    if (r < r_min) r_min = r, i_min = i;
    sum_sq += r * r;
  }
  const double rms = std::sqrt(sum_sq / nd);

  FitOptions without_jacobian = options;
  without_jacobian.jacobian = false;
  FitResult result = MakeResult(TaskKind::kPlane, n, without_jacobian);
  result.values << c, normal, r_max - r_min, rms;
  const bool exact = rms <= kExactFit * plane.extent;
  result.differentiable[6] = result.differentiable[7] = !exact;
  if (!options.jacobian) return result;

  // Every column is written (not zeroed first: 8 x 3N values of a scan), in chunks side by side.
  result.jacobian.resize(8, 3 * n);
  const Vector3d d_max_minus_min = points.col(i_max) - points.col(i_min);
  parallel_internal::ForEachChunk(
      static_cast<std::size_t>(n), kJacobianChunk, options.threads, [&](std::size_t, std::size_t b, std::size_t e) {
        for (long j = static_cast<long>(b); j < static_cast<long>(e); ++j) {
          const Vector3d d_j = points.col(j) - c;
          const Matrix3d dn = EigenvectorDerivative(plane.scatter, 0, normal, d_j);
          auto block = result.jacobian.middleCols<3>(3 * j);
          block.topRows<3>() = Matrix3d::Identity() / nd;
          block.middleRows<3>(3) = dn;
          if (exact) {
            block.bottomRows<2>().setZero();
            continue;
          }
          // flatness = r_max - r_min, r_i = n . (p_i - c): the centroid terms cancel.
          Eigen::RowVector3d flat = d_max_minus_min.transpose() * dn;
          if (j == i_max) flat += normal.transpose();
          if (j == i_min) flat -= normal.transpose();
          block.row(6) = flat;
          block.row(7) = normal.dot(d_j) * normal.transpose() / (nd * rms);  // envelope theorem
        }
      });
  return result;
}

FitResult FitSphere(const Points& points, const FitOptions& options, std::string_view where) {
  CheckPoints(points, TaskKind::kSphere, 4, false, where);
  if (tasks_internal::Weighted(options))
    return tasks_internal::FitWeightedFeature(TaskKind::kSphere, points, options, where);
  const long n = points.cols();
  const double nd = static_cast<double>(n);
  // Coplanar (or collinear) points: a family of spheres fits them.
  const Scatter s = ComputeScatter(points);
  if (!(s.lambda(2) > 0.0)) Fail(where, TaskKind::kSphere, "all points coincide");
  if (s.lambda(0) <= kRankRatio * s.lambda(2)) {
    Fail(where, TaskKind::kSphere, "points are coplanar, the sphere is undefined");
  }
  const auto get = [&](long i) -> Vector3d { return points.col(i); };
  const HypersphereFit<3> fit = FitHypersphere<3>(n, get, TaskKind::kSphere, where);
  const double rms = std::sqrt(fit.sum_sq / nd);

  FitResult result = MakeResult(TaskKind::kSphere, n, options);
  result.values << fit.centre, fit.radius, rms;
  result.iterations = fit.iterations;
  const bool exact = rms <= kExactFit * fit.radius;
  result.differentiable[4] = !exact;
  if (!options.jacobian) return result;
  parallel_internal::ForEachChunk(
      static_cast<std::size_t>(n), kJacobianChunk, options.threads, [&](std::size_t, std::size_t b, std::size_t e) {
        for (long j = static_cast<long>(b); j < static_cast<long>(e); ++j) {
          const RadialResidual<3> r = Radial<3>(points.col(j), fit.centre, fit.radius);
          auto block = result.jacobian.middleCols<3>(3 * j);
          block.topRows<4>() = HypersphereSensitivity<3>(fit, r);
          if (!exact) block.row(4) = r.e * r.u.transpose() / (nd * rms);  // envelope theorem
        }
      });
  return result;
}

FitResult FitCircle(const Points& points, const FitOptions& options, std::string_view where) {
  CheckPoints(points, TaskKind::kCircle, 3, false, where);
  if (tasks_internal::Weighted(options))
    return tasks_internal::FitWeightedFeature(TaskKind::kCircle, points, options, where);
  const long n = points.cols();
  const double nd = static_cast<double>(n);
  const PlaneFit plane = FitPlaneCore(points, TaskKind::kCircle, options, where);
  const Vector3d& c0 = plane.scatter.centroid;
  const Vector3d& normal = plane.normal;

  // In-plane orthonormal basis B = [u w]; the results do not depend on its rotation in the plane.
  int axis = 0;
  for (int k = 1; k < 3; ++k) {
    if (std::abs(normal(k)) < std::abs(normal(axis))) axis = k;
  }
  const Vector3d e = Vector3d::Unit(axis);
  const Vector3d u = (e - normal * normal.dot(e)).normalized();
  Eigen::Matrix<double, 3, 2> basis;
  basis << u, normal.cross(u);
  const auto project = [&](long i) -> Eigen::Vector2d { return basis.transpose() * (points.col(i) - c0); };
  const HypersphereFit<2> fit = FitHypersphere<2>(n, project, TaskKind::kCircle, where);
  const Vector3d offset = basis * fit.centre;  // centre - centroid, in the plane
  const double rms = std::sqrt(fit.sum_sq / nd);

  FitResult result = MakeResult(TaskKind::kCircle, n, options);
  result.values << c0 + offset, fit.radius, normal, rms;
  result.iterations = fit.iterations;
  const bool exact = rms <= kExactFit * fit.radius;
  result.differentiable[7] = !exact;
  if (!options.jacobian) return result;

  // a_i = B^T (p_i - c0). Moving point j moves the centroid (dc0 = dp_j / N) and the normal
  // (dn = N_j dp_j); the basis follows the normal without in-plane rotation, dB = -n dn^T B, so
  // da_i = B^T (dd_i - r_i dn) with r_i = n . d_i. Then d theta = sum_i K_i da_i gives
  //   d theta / dp_j = K_j B^T - (sum_i K_i) B^T / N - (sum_i r_i K_i B^T) N_j.
  Eigen::Matrix<double, 3, 2> k_sum = Eigen::Matrix<double, 3, 2>::Zero();
  Matrix3d k_r = Matrix3d::Zero();
  Eigen::RowVector2d g_sum = Eigen::RowVector2d::Zero();  // sum e_i u_i^T (for rms)
  Eigen::RowVector3d g_r = Eigen::RowVector3d::Zero();    // sum e_i r_i u_i^T B^T
  for (long i = 0; i < n; ++i) {
    const RadialResidual<2> r = Radial<2>(project(i), fit.centre, fit.radius);
    const Eigen::Matrix<double, 3, 2> k = HypersphereSensitivity<2>(fit, r);
    const double r_i = normal.dot(points.col(i) - c0);
    k_sum += k;
    k_r.noalias() += r_i * k * basis.transpose();
    g_sum += r.e * r.u.transpose();
    g_r += r.e * r_i * r.u.transpose() * basis.transpose();
  }
  for (long j = 0; j < n; ++j) {
    const Vector3d d_j = points.col(j) - c0;
    const Matrix3d dn = EigenvectorDerivative(plane.scatter, 0, normal, d_j);
    const RadialResidual<2> r = Radial<2>(project(j), fit.centre, fit.radius);
    const Eigen::Matrix<double, 3, 2> k = HypersphereSensitivity<2>(fit, r);
    const Matrix3d dtheta = k * basis.transpose() - k_sum * basis.transpose() / nd - k_r * dn;
    auto block = result.jacobian.middleCols<3>(3 * j);
    // centre = c0 + B mu: dc0 + dB mu + B dmu, dB mu = -n (B mu)^T dn.
    block.topRows<3>() =
        Matrix3d::Identity() / nd - normal * (offset.transpose() * dn) + basis * dtheta.topRows<2>();
    block.row(3) = dtheta.row(2);
    block.middleRows<3>(4) = dn;
    if (!exact) {
      // d(sum e^2)/dp_j / 2 = e_j u_j^T B^T - (sum e u^T) B^T / N - (sum e r u^T B^T) N_j.
      const Eigen::RowVector3d half_grad =
          r.e * r.u.transpose() * basis.transpose() - g_sum * basis.transpose() / nd - g_r * dn;
      block.row(7) = half_grad / (nd * rms);
    }
  }
  return result;
}

FitResult FitLine(const Points& points, const FitOptions& options, std::string_view where) {
  CheckPoints(points, TaskKind::kLine, 2, false, where);
  if (tasks_internal::Weighted(options))
    return tasks_internal::FitWeightedFeature(TaskKind::kLine, points, options, where);
  const long n = points.cols();
  const double nd = static_cast<double>(n);
  const Scatter s = ComputeScatter(points);
  const Vector3d& l = s.lambda;
  if (!(l(2) > 0.0)) Fail(where, TaskKind::kLine, "all points coincide");
  if (l(2) - l(1) <= kGapRatio * l(2)) {
    Fail(where, TaskKind::kLine, "points have no preferred direction");
  }
  const Vector3d v = s.vectors.col(2);
  const Vector3d direction = OrientationSign(v, options) * v;
  const Vector3d& c = s.centroid;
  const double extent = std::sqrt(l(2) / nd);

  long i_max = 0;
  double q_max = -1.0, sum_sq = 0.0;
  for (long i = 0; i < n; ++i) {
    const Vector3d d = points.col(i) - c;
    const double q2 = (d - direction * direction.dot(d)).squaredNorm();
    if (q2 > q_max) q_max = q2, i_max = i;
    sum_sq += q2;
  }
  q_max = std::sqrt(q_max);
  const double rms = std::sqrt(sum_sq / nd);

  FitResult result = MakeResult(TaskKind::kLine, n, options);
  result.values << c, direction, 2.0 * q_max, rms;
  const bool exact = rms <= kExactFit * extent;
  result.differentiable[6] = result.differentiable[7] = !exact;
  if (!options.jacobian) return result;

  const Vector3d d_m = points.col(i_max) - c;
  const double s_m = direction.dot(d_m);
  const Vector3d w_hat = (d_m - direction * s_m).normalized();
  for (long j = 0; j < n; ++j) {
    const Vector3d d_j = points.col(j) - c;
    const Matrix3d dv = EigenvectorDerivative(s, 2, direction, d_j);
    auto block = result.jacobian.middleCols<3>(3 * j);
    block.topRows<3>() = Matrix3d::Identity() / nd;
    block.middleRows<3>(3) = dv;
    if (exact) continue;
    // q_m = |P d_m|: dq_m = w^T (dp_m - dc) - s_m w^T dv  (w: unit perpendicular of point m).
    Eigen::RowVector3d dq = -w_hat.transpose() / nd - s_m * w_hat.transpose() * dv;
    if (j == i_max) dq += w_hat.transpose();
    block.row(6) = 2.0 * dq;
    const Vector3d w_j = d_j - direction * direction.dot(d_j);
    block.row(7) = w_j.transpose() / (nd * rms);  // envelope theorem
  }
  return result;
}

FitResult FitCylinder(const Points& points, const FitOptions& options, std::string_view where) {
  if (tasks_internal::Weighted(options)) {
    CheckPoints(points, TaskKind::kCylinder, MinimumPoints(TaskKind::kCylinder), false, where);
    return tasks_internal::FitWeightedFeature(TaskKind::kCylinder, points, options, where);
  }
  return tasks_internal::FitAxialSurface(TaskKind::kCylinder, points, options, where);
}

FitResult FitCone(const Points& points, const FitOptions& options, std::string_view where) {
  if (tasks_internal::Weighted(options)) {
    CheckPoints(points, TaskKind::kCone, MinimumPoints(TaskKind::kCone), false, where);
    return tasks_internal::FitWeightedFeature(TaskKind::kCone, points, options, where);
  }
  return tasks_internal::FitAxialSurface(TaskKind::kCone, points, options, where);
}

FitResult FitMinimumZone(TaskKind kind, const Points& points, const FitOptions& options,
                         std::string_view where) {
  return tasks_internal::FitForm(kind, points, options, where);
}

FitResult FitTask(TaskKind kind, const Points& points, const FitOptions& options, std::string_view where) {
  if (tasks_internal::Weighted(options)) tasks_internal::CheckWeightable(kind, where);
  switch (kind) {
    case TaskKind::kDistance: return FitDistance(points, options, where);
    case TaskKind::kPlane: return FitPlane(points, options, where);
    case TaskKind::kSphere: return FitSphere(points, options, where);
    case TaskKind::kCircle: return FitCircle(points, options, where);
    case TaskKind::kLine: return FitLine(points, options, where);
    case TaskKind::kTwoFace: return FitTwoFace(points, options, where);
    case TaskKind::kCylinder: return FitCylinder(points, options, where);
    case TaskKind::kCone: return FitCone(points, options, where);
    case TaskKind::kBestFit:
    case TaskKind::kBestFitScale:
    case TaskKind::kRps:
    case TaskKind::kFeatures: return FitBestFit(points, options, where);
    case TaskKind::kDeviation:
    case TaskKind::kPosition: return FitDeviation(points, options, where);
    case TaskKind::kProfile: return FitProfile(points, options, where);
    case TaskKind::kFlatness:
    case TaskKind::kStraightness:
    case TaskKind::kRoundness:
    case TaskKind::kCylindricity: return FitMinimumZone(kind, points, options, where);
  }
  Fail(where, kind, "unknown task kind");
}

FitOptions TaskFitOptions(const TaskSpec& task, bool jacobian) {
  FitOptions options;
  options.jacobian = jacobian;
  options.nominal = task.nominal;
  return options;
}

FitOptions TrialFitOptions(const TaskSpec& task, const Eigen::VectorXd& at_estimates,
                           std::shared_ptr<const FitWeights> weights) {
  FitOptions options = TaskFitOptions(task, false);
  if (task.weighted && weights == nullptr) {
    // Without them every trial would run the ordinary fit: a programming error, not an input's.
    throw std::invalid_argument("TrialFitOptions: task '" + task.name +
                                "' is weighted: give its fit's weights");
  }
  options.weights = std::move(weights);
  int orientation = -1, angles = -1;
  if (task.kind == TaskKind::kPlane || task.kind == TaskKind::kLine || task.kind == TaskKind::kCylinder ||
      task.kind == TaskKind::kCone) {
    orientation = 3;
  }
  if (task.kind == TaskKind::kCircle) orientation = 4;
  if (task.kind == TaskKind::kBestFit || task.kind == TaskKind::kBestFitScale ||
      task.kind == TaskKind::kRps || task.kind == TaskKind::kFeatures)
    angles = 3;
  const long need = std::max(orientation, angles) + 3;
  if (at_estimates.size() < need) return options;
  if (orientation >= 0) options.orientation = at_estimates.segment<3>(orientation);
  if (angles >= 0) options.reference_angles = at_estimates.segment<3>(angles);
  return options;
}

}  // namespace vlt
