// tasks/minimum_zone.cc — form by the minimum-zone (Chebyshev) definition: the narrowest zone of
// the feature's kind that holds every point (ISO 1101; ISO 12781-1 flatness, 12780-1 straightness,
// 12181-1 roundness, 12180-1 cylindricity), by sequential linear programming from the least-squares
// feature (docs/tasks.md "Form by minimum zone").
//
// Each step linearises the points' distances d_i(theta) from the feature about the current one and
// solves, with Clp (COIN-OR's simplex), the linear program of the zone within a trust region:
//     min t_hi - t_lo,  t_lo <= d_i + g_i s <= t_hi  (flatness, roundness, cylindricity)
//     |s_j| <= radius
// (straightness, a cylinder about a line, is convex in the line's offsets and tilts and is solved
// by cutting planes instead: Straightness below).
// A step is taken when the true zone shrinks (the trust region grows), else the region shrinks;
// it ends when the linear program finds no descent (a stationary point of the minimax: the zone is
// held by the points the standards call its contacts) or the region is below rounding.
#include "tasks/minimum_zone.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <ClpSimplex.hpp>
#include <Eigen/Dense>

#include "tasks/fit_support.h"

namespace vlt::tasks_internal {
namespace {

using Eigen::Vector3d;
using Points = Eigen::Ref<const Eigen::Matrix3Xd>;

constexpr TaskOutput kFlatnessOutputs[] = {
    {"flatness", "m",
     "minimum-zone flatness: distance of the two closest parallel planes that hold every point"},
    {"flatness_least_squares", "m",
     "max - min orthogonal distance from the least-squares plane (>= flatness)"},
};
constexpr TaskOutput kStraightnessOutputs[] = {
    {"straightness", "m",
     "minimum-zone straightness: diameter of the thinnest cylinder that holds every point"},
    {"straightness_least_squares", "m",
     "2 x the largest distance from the least-squares line (>= straightness)"},
};
constexpr TaskOutput kRoundnessOutputs[] = {
    {"roundness", "m",
     "minimum-zone roundness: radial distance of the two closest concentric circles that hold every point, "
     "in the plane of the least-squares circle"},
    {"roundness_least_squares", "m",
     "max - min radial distance from the least-squares circle (>= roundness)"},
};
constexpr TaskOutput kCylindricityOutputs[] = {
    {"cylindricity", "m",
     "minimum-zone cylindricity: radial distance of the two closest coaxial cylinders that hold every point"},
    {"cylindricity_least_squares", "m",
     "max - min radial distance from the least-squares cylinder (>= cylindricity)"},
};

// The linearised problem at the current feature: distances d (N) and their gradients G (N x k) over
// the feature's k parameters, in normalised units.
struct Linearised {
  Eigen::VectorXd d;
  Eigen::MatrixXd g;
};

// The zone of distances d: max - min (two-sided), or 2 max (one-sided: a cylinder about a line).
double Zone(const Eigen::VectorXd& d, bool two_sided) {
  return two_sided ? d.maxCoeff() - d.minCoeff() : 2.0 * d.maxCoeff();
}

// One linear program: the step s (|s_j| <= 1, the problem scaled by the trust region) that minimises
// the zone of d + G s, and that zone; false when Clp finds no optimum.
bool ZoneStep(const Linearised& at, Eigen::VectorXd& step, double& zone) {
  const int n = static_cast<int>(at.d.size()), k = static_cast<int>(at.g.cols());
  const int columns = k + 2, rows = 2 * n;
  std::vector<CoinBigIndex> start;
  std::vector<int> index;
  std::vector<double> value;
  for (int j = 0; j < k; ++j) {  // s_j: in every row
    start.push_back(static_cast<CoinBigIndex>(index.size()));
    for (int r = 0; r < rows; ++r) {
      index.push_back(r);
      value.push_back(at.g(r % n, j));
    }
  }
  for (int side = 0; side < 2; ++side) {  // t_hi in rows 0..n-1, t_lo in n..2n-1
    start.push_back(static_cast<CoinBigIndex>(index.size()));
    for (int i = 0; i < n; ++i) {
      index.push_back(side * n + i);
      value.push_back(-1.0);
    }
  }
  start.push_back(static_cast<CoinBigIndex>(index.size()));
  const double inf = COIN_DBL_MAX;
  std::vector<double> column_lower(columns, -inf), column_upper(columns, inf), objective(columns, 0.0);
  for (int j = 0; j < k; ++j) column_lower[j] = -1.0, column_upper[j] = 1.0;
  objective[k] = 1.0;  // the zone: t_hi - t_lo
  objective[k + 1] = -1.0;
  // g_i s - t_hi <= -d_i;  g_i s - t_lo >= -d_i.
  std::vector<double> row_lower(rows, -inf), row_upper(rows, inf);
  for (int i = 0; i < n; ++i) {
    row_upper[i] = -at.d(i);
    row_lower[n + i] = -at.d(i);
  }
  ClpSimplex lp;
  lp.setLogLevel(0);
  lp.scaling(0);
  lp.loadProblem(columns, rows, start.data(), index.data(), value.data(), column_lower.data(),
                 column_upper.data(), objective.data(), row_lower.data(), row_upper.data());
  lp.setPrimalTolerance(1e-10);
  lp.setDualTolerance(1e-10);
  lp.dual();
  if (lp.status() != 0) return false;
  const double* solution = lp.primalColumnSolution();
  step = Eigen::Map<const Eigen::VectorXd>(solution, k);
  zone = lp.objectiveValue();
  return true;
}

// An orthonormal basis (e1, e2, v) completing the unit vector v.
Eigen::Matrix3d Basis(const Vector3d& v) {
  const Vector3d helper = std::abs(v.x()) < 0.9 ? Vector3d::UnitX() : Vector3d::UnitY();
  const Vector3d e1 = (helper - helper.dot(v) * v).normalized();
  Eigen::Matrix3d basis;
  basis << e1, v.cross(e1), v;
  return basis;
}

// The features, as values the search copies: each gives its distances and their gradients at its
// current parameters (Linearise) and moves by a step of them (Move). Points are normalised (about
// their centroid, in units of their rms distance from it).

// A plane through the centroid with unit normal n: d_i = n . q_i. Parameters: the tilts (a, b) of
// n' = (n + a e1 + b e2) / |...|, d d_i / d(a, b) = (e1 . q_i, e2 . q_i).
struct PlaneZone {
  const Eigen::Matrix3Xd* q;
  Vector3d n;
  Linearised Linearise() const {
    const Eigen::Matrix3d basis = Basis(n);
    Linearised at;
    at.d = (n.transpose() * *q).transpose();
    at.g = (basis.leftCols<2>().transpose() * *q).transpose();
    return at;
  }
  void Move(const Eigen::VectorXd& s) {
    const Eigen::Matrix3d basis = Basis(n);
    n = (n + s(0) * basis.col(0) + s(1) * basis.col(1)).normalized();
  }
};

// A line through a with unit direction u: d_i = rho_i = |q_i - a - ((q_i - a) . u) u|. Parameters:
// the shifts (a1, a2) of a along e1, e2 and the tilts (b1, b2) of u' = (u + b1 e1 + b2 e2) / |...|;
// with (x, y, z) the coordinates of q_i - a in (e1, e2, u) (Forbes, NPL DITC 140/89):
//   d rho / d(a1, a2, b1, b2) = -(x, y, x z, y z) / rho.
struct AxisZone {
  const Eigen::Matrix3Xd* q;
  Vector3d a, u;
  Linearised Linearise() const {
    const Eigen::Matrix3d basis = Basis(u);
    const Eigen::Matrix3Xd local = basis.transpose() * (q->colwise() - a);
    Linearised at;
    const long n = q->cols();
    at.d.resize(n);
    at.g.resize(n, 4);
    for (long i = 0; i < n; ++i) {
      const double x = local(0, i), y = local(1, i), z = local(2, i), rho = std::hypot(x, y);
      at.d(i) = rho;
      // On the axis the distance has no gradient; any subgradient of the zone serves, 0 among them.
      const double inv = rho > 0.0 ? 1.0 / rho : 0.0;
      at.g.row(i) << -x * inv, -y * inv, -x * z * inv, -y * z * inv;
    }
    return at;
  }
  void Move(const Eigen::VectorXd& s) {
    const Eigen::Matrix3d basis = Basis(u);
    a += s(0) * basis.col(0) + s(1) * basis.col(1);
    u = (u + s(2) * basis.col(0) + s(3) * basis.col(1)).normalized();
    a -= a.dot(u) * u;  // the same line, through the foot of the centroid (the origin)
  }
};

// Concentric circles about c in a plane (2-D coordinates): d_i = |q_i - c|, d d_i / d c =
// -(q_i - c) / d_i.
struct CircleZone {
  const Eigen::Matrix2Xd* q;
  Eigen::Vector2d c;
  Linearised Linearise() const {
    const Eigen::Matrix2Xd r = q->colwise() - c;
    Linearised at;
    at.d = r.colwise().norm().transpose();
    at.g.resize(q->cols(), 2);
    for (long i = 0; i < q->cols(); ++i)
      at.g.row(i) =
          at.d(i) > 0.0 ? Eigen::RowVector2d(-r.col(i).transpose() / at.d(i)) : Eigen::RowVector2d::Zero();
    return at;
  }
  void Move(const Eigen::VectorXd& s) { c += s.head<2>(); }
};

// The smallest zone of `feature` from where it stands (sequential linear programming in a trust
// region, see the file comment); `start_radius` is the trust region's first radius in parameter
// units (the zone's order: the least-squares form, normalised).
template <typename F>
double MinimiseZone(F& feature, double start_radius, TaskKind kind, std::string_view where, int& programs) {
  double zone = Zone(feature.Linearise().d, true);
  double radius = std::max(start_radius, 1e-9);
  // Normalised points (rms distance 1): a zone below 1e-13 is rounding, an exact feature.
  for (int iteration = 0; iteration < 500 && zone > 1e-13; ++iteration) {
    ++programs;
    Linearised at = feature.Linearise();
    // Scaled: steps in units of the radius, distances in units of the zone (the simplex's
    // tolerances are then relative to both).
    at.g *= radius / zone;
    at.d /= zone;
    // The zone is unchanged by a common shift of the distances (t_hi, t_lo follow): centred, the
    // rows' bounds are of the zone's size, not of the radius's (a perfect circle's distances are
    // R / zone ~ 1e15, beyond the simplex's tolerances).
    at.d.array() -= 0.5 * (at.d.maxCoeff() + at.d.minCoeff());
    Eigen::VectorXd step;
    double predicted = 0.0;
    if (!ZoneStep(at, step, predicted)) Fail(where, kind, "the minimum-zone linear program failed");
    predicted *= zone;
    // No descent the linear model sees: a stationary point of the zone (to the simplex's tolerance).
    if (zone - predicted <= 1e-9 * zone) break;
    F candidate = feature;
    candidate.Move(step * radius);
    const double trial_zone = Zone(candidate.Linearise().d, true);
    if (trial_zone < zone) {
      const double ratio = (zone - trial_zone) / (zone - predicted);
      feature = candidate;
      zone = trial_zone;
      if (ratio > 0.75 && step.cwiseAbs().maxCoeff() > 0.99) radius *= 2.0;
    } else {
      radius *= 0.25;
      if (radius < 1e-13) break;
    }
  }
  return zone;
}

// The points about their centroid in units of their rms distance from it (the mean without
// overflow: differences from the first point).
struct Normalised {
  Eigen::Matrix3Xd q;
  Vector3d centroid;
  double scale = 0.0;
};

Normalised Normalise(const Points& points, TaskKind kind, std::string_view where) {
  Normalised out;
  const Vector3d first = points.col(0);
  out.centroid = first + (points.colwise() - first).rowwise().mean();
  const Eigen::Matrix3Xd centred = points.colwise() - out.centroid;
  out.scale = std::sqrt(centred.colwise().squaredNorm().mean());
  if (!(out.scale > 0.0) || !std::isfinite(out.scale)) Fail(where, kind, "the points coincide");
  out.q = centred / out.scale;
  return out;
}

// Each form from its least-squares feature: [minimum zone, least squares], SI.
Eigen::Vector2d Flatness(const Points& points, std::string_view where, int& programs) {
  const FitResult ls = FitPlane(points, {}, where);
  const Normalised p = Normalise(points, TaskKind::kFlatness, where);
  PlaneZone zone{&p.q, ls.values.segment<3>(3)};
  const double start = Zone(zone.Linearise().d, true);
  return {MinimiseZone(zone, start, TaskKind::kFlatness, where, programs) * p.scale, ls.values(6)};
}

// One linear program of the cutting planes below: min t over (theta, t) subject to
// w^T (v_i - A_i theta) <= t for every cut (i, w), |theta_j| <= bound; false when Clp fails.
bool CutStep(const Eigen::Matrix3Xd& local, const std::vector<std::pair<long, Eigen::Vector2d>>& cuts,
             double bound, Eigen::Vector4d& theta, double& t) {
  // v_i(theta) = (x_i - a1 - b1 z_i, y_i - a2 - b2 z_i): w^T v_i = w^T (x_i, y_i) - w1 a1 - w2 a2 -
  // w1 z_i b1 - w2 z_i b2, so the row is (-w1, -w2, -w1 z_i, -w2 z_i, -1) <= -w^T (x_i, y_i).
  const int rows = static_cast<int>(cuts.size());
  std::vector<CoinBigIndex> start;
  std::vector<int> index;
  std::vector<double> value;
  for (int j = 0; j < 5; ++j) {
    start.push_back(static_cast<CoinBigIndex>(index.size()));
    for (int r = 0; r < rows; ++r) {
      const auto& [i, w] = cuts[static_cast<std::size_t>(r)];
      const double z = local(2, i);
      const double coefficient = j == 0   ? -w(0)
                                 : j == 1 ? -w(1)
                                 : j == 2 ? -w(0) * z
                                 : j == 3 ? -w(1) * z
                                          : -1.0;
      index.push_back(r);
      value.push_back(coefficient);
    }
  }
  start.push_back(static_cast<CoinBigIndex>(index.size()));
  const double inf = COIN_DBL_MAX;
  std::vector<double> column_lower = {-bound, -bound, -bound, -bound, 0.0};
  std::vector<double> column_upper = {bound, bound, bound, bound, inf};
  std::vector<double> objective = {0.0, 0.0, 0.0, 0.0, 1.0};
  std::vector<double> row_lower(static_cast<std::size_t>(rows), -inf),
      row_upper(static_cast<std::size_t>(rows));
  for (int r = 0; r < rows; ++r) {
    const auto& [i, w] = cuts[static_cast<std::size_t>(r)];
    row_upper[static_cast<std::size_t>(r)] = -w.dot(local.block<2, 1>(0, i));
  }
  ClpSimplex lp;
  lp.setLogLevel(0);
  lp.loadProblem(5, rows, start.data(), index.data(), value.data(), column_lower.data(), column_upper.data(),
                 objective.data(), row_lower.data(), row_upper.data());
  lp.setPrimalTolerance(1e-10);
  lp.setDualTolerance(1e-10);
  lp.dual();
  if (lp.status() != 0) return false;
  theta = Eigen::Map<const Eigen::Vector4d>(lp.primalColumnSolution());
  t = lp.objectiveValue();
  return true;
}

// Straightness of a line in space: the thinnest cylinder about a line that holds the points. In
// the least-squares line's frame (x, y across, z along) a line is a1 + b1 z, a2 + b2 z, and point
// i's offset from it within its plane z = z_i, v_i(theta) = (x_i - a1 - b1 z_i, y_i - a2 - b2 z_i),
// is affine in theta = (a1, a2, b1, b2): min over theta of max_i |v_i| is convex. Kelley's cutting
// planes solve it: |v| >= w^T v for every unit w, so the linear program over a set of cuts (i, w)
// is a lower bound of the optimum and its solution's true max |v_i| an upper bound; each round adds,
// for every point beyond the lower bound, the cut along its offset there, until the bounds meet to
// 1e-8 (below that the simplex's own tolerance, 1e-10 of the offsets, stalls them). The zone is
// then the perpendicular distance's (|v_i| is it to second order in the tilt, 1e-10 relative at
// the tilts of a straightness fit), evaluated exactly for the line found.
Eigen::Vector2d Straightness(const Points& points, std::string_view where, int& programs) {
  const FitResult ls = FitLine(points, {}, where);
  const Normalised p = Normalise(points, TaskKind::kStraightness, where);
  const Eigen::Matrix3d basis = Basis(ls.values.segment<3>(3));
  const Eigen::Matrix3Xd local = basis.transpose() * p.q;  // the least-squares line is the z axis
  const long n = local.cols();
  // Offsets in units of the least-squares line's largest (the simplex's tolerances are absolute).
  const double unit = std::max(local.topRows<2>().colwise().norm().maxCoeff(), 1e-300);
  Eigen::Matrix3Xd scaled = local;
  scaled.topRows<2>() /= unit;
  auto offsets = [&](const Eigen::Vector4d& theta) {
    Eigen::Matrix2Xd v(2, n);
    for (long i = 0; i < n; ++i)
      v.col(i) << scaled(0, i) - theta(0) - theta(2) * scaled(2, i),
          scaled(1, i) - theta(1) - theta(3) * scaled(2, i);
    return v;
  };
  Eigen::Vector4d best = Eigen::Vector4d::Zero();
  double upper = offsets(best).colwise().norm().maxCoeff();
  if (unit > 1e-13) {
    // First cuts: four directions per point (a square about each offset).
    std::vector<std::pair<long, Eigen::Vector2d>> cuts;
    for (long i = 0; i < n; ++i)
      for (const Eigen::Vector2d& w :
           {Eigen::Vector2d(1, 0), Eigen::Vector2d(-1, 0), Eigen::Vector2d(0, 1), Eigen::Vector2d(0, -1)})
        cuts.emplace_back(i, w);
    const double bound = 10.0 * (1.0 + scaled.row(2).cwiseAbs().maxCoeff());
    for (int round = 0; round < 200; ++round) {
      ++programs;
      Eigen::Vector4d theta;
      double lower = 0.0;
      if (!CutStep(scaled, cuts, bound, theta, lower))
        Fail(where, TaskKind::kStraightness, "the minimum-zone linear program failed");
      const Eigen::Matrix2Xd v = offsets(theta);
      const Eigen::VectorXd norms = v.colwise().norm().transpose();
      if (norms.maxCoeff() < upper) upper = norms.maxCoeff(), best = theta;
      if (upper - lower <= 1e-8 * upper) break;
      for (long i = 0; i < n; ++i)
        if (norms(i) > lower && norms(i) > 0.0) cuts.emplace_back(i, v.col(i) / norms(i));
    }
  }
  // The zone of the line found, as perpendicular distances: through (a1, a2, 0) along (b1, b2, 1).
  best *= unit;
  AxisZone line{&local, Vector3d(best(0), best(1), 0.0), Vector3d(best(2), best(3), 1.0).normalized()};
  const double zone =
      std::min(Zone(line.Linearise().d, false),
               Zone(AxisZone{&local, Vector3d::Zero(), Vector3d::UnitZ()}.Linearise().d, false));
  return {zone * p.scale, ls.values(6)};
}

Eigen::Vector2d Roundness(const Points& points, std::string_view where, int& programs) {
  const FitResult ls = FitCircle(points, {}, where);
  const Normalised p = Normalise(points, TaskKind::kRoundness, where);
  // ISO 12181-1 judges a profile in its plane: the points projected on the least-squares circle's.
  const Eigen::Matrix3d basis = Basis(ls.values.segment<3>(4));
  const Eigen::Matrix2Xd in_plane = basis.leftCols<2>().transpose() * p.q;
  const Eigen::Vector2d centre =
      basis.leftCols<2>().transpose() * (ls.values.head<3>() - p.centroid) / p.scale;
  CircleZone zone{&in_plane, centre};
  const double start = Zone(zone.Linearise().d, true);
  const double least_squares = start * p.scale;
  return {MinimiseZone(zone, start, TaskKind::kRoundness, where, programs) * p.scale, least_squares};
}

Eigen::Vector2d Cylindricity(const Points& points, std::string_view where, int& programs) {
  const FitResult ls = FitCylinder(points, {}, where);
  const Normalised p = Normalise(points, TaskKind::kCylindricity, where);
  const Vector3d u = ls.values.segment<3>(3);
  Vector3d a = (ls.values.head<3>() - p.centroid) / p.scale;
  a -= a.dot(u) * u;
  AxisZone zone{&p.q, a, u};
  const double start = Zone(zone.Linearise().d, true);
  return {MinimiseZone(zone, start, TaskKind::kCylindricity, where, programs) * p.scale, ls.values(7)};
}

}  // namespace

std::span<const TaskOutput> FormOutputs(TaskKind kind) {
  switch (kind) {
    case TaskKind::kFlatness: return kFlatnessOutputs;
    case TaskKind::kStraightness: return kStraightnessOutputs;
    case TaskKind::kRoundness: return kRoundnessOutputs;
    case TaskKind::kCylindricity: return kCylindricityOutputs;
    default: return {};
  }
}

FitResult FitForm(TaskKind kind, const Points& points, const FitOptions& options, std::string_view where) {
  CheckPoints(points, kind, MinimumPoints(kind), false, where);
  FitResult r = MakeResult(kind, points.cols(), options);
  Eigen::Vector2d form;
  switch (kind) {
    case TaskKind::kFlatness: form = Flatness(points, where, r.iterations); break;
    case TaskKind::kStraightness: form = Straightness(points, where, r.iterations); break;
    case TaskKind::kRoundness: form = Roundness(points, where, r.iterations); break;
    case TaskKind::kCylindricity: form = Cylindricity(points, where, r.iterations); break;
    default: Fail(where, kind, "not a form");
  }
  // The search starts at the least-squares feature and only shrinks the zone: never above the
  // least-squares form, whose own rounding may differ in the last digits.
  r.values << std::min(form(0), form(1)), form(1);
  // The extremes of distances have no derivative (ISO's contacts change with the points): Monte
  // Carlo only (docs/tasks.md).
  r.differentiable.assign(2, false);
  return r;
}

}  // namespace vlt::tasks_internal
