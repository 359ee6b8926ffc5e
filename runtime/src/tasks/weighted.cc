// tasks/weighted.cc — the weights of a covariance-weighted fit and the weighted plane, line,
// sphere, circle, cylinder and cone (tasks/weighted.h; docs/tasks.md "Fits weighted by the points'
// covariance"). Each starts from the ordinary fit of the same points and keeps its outputs'
// definitions and sign conventions (vlt/fits.h), with two differences that the weighting forces:
// the point of a plane or line is the centroid's foot on the fitted feature (the weighted feature
// need not pass through the centroid), and a circle is one fit of both residuals of each point
// (out of its plane and radial in it), not a plane and then a circle.
#include "tasks/weighted.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "vlt/error.h"

namespace vlt {

namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;
template <class T>
using V3 = Eigen::Matrix<T, 3, 1>;

// Smallest eigenvalue of a symmetric matrix relative to its largest: above this it is positive
// definite for the factorisations here (1e-12: a standard uncertainty 1e-6 of the largest).
constexpr double kDefinite = 1e-12;

bool PositiveDefinite(const Eigen::MatrixXd& m) {
  if (m.size() == 0) return false;
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(m, Eigen::EigenvaluesOnly);
  const Eigen::VectorXd& l = eig.eigenvalues();
  return l(0) > kDefinite * l(l.size() - 1) && l(l.size() - 1) > 0.0;
}

}  // namespace

FitWeights::FitWeights(const PointCovariance& v, const std::vector<Eigen::MatrixXd>& d,
                       const Eigen::Vector3d& reference, TaskKind kind, std::string_view where)
    : reference_(reference) {
  using tasks_internal::Fail;
  const long n = static_cast<long>(d.size());
  offsets_.assign(static_cast<std::size_t>(n) + 1, 0);
  for (long i = 0; i < n; ++i)
    offsets_[static_cast<std::size_t>(i) + 1] =
        offsets_[static_cast<std::size_t>(i)] + d[static_cast<std::size_t>(i)].rows();
  const long rows = offsets_.back();
  const bool has_dense = v.dense.size() > 0;
  if (has_dense
          ? v.dense.rows() != 3 * n || v.dense.cols() != 3 * n
          : static_cast<long>(v.blocks.size()) != n || (v.shared.size() > 0 && v.shared.rows() != 3 * n)) {
    throw std::invalid_argument("FitWeights: the covariance is not of the fit's points");
  }
  auto begin = [&](long i) { return offsets_[static_cast<std::size_t>(i)]; };
  auto count = [&](long i) { return d[static_cast<std::size_t>(i)].rows(); };
  // M = D L (rows x r): each point's rows times its three rows of the shared factor.
  const long r = has_dense ? 0 : v.shared.cols();
  Eigen::MatrixXd m(rows, r);
  for (long i = 0; i < n && r > 0; ++i)
    m.middleRows(begin(i), count(i)) = d[static_cast<std::size_t>(i)] * v.shared.middleRows(3 * i, 3);

  dense_ = has_dense;
  if (!dense_) {
    block_inverse_.resize(static_cast<std::size_t>(n));
    for (long i = 0; i < n && !dense_; ++i) {
      const Eigen::MatrixXd& di = d[static_cast<std::size_t>(i)];
      const Eigen::MatrixXd block = di * v.blocks[static_cast<std::size_t>(i)] * di.transpose();
      if (!PositiveDefinite(block)) {
        dense_ = true;  // a point without its own noise along a residual: factor V_d whole
        break;
      }
      block_inverse_[static_cast<std::size_t>(i)] =
          block.llt().solve(Eigen::MatrixXd::Identity(count(i), count(i)));
    }
  }
  if (dense_) {
    block_inverse_.clear();
    if (rows > kDenseRows) {
      Fail(where, kind,
           has_dense ? "a weighted fit with a joint covariance of the points is limited to " +
                           std::to_string(kDenseRows) + " residuals (it has " + std::to_string(rows) + ")"
                     : "a weighted fit of " + std::to_string(rows) +
                           " residuals needs each point's own covariance to be positive definite along its "
                           "residuals "
                           "(it is not)");
    }
    Eigen::MatrixXd vd = Eigen::MatrixXd::Zero(rows, rows);
    for (long i = 0; i < n; ++i) {
      const Eigen::MatrixXd& di = d[static_cast<std::size_t>(i)];
      if (has_dense) {
        for (long j = 0; j < n; ++j) {
          vd.block(begin(i), begin(j), count(i), count(j)) =
              di * v.dense.block<3, 3>(3 * i, 3 * j) * d[static_cast<std::size_t>(j)].transpose();
        }
      } else {
        vd.block(begin(i), begin(i), count(i), count(i)) =
            di * v.blocks[static_cast<std::size_t>(i)] * di.transpose();
      }
    }
    if (r > 0) vd.noalias() += m * m.transpose();
    vd = 0.5 * (vd + vd.transpose());
    if (!PositiveDefinite(vd)) {
      Fail(where, kind,
           "the covariance of the fit's residuals is singular: the points' covariance cannot weight it");
    }
    dense_factor_.compute(vd);
    return;
  }
  delta_inverse_m_.resize(rows, r);
  for (long i = 0; i < n && r > 0; ++i)
    delta_inverse_m_.middleRows(begin(i), count(i)) =
        block_inverse_[static_cast<std::size_t>(i)] * m.middleRows(begin(i), count(i));
  if (r > 0) {
    Eigen::MatrixXd capacitance = Eigen::MatrixXd::Identity(r, r);
    capacitance.noalias() += m.transpose() * delta_inverse_m_;
    capacitance_.compute(capacitance);
    if (capacitance_.info() != Eigen::Success)
      Fail(where, kind, "the residuals' covariance could not be factored");
  }
}

Eigen::MatrixXd FitWeights::Apply(const Eigen::MatrixXd& a) const {
  if (dense_) return dense_factor_.solve(a);
  Eigen::MatrixXd y(a.rows(), a.cols());
  for (std::size_t i = 0; i + 1 < offsets_.size(); ++i) {
    const long b = offsets_[i], c = offsets_[i + 1] - offsets_[i];
    y.middleRows(b, c).noalias() = block_inverse_[i] * a.middleRows(b, c);
  }
  if (delta_inverse_m_.cols() > 0) {
    const Eigen::MatrixXd t = capacitance_.solve(delta_inverse_m_.transpose() * a);
    y.noalias() -= delta_inverse_m_ * t;
  }
  return y;
}

namespace tasks_internal {

PointCovariance LeadingPoints(const PointCovariance& v, long k) {
  PointCovariance out;
  if (v.dense.size() > 0) {
    out.dense = v.dense.topLeftCorner(3 * k, 3 * k);
    return out;
  }
  out.blocks.assign(v.blocks.begin(), v.blocks.begin() + k);
  if (v.shared.size() > 0) out.shared = v.shared.topRows(3 * k);
  return out;
}

}  // namespace tasks_internal

namespace {

using tasks_internal::Fail;
using tasks_internal::SolveWeighted;
using tasks_internal::WeightedSolution;
using Points = Eigen::Ref<const Eigen::Matrix3Xd>;

// Two unit vectors completing unit n to a right-handed orthonormal basis.
void CompleteBasis(const Vector3d& n, Vector3d& u, Vector3d& v) {
  int k = 0;
  for (int c = 1; c < 3; ++c) {
    if (std::abs(n(c)) < std::abs(n(k))) k = c;
  }
  u = n.cross(Vector3d::Unit(k)).normalized();
  v = n.cross(u);
}

// A unit vector near n0 (chart: n0 + a u + b v, normalised).
struct DirectionChart {
  Vector3d n0, u, v;
  explicit DirectionChart(const Vector3d& n) : n0(n.normalized()) { CompleteBasis(n0, u, v); }
  template <class T>
  V3<T> At(const T& a, const T& b) const {
    using std::sqrt;
    const V3<T> w = n0.cast<T>() + u.cast<T>() * a + v.cast<T>() * b;
    return w / sqrt(w.dot(w));
  }
  void Move(double a, double b) { *this = DirectionChart(At(a, b)); }
};

template <class T>
V3<T> Point(const T* x) {
  return V3<T>(x[0], x[1], x[2]);
}

// --- The features. Each: kParams, kRows, Residual, Active, Retract, Geometry (the outputs that
// are not residual statistics, from delta and the centroid of the points).

struct PlaneProblem {  // r = n . (x - c0) - h
  static constexpr int kParams = 3, kRows = 1, kGeometry = 6;
  DirectionChart normal;
  Vector3d c0;
  template <class T>
  void Residual(const T* d, long, const T* x, T* r) const {
    r[0] = normal.At(d[0], d[1]).dot(Point(x) - c0.cast<T>()) - d[2];
  }
  bool Active(long, int) const { return true; }
  void Retract(const Eigen::Matrix<double, 3, 1>& d) {
    normal.Move(d(0), d(1));
    c0 += d(2) * normal.n0;
  }
  // The centroid's foot on the plane, the normal.
  template <class T>
  void Geometry(const T* d, const T* centroid, T* out) const {
    const V3<T> n = normal.At(d[0], d[1]);
    const V3<T> g = Point(centroid);
    const V3<T> foot = g - (n.dot(g - c0.cast<T>()) - d[2]) * n;
    for (int c = 0; c < 3; ++c) out[c] = foot(c), out[3 + c] = n(c);
  }
};

// An axis near e0 through a point near c0 (the point moves across the axis): line, cylinder, cone.
struct AxisChart {
  DirectionChart direction;
  Vector3d c0;
  template <class T>
  V3<T> Direction(const T* d) const {
    return direction.At(d[0], d[1]);
  }
  template <class T>
  V3<T> Through(const T* d) const {
    return c0.cast<T>() + direction.u.cast<T>() * d[2] + direction.v.cast<T>() * d[3];
  }
  void Move(const double* d) {
    c0 += d[2] * direction.u + d[3] * direction.v;
    direction.Move(d[0], d[1]);
  }
  // The foot of point g on the axis.
  template <class T>
  V3<T> Foot(const T* d, const V3<T>& g) const {
    const V3<T> e = Direction(d), q = Through(d);
    return q + e * e.dot(g - q);
  }
};

struct LineProblem {  // r = the two components of (x - q) across e
  static constexpr int kParams = 4, kRows = 2, kGeometry = 6;
  AxisChart axis;
  // The basis of the two rows across e: u = reference less its component along e, then e x u. Held
  // through the iterations and, by FitWeights::reference, across every fit with the same weights (a
  // basis rebuilt from each direction would turn by 90 degrees where the direction's two smallest
  // components swap, and the 2 x 2 weights would then weight the wrong rows).
  Vector3d reference;
  template <class T>
  void Residual(const T* d, long, const T* x, T* r) const {
    using std::sqrt;
    const V3<T> e = axis.Direction(d);
    V3<T> u = reference.cast<T>() - e * e.dot(reference.cast<T>());
    u = u / sqrt(u.dot(u));
    const V3<T> v = e.cross(u);
    const V3<T> a = Point(x) - axis.Through(d);
    r[0] = u.dot(a);
    r[1] = v.dot(a);
  }
  bool Active(long, int) const { return true; }
  void Retract(const Eigen::Matrix<double, 4, 1>& d) { axis.Move(d.data()); }
  template <class T>
  void Geometry(const T* d, const T* centroid, T* out) const {
    const V3<T> foot = axis.Foot(d, Point(centroid)), e = axis.Direction(d);
    for (int c = 0; c < 3; ++c) out[c] = foot(c), out[3 + c] = e(c);
  }
};

struct SphereProblem {  // r = |x - c| - R
  static constexpr int kParams = 4, kRows = 1, kGeometry = 4;
  Vector3d c0;
  double radius = 0.0;
  template <class T>
  void Residual(const T* d, long, const T* x, T* r) const {
    using std::sqrt;
    const V3<T> a = Point(x) - c0.cast<T>() - Point(d);
    r[0] = sqrt(a.dot(a)) - (radius + d[3]);
  }
  bool Active(long, int) const { return true; }
  void Retract(const Eigen::Matrix<double, 4, 1>& d) {
    c0 += d.head<3>();
    radius += d(3);
  }
  template <class T>
  void Geometry(const T* d, const T*, T* out) const {
    for (int c = 0; c < 3; ++c) out[c] = c0(c) + d[c];
    out[3] = radius + d[3];
  }
};

struct CircleProblem {  // r = (n . (x - c), |across n| - R)
  static constexpr int kParams = 6, kRows = 2, kGeometry = 7;
  DirectionChart normal;
  Vector3d c0;
  double radius = 0.0;
  template <class T>
  void Residual(const T* d, long, const T* x, T* r) const {
    using std::sqrt;
    const V3<T> n = normal.At(d[0], d[1]);
    const V3<T> a = Point(x) - c0.cast<T>() - Point(d + 2);
    const T w = n.dot(a);
    const V3<T> across = a - w * n;
    r[0] = w;
    r[1] = sqrt(across.dot(across)) - (radius + d[5]);
  }
  bool Active(long, int) const { return true; }
  void Retract(const Eigen::Matrix<double, 6, 1>& d) {
    normal.Move(d(0), d(1));
    c0 += d.segment<3>(2);
    radius += d(5);
  }
  // centre, radius, normal (the order of kCircleOutputs).
  template <class T>
  void Geometry(const T* d, const T*, T* out) const {
    const V3<T> n = normal.At(d[0], d[1]);
    for (int c = 0; c < 3; ++c) out[c] = c0(c) + d[2 + c], out[4 + c] = n(c);
    out[3] = radius + d[5];
  }
};

struct CylinderProblem {  // r = distance from the axis - R
  static constexpr int kParams = 5, kRows = 1, kGeometry = 7;
  AxisChart axis;
  double radius = 0.0;
  template <class T>
  void Residual(const T* d, long, const T* x, T* r) const {
    using std::sqrt;
    const V3<T> e = axis.Direction(d);
    const V3<T> a = Point(x) - axis.Through(d);
    const V3<T> across = a - e * e.dot(a);
    r[0] = sqrt(across.dot(across)) - (radius + d[4]);
  }
  bool Active(long, int) const { return true; }
  void Retract(const Eigen::Matrix<double, 5, 1>& d) {
    axis.Move(d.data());
    radius += d(4);
  }
  template <class T>
  void Geometry(const T* d, const T* centroid, T* out) const {
    const V3<T> foot = axis.Foot(d, Point(centroid)), e = axis.Direction(d);
    for (int c = 0; c < 3; ++c) out[c] = foot(c), out[3 + c] = e(c);
    out[6] = radius + d[4];
  }
};

struct ConeProblem {  // r = (rho - R - t tan psi) cos psi about the axis point q
  static constexpr int kParams = 6, kRows = 1, kGeometry = 8;
  AxisChart axis;
  double radius = 0.0, half_angle = 0.0;
  template <class T>
  void Residual(const T* d, long, const T* x, T* r) const {
    using std::cos;
    using std::sqrt;
    using std::tan;
    const V3<T> e = axis.Direction(d);
    const V3<T> a = Point(x) - axis.Through(d);
    const T t = e.dot(a);
    const V3<T> across = a - e * t;
    const T psi = half_angle + d[5];
    r[0] = (sqrt(across.dot(across)) - (radius + d[4]) - t * tan(psi)) * cos(psi);
  }
  bool Active(long, int) const { return true; }
  void Retract(const Eigen::Matrix<double, 6, 1>& d) {
    axis.Move(d.data());
    radius += d(4);
    half_angle += d(5);
  }
  // The axis point nearest the centroid, the direction, the radius there, the half-angle.
  template <class T>
  void Geometry(const T* d, const T* centroid, T* out) const {
    using std::tan;
    const V3<T> e = axis.Direction(d), q = axis.Through(d);
    const T along = e.dot(Point(centroid) - q);
    const V3<T> foot = q + e * along;
    const T psi = half_angle + d[5];
    for (int c = 0; c < 3; ++c) out[c] = foot(c), out[3 + c] = e(c);
    out[6] = radius + d[4] + along * tan(psi);
    out[7] = psi;
  }
};

// The geometric outputs and their Jacobian (G x 3N): through delta (dtheta/dx) and, for the
// centroid, each point's 1/N share.
template <class Problem>
void GeometryOutputs(const Problem& problem, const Points& x, const WeightedSolution& s, bool jacobian,
                     FitResult& result) {
  constexpr int P = Problem::kParams, G = Problem::kGeometry, K = P + 3;
  using D = tasks_internal::weighted_detail::Dual<K>;
  const long n = x.cols();
  const Vector3d centroid = x.rowwise().mean();
  D delta[P], g[3], out[G];
  for (int a = 0; a < P; ++a) delta[a] = D(0.0, K, a);
  for (int c = 0; c < 3; ++c) g[c] = D(centroid(c), K, P + c);
  problem.Geometry(delta, g, out);
  for (int q = 0; q < G; ++q) result.values(q) = out[q].value();
  if (!jacobian) return;
  for (int q = 0; q < G; ++q) {
    const Eigen::Matrix<double, K, 1> grad = out[q].derivatives();
    Eigen::RowVectorXd row = grad.template head<P>().transpose() * s.dtheta_dx;
    for (long j = 0; j < n; ++j)
      row.segment<3>(3 * j) += grad.template tail<3>().transpose() / static_cast<double>(n);
    result.jacobian.row(q) = row;
  }
}

// d residual row / dX (1 x 3N) at the solution.
Eigen::RowVectorXd ResidualRow(const WeightedSolution& s, long row, long point) {
  Eigen::RowVectorXd out = s.dr_dtheta.row(row) * s.dtheta_dx;
  out.segment<3>(3 * point) += s.dr_dx.row(row);
  return out;
}

// The form outputs from the residuals: `span_row` (max - min of a one-row residual, or 2 max |r_i|
// of a two-row one when `across` is true), then rms over row `rms_row` of each point (-1: all rows).
void FormOutputs(const WeightedSolution& s, long n, int rows_per_point, int span_output, bool across,
                 int rms_output, int rms_row, double extent, bool jacobian, FitResult& result) {
  constexpr double kExactFit = 1e-10;
  auto row_of = [&](long i, int m) { return s.offsets[static_cast<std::size_t>(i)] + m; };
  if (span_output >= 0) {
    long low = 0, high = 0;
    std::vector<double> size(static_cast<std::size_t>(n));
    for (long i = 0; i < n; ++i) {
      size[static_cast<std::size_t>(i)] =
          across ? s.residuals.segment(row_of(i, 0), rows_per_point).norm() : s.residuals(row_of(i, 0));
      if (size[static_cast<std::size_t>(i)] < size[static_cast<std::size_t>(low)]) low = i;
      if (size[static_cast<std::size_t>(i)] > size[static_cast<std::size_t>(high)]) high = i;
    }
    const double value = across ? 2.0 * size[static_cast<std::size_t>(high)]
                                : size[static_cast<std::size_t>(high)] - size[static_cast<std::size_t>(low)];
    result.values(span_output) = value;
    const bool exact = value <= kExactFit * extent;
    result.differentiable[static_cast<std::size_t>(span_output)] = !exact;
    if (jacobian && !exact) {
      if (across) {
        const Eigen::VectorXd r = s.residuals.segment(row_of(high, 0), rows_per_point);
        Eigen::RowVectorXd row = Eigen::RowVectorXd::Zero(3 * n);
        for (int m = 0; m < rows_per_point; ++m) row += r(m) * ResidualRow(s, row_of(high, m), high);
        result.jacobian.row(span_output) = 2.0 * row / r.norm();
      } else {
        result.jacobian.row(span_output) =
            ResidualRow(s, row_of(high, 0), high) - ResidualRow(s, row_of(low, 0), low);
      }
    }
  }
  double sum = 0.0;
  for (long i = 0; i < n; ++i) {
    for (int m = 0; m < rows_per_point; ++m) {
      if (rms_row >= 0 && m != rms_row) continue;
      sum += s.residuals(row_of(i, m)) * s.residuals(row_of(i, m));
    }
  }
  const double rms = std::sqrt(sum / static_cast<double>(n));
  result.values(rms_output) = rms;
  const bool exact = rms <= kExactFit * extent;
  result.differentiable[static_cast<std::size_t>(rms_output)] = !exact;
  if (!jacobian || exact) return;
  // rms = sqrt(sum r^2 / N): d rms = sum r dr / (N rms) (no envelope theorem: the weighted fit
  // does not minimise sum r^2).
  Eigen::RowVectorXd row = Eigen::RowVectorXd::Zero(3 * n);
  for (long i = 0; i < n; ++i) {
    for (int m = 0; m < rows_per_point; ++m) {
      if (rms_row >= 0 && m != rms_row) continue;
      row += s.residuals(row_of(i, m)) * ResidualRow(s, row_of(i, m), i);
    }
  }
  result.jacobian.row(rms_output) = row / (static_cast<double>(n) * rms);
}

// Largest distance of a point from the centroid: the size that "exact fit" is relative to.
double Extent(const Points& x) {
  const Vector3d centroid = x.rowwise().mean();
  return (x.colwise() - centroid).colwise().norm().maxCoeff();
}

template <class Problem>
FitResult Solve(TaskKind kind, Problem problem, const Points& x, const FitOptions& options, int span_output,
                bool across, int rms_output, int rms_row, std::string_view where) {
  const WeightedSolution s = SolveWeighted(problem, x, options, kind, where);
  FitResult result = tasks_internal::MakeResult(kind, x.cols(), options);
  GeometryOutputs(problem, x, s, options.jacobian, result);
  FormOutputs(s, x.cols(), Problem::kRows, span_output, across, rms_output, rms_row, Extent(x),
              options.jacobian, result);
  result.weights = s.weights;
  result.chi2 = s.chi2;
  result.degrees_of_freedom = static_cast<int>(s.residuals.size()) - Problem::kParams;
  result.iterations = s.iterations;
  if (!result.values.allFinite()) Fail(where, kind, "the weighted fit has no finite result");
  return result;
}

}  // namespace

bool Weightable(TaskKind kind) {
  switch (kind) {
    case TaskKind::kPlane:
    case TaskKind::kSphere:
    case TaskKind::kCircle:
    case TaskKind::kLine:
    case TaskKind::kCylinder:
    case TaskKind::kCone:
    case TaskKind::kBestFit:
    case TaskKind::kBestFitScale:
    case TaskKind::kRps:
    case TaskKind::kDeviation:
    case TaskKind::kPosition:
    case TaskKind::kProfile: return true;
    default: return false;
  }
}

namespace tasks_internal {

void CheckWeightable(TaskKind kind, std::string_view where) {
  if (!Weightable(kind)) {
    throw InputError(
        std::string(where) + ": " + std::string(TaskKindName(kind)) +
        ": only a least-squares fit can be weighted by the points' covariance (plane, sphere, "
        "circle, line, cylinder, cone, best_fit, rps and the deviations and profiles over them)");
  }
}

FitResult FitWeightedFeature(TaskKind kind, const Points& points, const FitOptions& options,
                             std::string_view where) {
  // The ordinary fit of the same points: the start, the orientation of normals and directions.
  FitOptions ordinary = options;
  ordinary.jacobian = false;
  ordinary.covariance = nullptr;
  ordinary.weights = nullptr;
  const FitResult start = FitTask(kind, points, ordinary, where);
  const Eigen::VectorXd& v = start.values;
  switch (kind) {
    case TaskKind::kPlane: {
      PlaneProblem p{DirectionChart(v.segment<3>(3)), v.head<3>()};
      return Solve(kind, p, points, options, 6, false, 7, -1, where);
    }
    case TaskKind::kLine: {
      const DirectionChart direction(v.segment<3>(3));
      LineProblem p{AxisChart{direction, v.head<3>()}, direction.u};
      return Solve(kind, p, points, options, 6, true, 7, -1, where);
    }
    case TaskKind::kSphere: {
      SphereProblem p{v.head<3>(), v(3)};
      return Solve(kind, p, points, options, -1, false, 4, -1, where);
    }
    case TaskKind::kCircle: {
      CircleProblem p{DirectionChart(v.segment<3>(4)), v.head<3>(), v(3)};
      return Solve(kind, p, points, options, -1, false, 7, 1, where);
    }
    case TaskKind::kCylinder: {
      CylinderProblem p{AxisChart{DirectionChart(v.segment<3>(3)), v.head<3>()}, v(6)};
      return Solve(kind, p, points, options, 7, false, 8, -1, where);
    }
    case TaskKind::kCone: {
      ConeProblem p{AxisChart{DirectionChart(v.segment<3>(3)), v.head<3>()}, v(6), v(7)};
      return Solve(kind, p, points, options, 8, false, 9, -1, where);
    }
    default: break;
  }
  Fail(where, kind, "not a weighted feature (plane, sphere, circle, line, cylinder, cone)");
}

}  // namespace tasks_internal
}  // namespace vlt
