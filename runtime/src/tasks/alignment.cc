// tasks/alignment.cc — alignment of measured points to their nominal (CAD) positions and the
// deviations from nominal in the aligned part frame (vlt/fits.h FitBestFit, FitDeviation).
//
// The fit (docs/tasks.md "Alignment to nominal"): part = s R x + t minimising
// F = 1/2 sum |r_i|^2, r_i = s R x_i + t - n_i. Closed form (Umeyama, IEEE TPAMI 13 (1991) 376;
// Kabsch 1976 without the scale): with a_i, b_i the measured and nominal points less their
// centroids and S = sum b_i a_i^T = U D V^T, R = U diag(1, 1, det(U V^T)) V^T,
// s = trace(D diag(1, 1, det(U V^T))) / sum |a_i|^2, t = n_bar - s R x_bar.
//
// Derivatives: theta = (w, t, sigma) with R = exp([w]x) R^ (a rotation on the left of the fitted
// one), s = s^ + sigma. At the optimum the gradient g(theta, X) = sum J_i^T r_i vanishes, so
// dtheta/dx_j = -H^-1 dg/dx_j (implicit function theorem) with the FULL Hessian
//   H = sum J_i^T J_i + sum_k r_ik d2 r_ik / dtheta2,   J_i = [-s [y_i]x, I, y_i],  y_i = R^ x_i,
// whose residual terms are s sum (1/2 (r_i y_i^T + y_i r_i^T) - (r_i . y_i) I) (w, w) and
// sum y_i x r_i (w, sigma); and dg/dx_j = [s (s [y_j]x - [r_j]x); s I; r_j^T + s y_j^T] R^.
// Exact for non-zero residuals (tests/test_alignment.cc: central differences of the whole fit).
#include "tasks/alignment.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <string>

#include <Eigen/Dense>

#include "tasks/weighted.h"
#include "vlt/error.h"

namespace vlt {
namespace tasks_internal {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using Points = Eigen::Ref<const Eigen::Matrix3Xd>;

// best_fit_scale: these eight; best_fit and rps: the first seven (s = 1).
constexpr TaskOutput kBestFitScaleOutputs[] = {
    {"tx", "m", "x of the translation t of part = s R x + t (the measured frame's origin in the part frame)"},
    {"ty", "m", "y of the translation t"},
    {"tz", "m", "z of the translation t"},
    {"rx", "rad",
     "rotation about the part's x axis: R = Rz(rz) Ry(ry) Rx(rx) (fixed axes x, then y, then z)"},
    {"ry", "rad", "rotation about the part's y axis, in [-pi/2, pi/2]"},
    {"rz", "rad", "rotation about the part's z axis"},
    {"rms", "m",
     "root mean square distance |s R x_i + t - n_i| of the aligned points from nominal (rps: of the held "
     "components)"},
    {"scale", "1",
     "scale s applied to the measured points (1 + thermal expansion or range scale not modelled)"},
};
const std::span<const TaskOutput> kBestFitOutputs(kBestFitScaleOutputs, 7);
constexpr TaskOutput kPositionOutputs[] = {
    {"deviation", "m", "deviation d . n along the nominal unit normal n (positive: on the side n points to)"},
    {"dx", "m", "x of the deviation d = s R x + t - n_nominal in the part frame"},
    {"dy", "m", "y of the deviation d"},
    {"dz", "m", "z of the deviation d"},
    {"position", "m", "2 |d - (d . n) n|: diameter of the ISO 1101 position zone about the nominal axis n"},
};
constexpr TaskOutput kProfileOutputs[] = {
    {"min_deviation", "m", "smallest deviation along the nominal normals of the profile's points"},
    {"max_deviation", "m", "largest deviation along the nominal normals"},
    {"profile", "m",
     "2 max |deviation|: width of the ISO 1101 profile zone centred on nominal that holds every point"},
};
// A deviation without the position: the first four.
const std::span<const TaskOutput> kDeviationOutputs(kPositionOutputs, 4);

// Relative size below which a residual is "zero" (nominal points of a plan fit exactly): the rms
// and the position are then not differentiable (vlt/fits.h FitResult::differentiable).
constexpr double kExactFit = 1e-10;
// Second singular value of the cross-covariance below this fraction of the first: the points are
// collinear and the rotation about their line is undetermined.
constexpr double kCollinear = 1e-12;
// |cos ry| below this: Rx and Rz turn about the same axis (gimbal lock), rx and rz undetermined.
constexpr double kGimbalLock = 1e-9;

const NominalGeometry& Nominal(const FitOptions& options, TaskKind kind, long n, std::string_view where) {
  if (!options.nominal)
    throw InputError(std::string(where) + ": " + std::string(TaskKindName(kind)) + ": no nominal geometry");
  const NominalGeometry& g = *options.nominal;
  const long k = g.alignment_points;
  if (g.positions.cols() != n || k < 3 || k > n) {
    throw InputError(std::string(where) + ": " + std::string(TaskKindName(kind)) +
                     ": needs at least 3 points with nominal positions, got " + std::to_string(k));
  }
  for (long i = 0; i < n; ++i) {
    if (!g.positions.col(i).allFinite())
      throw InputError(std::string(where) + ": nominal position " + std::to_string(i) + " is not finite");
  }
  return g;
}

Matrix3d Hat(const Vector3d& v) {
  Matrix3d m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

// The fitted transform and, when asked, dtheta/dX (p x 3K, theta = (w, t[, sigma])).
struct Alignment {
  Matrix3d rotation;
  Vector3d translation;
  double scale = 1.0;
  double rms = 0.0;
  double extent = 0.0;        // largest distance of a nominal point from their centroid
  Eigen::MatrixXd dtheta_dx;  // empty unless jacobian
  Eigen::MatrixXd residuals;  // 3 x K
  // A weighted alignment (tasks/weighted.h): its weights, r^T W r and degrees of freedom.
  std::shared_ptr<const FitWeights> weights;
  double chi2 = 0.0;
  int degrees_of_freedom = 0;
};

// Closed-form fit of the first k points (Umeyama / Kabsch).
void FitTransform(const Points& x, const Eigen::Matrix3Xd& n, long k, bool scale, TaskKind kind,
                  std::string_view where, Alignment& a) {
  const Vector3d x_bar = x.leftCols(k).rowwise().mean();
  const Vector3d n_bar = n.leftCols(k).rowwise().mean();
  Matrix3d cross = Matrix3d::Zero();
  double spread = 0.0;
  for (long i = 0; i < k; ++i) {
    const Vector3d ai = x.col(i) - x_bar;
    cross += (n.col(i) - n_bar) * ai.transpose();
    spread += ai.squaredNorm();
    a.extent = std::max(a.extent, (n.col(i) - n_bar).norm());
  }
  const Eigen::JacobiSVD<Matrix3d> svd(cross, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Vector3d d = svd.singularValues();
  if (!(d(1) > kCollinear * d(0))) {
    Fail(where, kind,
         "the points are collinear (measured or nominal): the rotation about their line is undetermined");
  }
  Vector3d sign(1.0, 1.0, (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0.0 ? -1.0 : 1.0);
  a.rotation = svd.matrixU() * sign.asDiagonal() * svd.matrixV().transpose();
  a.scale = scale ? d.dot(sign) / spread : 1.0;
  if (!(a.scale > 0.0))
    Fail(where, kind, "the fitted scale is not positive (the points do not match their nominals)");
  a.translation = n_bar - a.scale * a.rotation * x_bar;
  a.residuals.resize(3, k);
  double sum = 0.0;
  for (long i = 0; i < k; ++i) {
    a.residuals.col(i) = a.scale * a.rotation * x.col(i) + a.translation - n.col(i);
    sum += a.residuals.col(i).squaredNorm();
  }
  a.rms = std::sqrt(sum / static_cast<double>(k));
}

// The weight of point i's residual: I for a best fit, the projection on the axes it holds for an
// RPS (W_i = diag(holds_i), in the part frame where r_i lives).
Matrix3d Weight(const NominalGeometry& g, long i) {
  if (g.holds.empty()) return Matrix3d::Identity();
  const std::array<bool, 3>& h = g.holds[static_cast<std::size_t>(i)];
  return Vector3d(h[0] ? 1.0 : 0.0, h[1] ? 1.0 : 0.0, h[2] ? 1.0 : 0.0).asDiagonal();
}

// J_i = d r_i / d theta at the current fit (header comment).
Eigen::Matrix<double, 3, Eigen::Dynamic> ResidualJacobian(const Vector3d& y, double s, bool scale) {
  Eigen::Matrix<double, 3, Eigen::Dynamic> j(3, scale ? 7 : 6);
  j.leftCols<3>() = -s * Hat(y);
  j.middleCols<3>(3) = Matrix3d::Identity();
  if (scale) j.col(6) = y;
  return j;
}

// What the rms averages over: the points of a best fit (rms of the distances |r_i|), the held
// directions of an RPS (rms of the held residual components).
double RmsDivisor(const NominalGeometry& g, long k) {
  if (g.holds.empty()) return static_cast<double>(k);
  double held = 0.0;
  for (long i = 0; i < k; ++i) held += Weight(g, i).trace();
  return held;
}

void UpdateResiduals(const Points& x, const NominalGeometry& g, long k, Alignment& a) {
  a.residuals.resize(3, k);
  double sum = 0.0;
  for (long i = 0; i < k; ++i) {
    a.residuals.col(i) = a.scale * a.rotation * x.col(i) + a.translation - g.positions.col(i);
    sum += a.residuals.col(i).dot(Weight(g, i) * a.residuals.col(i));
  }
  a.rms = std::sqrt(sum / RmsDivisor(g, k));
}

// The reference point system: minimise 1/2 sum r_i^T W_i r_i from the best fit of the same points,
// by Gauss-Newton steps on theta (rotation on the left). The held directions must fix all six
// (seven) parameters; a 3-2-1 system fits exactly (zero residuals) in a few steps.
void FitReferencePointSystem(const Points& x, const NominalGeometry& g, long k, TaskKind kind,
                             std::string_view where, Alignment& a) {
  const int p = g.scale ? 7 : 6;
  for (int iteration = 0; iteration < 50; ++iteration) {
    Eigen::MatrixXd h = Eigen::MatrixXd::Zero(p, p);
    Eigen::VectorXd grad = Eigen::VectorXd::Zero(p);
    for (long i = 0; i < k; ++i) {
      const Eigen::Matrix<double, 3, Eigen::Dynamic> j =
          ResidualJacobian(a.rotation * x.col(i), a.scale, g.scale);
      const Matrix3d w = Weight(g, i);
      h.noalias() += j.transpose() * w * j;
      grad.noalias() += j.transpose() * (w * a.residuals.col(i));
    }
    const Eigen::LDLT<Eigen::MatrixXd> factor(h);
    if (factor.info() != Eigen::Success ||
        !(factor.vectorD().minCoeff() > 1e-12 * factor.vectorD().maxCoeff())) {
      Fail(where, kind,
           "the held directions do not fix the part: a rotation or translation is left free (3-2-1 holds x, "
           "y, z of one point, two axes of a second, one of a third)");
    }
    const Eigen::VectorXd step = -factor.solve(grad);
    const Vector3d w = step.head<3>();
    if (w.norm() > 0.0)
      a.rotation = Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix() * a.rotation;
    a.translation += step.segment<3>(3);
    if (g.scale) a.scale += step(6);
    UpdateResiduals(x, g, k, a);
    // Converged when the step is at the rounding level of the transform (relative: a part 20 m
    // from the tracker's origin has translation steps of 1e-15 x 20 m from rounding alone).
    const double size = std::max({1.0, a.translation.norm(), a.extent});
    if (step.head<3>().norm() <= 1e-13 && step.segment<3>(3).norm() <= 1e-13 * size) return;
  }
  Fail(where, kind, "the reference point system did not converge in 50 Gauss-Newton steps");
}

// dtheta/dX by the implicit function theorem (header comment), for residual weights W_i: the
// residual terms of H carry rho_i = W_i r_i, and dg/dx_j = [s (s [y]x W - [rho]x); s W; (rho + s W y)^T] R^.
void AlignmentSensitivity(const Points& x, const NominalGeometry& g, long k, TaskKind kind,
                          std::string_view where, Alignment& a) {
  const bool scale = g.scale;
  const int p = scale ? 7 : 6;
  const double s = a.scale;
  Eigen::MatrixXd h = Eigen::MatrixXd::Zero(p, p);
  for (long i = 0; i < k; ++i) {
    const Vector3d y = a.rotation * x.col(i);
    const Matrix3d w = Weight(g, i);
    const Vector3d rho = w * a.residuals.col(i);
    const Eigen::Matrix<double, 3, Eigen::Dynamic> j = ResidualJacobian(y, s, scale);
    h.noalias() += j.transpose() * w * j;
    h.topLeftCorner<3, 3>() +=
        s * (0.5 * (rho * y.transpose() + y * rho.transpose()) - rho.dot(y) * Matrix3d::Identity());
    if (scale) {
      const Vector3d y_cross_rho = y.cross(rho);
      h.block<3, 1>(0, 6) += y_cross_rho;
      h.block<1, 3>(6, 0) += y_cross_rho.transpose();
    }
  }
  const Eigen::LDLT<Eigen::MatrixXd> factor(h);
  if (factor.info() != Eigen::Success || !(factor.vectorD().minCoeff() > 0.0)) {
    Fail(where, kind, "the alignment is not a minimum its points determine (singular normal equations)");
  }
  a.dtheta_dx.resize(p, 3 * k);
  Eigen::MatrixXd dg(p, 3);
  for (long j = 0; j < k; ++j) {
    const Vector3d y = a.rotation * x.col(j);
    const Matrix3d w = Weight(g, j);
    const Vector3d rho = w * a.residuals.col(j);
    dg.topRows<3>() = s * (s * Hat(y) * w - Hat(rho)) * a.rotation;
    dg.middleRows<3>(3) = s * w * a.rotation;
    if (scale) dg.row(6) = (rho + s * w * y).transpose() * a.rotation;
    a.dtheta_dx.middleCols(3 * j, 3) = -factor.solve(dg);
  }
}

// --- Alignment by datum features (kind features; docs/tasks.md "Alignment by datum features"):
// the plane of the first points (primary datum: its normal is the part's third axis), the line of
// the next (secondary: its direction, projected into the plane, the first axis), the last point
// (tertiary). The nominal datums are the same fits of the nominal positions. With the datum frame
// F = [e1 e2 e3], e3 = n, e1 = (l - (l . n) n) / |...|, e2 = e3 x e1 (measured F_m, nominal F_n):
//   R = F_n F_m^T,   t = F_n q,   q = (e1_n . (p_n - R p_m), e2_n . (a_n - R a_m), e3_n . (c_n - R c_m)),
// c, a the plane's and the line's centroids, p the point: the plane fixes the part along e3, the
// line along e2, the point along e1. Signs of n and l: those that agree with the best fit of all
// the datum points to their nominals (a tracker frame can be anything).

// A datum frame and what its derivative needs.
struct DatumFrame {
  Matrix3d f;     // [e1 e2 e3]
  double v_norm;  // |l - (l . n) n|
};

DatumFrame MakeDatumFrame(const Vector3d& n, const Vector3d& l, TaskKind kind, std::string_view where) {
  const Vector3d v = l - l.dot(n) * n;
  DatumFrame frame;
  frame.v_norm = v.norm();
  // Below 1e-3 (the line within 0.06 degrees of the plane's normal) the rotation about the normal
  // is undetermined for any real measurement.
  if (!(frame.v_norm > 1e-3)) {
    Fail(where, kind,
         "the datum line is perpendicular to the datum plane: it does not fix the rotation about the plane's "
         "normal");
  }
  const Vector3d e1 = v / frame.v_norm;
  frame.f << e1, n.cross(e1), n;
  return frame;
}

// d[e1 e2 e3] of the measured frame for changes dn, dl of its normal and direction.
Matrix3d DatumFrameChange(const DatumFrame& frame, const Vector3d& n, const Vector3d& l, const Vector3d& dn,
                          const Vector3d& dl) {
  const Vector3d e1 = frame.f.col(0);
  const Vector3d dv = dl - (dl.dot(n) + l.dot(dn)) * n - l.dot(n) * dn;
  const Vector3d de1 = (dv - e1.dot(dv) * e1) / frame.v_norm;
  Matrix3d df;
  df << de1, dn.cross(e1) + n.cross(de1), dn;
  return df;
}

void FitDatumFeatures(const Points& x, const NominalGeometry& g, bool jacobian, TaskKind kind,
                      std::string_view where, Alignment& a) {
  const long kp = g.plane_points, kl = g.line_points, k = g.alignment_points, point = kp + kl;
  if (kp < 3 || kl < 2 || point + 1 != k) {
    throw InputError(std::string(where) + ": features: a plane of >= 3 points, a line of >= 2 and one point");
  }
  // The best fit of every datum point: only the signs of the datums' directions come from it.
  Alignment rough;
  FitTransform(x, g.positions, k, false, kind, where, rough);
  FitOptions with_jacobian;
  with_jacobian.jacobian = jacobian;
  const FitResult plane = FitPlane(x.leftCols(kp), with_jacobian, where);
  const FitResult line = FitLine(x.middleCols(kp, kl), with_jacobian, where);
  const FitResult plane_n = FitPlane(g.positions.leftCols(kp), {}, where);
  const FitResult line_n = FitLine(g.positions.middleCols(kp, kl), {}, where);
  const Vector3d nn = plane_n.values.segment<3>(3), ln = line_n.values.segment<3>(3);
  const double sn = (rough.rotation * plane.values.segment<3>(3)).dot(nn) < 0.0 ? -1.0 : 1.0;
  const double sl = (rough.rotation * line.values.segment<3>(3)).dot(ln) < 0.0 ? -1.0 : 1.0;
  const Vector3d n = sn * plane.values.segment<3>(3), l = sl * line.values.segment<3>(3);
  const DatumFrame measured = MakeDatumFrame(n, l, kind, where),
                   nominal = MakeDatumFrame(nn, ln, kind, where);
  const Matrix3d& fn = nominal.f;
  a.rotation = fn * measured.f.transpose();
  const Vector3d c = plane.values.head<3>(), al = line.values.head<3>(), p = x.col(point);
  const Vector3d cn = plane_n.values.head<3>(), an = line_n.values.head<3>(), pn = g.positions.col(point);
  const Vector3d q(fn.col(0).dot(pn - a.rotation * p), fn.col(1).dot(an - a.rotation * al),
                   fn.col(2).dot(cn - a.rotation * c));
  a.translation = fn * q;
  a.scale = 1.0;
  const Vector3d n_bar = g.positions.leftCols(k).rowwise().mean();
  a.residuals.resize(3, k);
  double sum = 0.0;
  for (long i = 0; i < k; ++i) {
    a.extent = std::max(a.extent, (g.positions.col(i) - n_bar).norm());
    a.residuals.col(i) = a.rotation * x.col(i) + a.translation - g.positions.col(i);
    sum += a.residuals.col(i).squaredNorm();
  }
  a.rms = std::sqrt(sum / static_cast<double>(k));
  if (!jacobian) return;
  // dtheta/dX, theta = (w, t): R = exp([w]x) R^, so [dw]x = dR R^T = F_n dF_m^T F_m F_n^T.
  a.dtheta_dx = Eigen::MatrixXd::Zero(6, 3 * k);
  const Vector3d rp = a.rotation * p, ra = a.rotation * al, rc = a.rotation * c;
  for (long column = 0; column < 3 * point + 3; ++column) {
    Vector3d dn = Vector3d::Zero(), dl = Vector3d::Zero(), dc = Vector3d::Zero(), da = Vector3d::Zero(),
             dp = Vector3d::Zero();
    if (column < 3 * kp) {
      dn = sn * plane.jacobian.block<3, 1>(3, column);
      dc = plane.jacobian.block<3, 1>(0, column);
    } else if (column < 3 * point) {
      dl = sl * line.jacobian.block<3, 1>(3, column - 3 * kp);
      da = line.jacobian.block<3, 1>(0, column - 3 * kp);
    } else {
      dp(column - 3 * point) = 1.0;
    }
    const Matrix3d skew =
        fn * DatumFrameChange(measured, n, l, dn, dl).transpose() * measured.f * fn.transpose();
    const Vector3d dw(0.5 * (skew(2, 1) - skew(1, 2)), 0.5 * (skew(0, 2) - skew(2, 0)),
                      0.5 * (skew(1, 0) - skew(0, 1)));
    // dq_1 = -e1_n . (dw x R p + R dp), and alike for the line's and the plane's centroids.
    const Vector3d dq(-fn.col(0).dot(dw.cross(rp) + a.rotation * dp),
                      -fn.col(1).dot(dw.cross(ra) + a.rotation * da),
                      -fn.col(2).dot(dw.cross(rc) + a.rotation * dc));
    a.dtheta_dx.block<3, 1>(0, column) = dw;
    a.dtheta_dx.block<3, 1>(3, column) = fn * dq;
  }
}

// The weighted alignment's problem (tasks/weighted.h) in AlignmentSensitivity's chart:
// R = exp([w]x) R^, t = t^ + dt, s = s^ + sigma. The rotation is expanded to second order,
// y + w x y + 1/2 w x (w x y): at w = 0 its value and first and second derivatives are exp's.
template <int P>
struct AlignmentProblem {
  static constexpr int kParams = P, kRows = 3;
  Matrix3d rotation;
  Vector3d translation;
  double scale = 1.0;
  const NominalGeometry* g = nullptr;
  template <class T>
  void Residual(const T* d, long i, const T* x, T* r) const {
    using V = Eigen::Matrix<T, 3, 1>;
    const V w(d[0], d[1], d[2]);
    const V y = rotation.cast<T>() * V(x[0], x[1], x[2]);
    const V wy = w.cross(y);
    const V wwy = w.cross(wy);
    for (int c = 0; c < 3; ++c) {
      const T turned = y(c) + wy(c) + wwy(c) * 0.5;  // scalar by scalar: nested duals take no double vectors
      T part;
      if constexpr (P == 7) {
        part = turned * (d[6] + scale);
      } else {
        part = turned * scale;
      }
      r[c] = part + d[3 + c] + (translation(c) - g->positions(c, i));
    }
  }
  bool Active(long i, int m) const {
    return g->holds.empty() || g->holds[static_cast<std::size_t>(i)][static_cast<std::size_t>(m)];
  }
  void Retract(const Eigen::Matrix<double, P, 1>& d) {
    const Vector3d w = d.template head<3>();
    if (w.norm() > 0.0) rotation = Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix() * rotation;
    translation += d.template segment<3>(3);
    if constexpr (P == 7) scale += d(6);
  }
};

// The alignment weighted by the covariance of its points (the first k of the task's), from the
// ordinary fit (or RPS) in `a`.
template <int P>
void WeightAlignment(const Points& x, const NominalGeometry& g, const FitOptions& options, TaskKind kind,
                     std::string_view where, Alignment& a) {
  const long k = g.alignment_points;
  AlignmentProblem<P> problem{a.rotation, a.translation, a.scale, &g};
  FitOptions leading = options;
  if (options.weights == nullptr && k < x.cols())
    leading.covariance = std::make_shared<const PointCovariance>(LeadingPoints(*options.covariance, k));
  const WeightedSolution s = SolveWeighted(problem, x.leftCols(k), leading, kind, where);
  a.rotation = problem.rotation;
  a.translation = problem.translation;
  a.scale = problem.scale;
  if (!(a.scale > 0.0)) Fail(where, kind, "the weighted fit's scale is not positive");
  UpdateResiduals(x, g, k, a);
  a.dtheta_dx = s.dtheta_dx;
  a.weights = s.weights;
  a.chi2 = s.chi2;
  a.degrees_of_freedom = static_cast<int>(s.residuals.size()) - P;
}

Alignment Align(const Points& x, const NominalGeometry& g, const FitOptions& options, TaskKind kind,
                std::string_view where) {
  Alignment a;
  const long k = g.alignment_points;
  for (long i = 0; i < x.cols(); ++i) {
    if (!x.col(i).allFinite())
      Fail(where, kind, "point " + std::to_string(i) + " has a non-finite coordinate");
  }
  if (!g.holds.empty() && static_cast<long>(g.holds.size()) != k) {
    throw InputError(std::string(where) + ": rps: one set of held axes per alignment point");
  }
  if (g.plane_points > 0) {
    if (g.scale || !g.holds.empty())
      throw InputError(std::string(where) + ": features: no scale, no held axes");
    if (Weighted(options)) CheckWeightable(TaskKind::kFeatures, where);
    FitDatumFeatures(x, g, options.jacobian, kind, where, a);
    return a;
  }
  FitTransform(x, g.positions, k, g.scale, kind, where, a);
  if (!g.holds.empty()) FitReferencePointSystem(x, g, k, kind, where, a);
  if (Weighted(options)) {
    if (g.scale) {
      WeightAlignment<7>(x, g, options, kind, where, a);
    } else {
      WeightAlignment<6>(x, g, options, kind, where, a);
    }
  } else if (options.jacobian) {
    AlignmentSensitivity(x, g, k, kind, where, a);
  }
  return a;
}

// d = s R x_P + t - n_P of task point `point` in the aligned part frame.
Vector3d DeviationOf(const Points& x, const NominalGeometry& g, const Alignment& a, long point) {
  return a.scale * a.rotation * x.col(point) + a.translation - g.positions.col(point);
}

// dd/dX (3 x 3N): d = s exp([w]x) R^ x_P + t - n_P, so dd/dw = -s [y]x, dd/dt = I,
// dd/dsigma = y (y = R^ x_P) through the alignment's dtheta/dX, plus s R^ in P's own columns.
Eigen::MatrixXd DeviationJacobian(const Points& x, const NominalGeometry& g, const Alignment& a, long point) {
  const Vector3d y = a.rotation * x.col(point);
  Eigen::MatrixXd dd_dtheta(3, g.scale ? 7 : 6);
  dd_dtheta.leftCols<3>() = -a.scale * Hat(y);
  dd_dtheta.middleCols<3>(3) = Matrix3d::Identity();
  if (g.scale) dd_dtheta.col(6) = y;
  Eigen::MatrixXd dd_dx = Eigen::MatrixXd::Zero(3, 3 * x.cols());
  dd_dx.leftCols(3 * g.alignment_points) = dd_dtheta * a.dtheta_dx;
  dd_dx.middleCols<3>(3 * point) += a.scale * a.rotation;
  return dd_dx;
}

// Fixed-axis angles of R = Rz(c) Ry(b) Rx(a).
Vector3d CardanAngles(const Matrix3d& r) {
  return {std::atan2(r(2, 1), r(2, 2)), std::atan2(-r(2, 0), std::hypot(r(0, 0), r(1, 0))),
          std::atan2(r(1, 0), r(0, 0))};
}

// d(a, b, c) / dw for a rotation dR = [dw]x R on the left: dw = c' e_z + b' Rz e_y + a' Rz Ry e_x, so
// the angle rates are E^-1 dw with E = [Rz Ry e_x, Rz e_y, e_z].
Matrix3d AnglesFromLeftRotation(const Vector3d& angles) {
  const double cb = std::cos(angles(1)), sb = std::sin(angles(1)), cc = std::cos(angles(2)),
               sc = std::sin(angles(2));
  Matrix3d e;
  e.col(0) << cc * cb, sc * cb, -sb;
  e.col(1) << -sc, cc, 0.0;
  e.col(2) << 0.0, 0.0, 1.0;
  return e.inverse();
}

}  // namespace

std::span<const TaskOutput> AlignmentOutputs(TaskKind kind) {
  switch (kind) {
    case TaskKind::kBestFit:
    case TaskKind::kRps:
    case TaskKind::kFeatures: return kBestFitOutputs;
    case TaskKind::kBestFitScale: return kBestFitScaleOutputs;
    case TaskKind::kDeviation: return kDeviationOutputs;
    case TaskKind::kPosition: return kPositionOutputs;
    case TaskKind::kProfile: return kProfileOutputs;
    default: return {};
  }
}

}  // namespace tasks_internal

namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

FitResult MakeAlignmentResult(TaskKind kind, long num_points, const FitOptions& options,
                              const tasks_internal::Alignment& a) {
  FitResult r;
  r.weights = a.weights;
  r.chi2 = a.chi2;
  r.degrees_of_freedom = a.degrees_of_freedom;
  r.kind = kind;
  r.outputs = tasks_internal::AlignmentOutputs(kind);
  const long k = static_cast<long>(r.outputs.size());
  r.values = Eigen::VectorXd::Zero(k);
  r.differentiable.assign(static_cast<std::size_t>(k), true);
  if (options.jacobian) r.jacobian = Eigen::MatrixXd::Zero(k, 3 * num_points);
  return r;
}

// An angle taken within pi of its reference (Monte Carlo trials of a rotation near +-180 degrees
// must not jump by 2 pi between trials).
double Near(double angle, double reference) {
  constexpr double kTurn = 2.0 * std::numbers::pi;
  return angle + kTurn * std::round((reference - angle) / kTurn);
}

}  // namespace

FitResult FitBestFit(const Eigen::Ref<const Eigen::Matrix3Xd>& points, const FitOptions& options,
                     std::string_view where) {
  using namespace tasks_internal;
  const long n = points.cols();
  const bool rps = options.nominal && !options.nominal->holds.empty();
  const bool features = options.nominal && options.nominal->plane_points > 0;
  const TaskKind kind = features                                    ? TaskKind::kFeatures
                        : rps                                       ? TaskKind::kRps
                        : options.nominal && options.nominal->scale ? TaskKind::kBestFitScale
                                                                    : TaskKind::kBestFit;
  const NominalGeometry& g = Nominal(options, kind, n, where);
  if (g.alignment_points != n)
    throw InputError(std::string(where) + ": " + std::string(TaskKindName(kind)) +
                     ": every point is an alignment point");
  if (rps && g.scale) throw InputError(std::string(where) + ": rps: a reference point system fits no scale");
  const Alignment a = Align(points, g, options, kind, where);
  const bool weighted = Weighted(options);
  Vector3d angles = CardanAngles(a.rotation);
  if (!(std::abs(std::cos(angles(1))) > kGimbalLock)) {
    Fail(where, kind,
         "the rotation about y is +-90 degrees: rx and rz turn about the same axis (undetermined)");
  }
  if (options.reference_angles) {
    for (int c = 0; c < 3; ++c) angles(c) = Near(angles(c), (*options.reference_angles)(c));
  }
  FitResult result = MakeAlignmentResult(kind, n, options, a);
  constexpr int rms_row = 6, scale_row = 7;
  result.values.head<3>() = a.translation;
  result.values.segment<3>(3) = angles;
  result.values(rms_row) = a.rms;
  if (g.scale) result.values(scale_row) = a.scale;
  const bool exact = a.rms <= kExactFit * a.extent;
  result.differentiable[static_cast<std::size_t>(rms_row)] = !exact;
  if (!options.jacobian) return result;
  // Outputs from theta = (w, t[, sigma]): t and s directly, the angles through the left rotation w.
  const Matrix3d angle_rates = AnglesFromLeftRotation(angles);
  const double divisor = RmsDivisor(g, n);
  for (long j = 0; j < n; ++j) {
    auto block = result.jacobian.middleCols<3>(3 * j);
    const auto dtheta = a.dtheta_dx.middleCols(3 * j, 3);
    block.topRows<3>() = dtheta.middleRows(3, 3);
    block.middleRows<3>(3) = angle_rates * dtheta.topRows(3);
    if (g.scale) block.row(scale_row) = dtheta.row(6);
    // rms: envelope theorem, d(sum r^T W r)/dx_j = 2 s (W r_j)^T R at the optimum.
    if (!exact && !features && !weighted)
      block.row(rms_row) =
          a.scale * (Weight(g, j) * a.residuals.col(j)).transpose() * a.rotation / (divisor * a.rms);
  }
  // Datum features and weighted fits: the residuals' sum of squares is not at its optimum, so
  // d rms = sum_i (W_i r_i)^T (-s [R x_i]x dw + dt + R x_i dsigma + s R dx_i) / (divisor rms).
  if ((features || weighted) && !exact) {
    const int p = g.scale ? 7 : 6;
    Eigen::RowVectorXd row = Eigen::RowVectorXd::Zero(3 * n);
    for (long i = 0; i < n; ++i) {
      const Vector3d rho = Weight(g, i) * a.residuals.col(i);
      const Vector3d y = a.rotation * points.col(i);
      Eigen::MatrixXd dr_dtheta(3, p);
      dr_dtheta.leftCols<3>() = -a.scale * Hat(y);
      dr_dtheta.middleCols<3>(3) = Matrix3d::Identity();
      if (g.scale) dr_dtheta.col(6) = y;
      row += rho.transpose() * dr_dtheta * a.dtheta_dx;
      row.segment<3>(3 * i) += a.scale * rho.transpose() * a.rotation;
    }
    result.jacobian.row(rms_row) = row / (divisor * a.rms);
  }
  return result;
}

FitResult FitDeviation(const Eigen::Ref<const Eigen::Matrix3Xd>& points, const FitOptions& options,
                       std::string_view where) {
  using namespace tasks_internal;
  const long n = points.cols();
  const TaskKind kind =
      options.nominal && options.nominal->position ? TaskKind::kPosition : TaskKind::kDeviation;
  const NominalGeometry& g = Nominal(options, kind, n, where);
  if (g.point < 0 || g.point >= n || !(std::abs(g.normal.norm() - 1.0) < 1e-9)) {
    throw InputError(std::string(where) + ": deviation: needs its point and the unit normal of its nominal");
  }
  const Alignment a = Align(points, g, options, kind, where);
  const Vector3d d = DeviationOf(points, g, a, g.point);
  const Vector3d& normal = g.normal;
  const Vector3d lateral = d - d.dot(normal) * normal;
  const double position = 2.0 * lateral.norm();
  FitResult result = MakeAlignmentResult(kind, n, options, a);
  result.values.head<4>() << d.dot(normal), d;
  const bool exact = lateral.norm() <= kExactFit * std::max(a.extent, 1.0);
  if (g.position) {
    result.values(4) = position;
    result.differentiable[4] = !exact;
  }
  if (!options.jacobian) return result;
  const Eigen::MatrixXd dd_dx = DeviationJacobian(points, g, a, g.point);
  result.jacobian.row(0) = normal.transpose() * dd_dx;
  result.jacobian.middleRows<3>(1) = dd_dx;
  if (g.position && !exact) result.jacobian.row(4) = 2.0 * lateral.normalized().transpose() * dd_dx;
  return result;
}

FitResult FitProfile(const Eigen::Ref<const Eigen::Matrix3Xd>& points, const FitOptions& options,
                     std::string_view where) {
  using namespace tasks_internal;
  const long n = points.cols();
  const TaskKind kind = TaskKind::kProfile;
  const NominalGeometry& g = Nominal(options, kind, n, where);
  if (g.profile.empty() || g.profile.size() != g.profile_normals.size()) {
    throw InputError(std::string(where) + ": profile: needs its points and the unit normal of each");
  }
  const Alignment a = Align(points, g, options, kind, where);
  // The extremes, ties to the first point reaching them (one-sided derivatives, as flatness).
  std::size_t low = 0, high = 0;
  std::vector<double> deviation(g.profile.size());
  for (std::size_t i = 0; i < g.profile.size(); ++i) {
    if (g.profile[i] < 0 || g.profile[i] >= n)
      throw InputError(std::string(where) + ": profile: a point index out of range");
    deviation[i] = g.profile_normals[i].dot(DeviationOf(points, g, a, g.profile[i]));
    if (deviation[i] < deviation[low]) low = i;
    if (deviation[i] > deviation[high]) high = i;
  }
  const bool high_wider = std::abs(deviation[high]) >= std::abs(deviation[low]);
  const std::size_t widest = high_wider ? high : low;
  FitResult result = MakeAlignmentResult(kind, n, options, a);
  result.values << deviation[low], deviation[high], 2.0 * std::abs(deviation[widest]);
  const bool exact = std::abs(deviation[widest]) <= kExactFit * std::max(a.extent, 1.0);
  result.differentiable[2] = !exact;
  if (!options.jacobian) return result;
  auto row = [&](std::size_t i) {
    return Eigen::RowVectorXd(g.profile_normals[i].transpose() *
                              DeviationJacobian(points, g, a, g.profile[i]));
  };
  result.jacobian.row(0) = row(low);
  result.jacobian.row(1) = row(high);
  if (!exact) result.jacobian.row(2) = (deviation[widest] < 0.0 ? -2.0 : 2.0) * row(widest);
  return result;
}

}  // namespace vlt
