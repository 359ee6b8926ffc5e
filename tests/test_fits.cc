// test_fits.cc — task features: exact recovery on synthetic points, Jacobians against central
// finite differences of the fit itself, invariances, and refusals of degenerate point sets.
#include "vlt/fits.h"

#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "vlt/error.h"

namespace vlt {
namespace {

using Eigen::Matrix3Xd;
using Eigen::Vector3d;
constexpr double kPi = std::numbers::pi;

// Deterministic Gaussian noise.
Matrix3Xd Noisy(Matrix3Xd points, double sigma, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, sigma);
  for (long i = 0; i < points.cols(); ++i) {
    for (int c = 0; c < 3; ++c) points(c, i) += normal(rng);
  }
  return points;
}

// An orthonormal basis (u, w) of the plane with unit normal n.
std::pair<Vector3d, Vector3d> PlaneBasis(const Vector3d& n) {
  const Vector3d u = n.unitOrthogonal();
  return {u, n.cross(u)};
}

Matrix3Xd PlanePoints(const Vector3d& origin, const Vector3d& normal, int n) {
  const auto [u, w] = PlaneBasis(normal);
  Matrix3Xd p(3, n);
  for (int i = 0; i < n; ++i) {
    const double a = 0.37 * i - 2.0, b = std::sin(1.3 * i) * 1.5;
    p.col(i) = origin + a * u + b * w;
  }
  return p;
}

// Points on a sphere cap (polar angle up to max_polar) about axis z.
Matrix3Xd SpherePoints(const Vector3d& centre, double radius, int n, double max_polar) {
  Matrix3Xd p(3, n);
  const double golden = kPi * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < n; ++i) {
    const double z = 1.0 - (1.0 - std::cos(max_polar)) * (i + 0.5) / n;
    const double r = std::sqrt(1.0 - z * z), phi = golden * i;
    p.col(i) = centre + radius * Vector3d(r * std::cos(phi), r * std::sin(phi), z);
  }
  return p;
}

Matrix3Xd CirclePoints(const Vector3d& centre, const Vector3d& normal, double radius, int n, double arc) {
  const auto [u, w] = PlaneBasis(normal);
  Matrix3Xd p(3, n);
  for (int i = 0; i < n; ++i) {
    const double phi = arc * i / n + 0.1;
    p.col(i) = centre + radius * (std::cos(phi) * u + std::sin(phi) * w);
  }
  return p;
}

Matrix3Xd LinePoints(const Vector3d& origin, const Vector3d& direction, int n) {
  Matrix3Xd p(3, n);
  for (int i = 0; i < n; ++i) p.col(i) = origin + (0.25 * i - 1.0) * direction;
  return p;
}

// Central finite differences of every output w.r.t. every coordinate (k x 3N), fitting with the
// given orientation so that no perturbed fit flips sign.
Eigen::MatrixXd FiniteDifferenceJacobian(TaskKind kind, const Matrix3Xd& points, const FitOptions& options,
                                         double h) {
  FitOptions value_only = options;
  value_only.jacobian = false;
  const long k = FitTask(kind, points, value_only).values.size();
  Eigen::MatrixXd fd(k, 3 * points.cols());
  for (long j = 0; j < points.cols(); ++j) {
    for (int c = 0; c < 3; ++c) {
      Matrix3Xd plus = points, minus = points;
      plus(c, j) += h;
      minus(c, j) -= h;
      fd.col(3 * j + c) =
          (FitTask(kind, plus, value_only).values - FitTask(kind, minus, value_only).values) / (2.0 * h);
    }
  }
  return fd;
}

// Every differentiable row of the analytic Jacobian matches finite differences to 1e-6 relative
// to the row's largest entry.
void ExpectJacobianMatches(TaskKind kind, const Matrix3Xd& points, double h) {
  FitOptions options;
  options.jacobian = true;
  const FitResult fit = FitTask(kind, points, options);
  options.orientation = Vector3d::Zero();
  if (kind == TaskKind::kPlane || kind == TaskKind::kLine) options.orientation = fit.values.segment<3>(3);
  if (kind == TaskKind::kCircle) options.orientation = fit.values.segment<3>(4);
  const Eigen::MatrixXd fd = FiniteDifferenceJacobian(kind, points, options, h);
  ASSERT_EQ(fit.jacobian.rows(), fd.rows());
  ASSERT_EQ(fit.jacobian.cols(), fd.cols());
  ASSERT_TRUE(fit.jacobian.allFinite());
  for (long row = 0; row < fd.rows(); ++row) {
    if (!fit.differentiable[static_cast<std::size_t>(row)]) continue;
    const double scale = fd.row(row).cwiseAbs().maxCoeff();
    ASSERT_GT(scale, 0.0) << fit.outputs[row].name;
    const double error = (fit.jacobian.row(row) - fd.row(row)).cwiseAbs().maxCoeff();
    EXPECT_LE(error, 1e-6 * scale) << TaskOutputs(kind)[row].name << " of " << static_cast<int>(kind);
  }
}

TEST(Fits, OutputNamesAndUnits) {
  EXPECT_EQ(TaskOutputs(TaskKind::kDistance).size(), 1u);
  EXPECT_EQ(TaskOutputs(TaskKind::kPlane).size(), 8u);
  EXPECT_EQ(TaskOutputs(TaskKind::kSphere).size(), 5u);
  EXPECT_EQ(TaskOutputs(TaskKind::kCircle).size(), 8u);
  EXPECT_EQ(TaskOutputs(TaskKind::kLine).size(), 8u);
  EXPECT_EQ(TaskOutputs(TaskKind::kSphere)[3].name, "radius");
  EXPECT_EQ(TaskOutputs(TaskKind::kPlane)[6].name, "flatness");
  EXPECT_EQ(TaskOutputs(TaskKind::kPlane)[3].unit, "1");
  EXPECT_EQ(TaskOutputs(TaskKind::kLine)[6].name, "straightness");
}

TEST(Fits, DistanceValueAndJacobian) {
  Matrix3Xd p(3, 2);
  p << 1.0, 4.0, 2.0, 6.0, 3.0, 3.0;  // columns (1,2,3) and (4,6,3): distance 5
  FitOptions options;
  options.jacobian = true;
  const FitResult r = FitDistance(p, options);
  EXPECT_DOUBLE_EQ(r.values(0), 5.0);
  Eigen::RowVectorXd expected(6);
  expected << -0.6, -0.8, 0.0, 0.6, 0.8, 0.0;
  EXPECT_LE((r.jacobian.row(0) - expected).cwiseAbs().maxCoeff(), 1e-15);
  ExpectJacobianMatches(TaskKind::kDistance, p, 1e-6);
}

TEST(Fits, ExactRecovery) {
  const Vector3d n = Vector3d(0.2, -0.3, 0.93).normalized();
  const Vector3d origin(1.5, -2.0, 0.7);
  {  // plane
    const Matrix3Xd p = PlanePoints(origin, n, 25);
    const FitResult r = FitPlane(p);
    EXPECT_LE((r.values.head<3>() - p.rowwise().mean()).norm(), 1e-14);
    EXPECT_LE((r.values.segment<3>(3) - n).norm(), 1e-13);  // largest component z > 0
    EXPECT_LE(r.values(6), 1e-13);
    EXPECT_LE(r.values(7), 1e-13);
    EXPECT_FALSE(r.differentiable[6]);
    EXPECT_FALSE(r.differentiable[7]);
    EXPECT_NEAR(n.dot(r.values.head<3>() - origin), 0.0, 1e-14);
  }
  {  // sphere, from a 60 degree cap only
    const Matrix3Xd p = SpherePoints(Vector3d(0.3, 2.0, -1.0), 0.0195, 40, kPi / 3);
    const FitResult r = FitSphere(p);
    EXPECT_LE((r.values.head<3>() - Vector3d(0.3, 2.0, -1.0)).norm(), 1e-13);
    EXPECT_NEAR(r.values(3), 0.0195, 1e-14);
    EXPECT_LE(r.values(4), 1e-14);
    EXPECT_GE(r.iterations, 1);
  }
  {  // circle on a 120 degree arc
    const Vector3d centre(5.0, -1.0, 2.0);
    const Matrix3Xd p = CirclePoints(centre, n, 0.35, 12, 2.0 * kPi / 3.0);
    const FitResult r = FitCircle(p);
    EXPECT_LE((r.values.head<3>() - centre).norm(), 1e-13);
    EXPECT_NEAR(r.values(3), 0.35, 1e-13);
    EXPECT_LE((r.values.segment<3>(4) - n).norm(), 1e-13);
    EXPECT_LE(r.values(7), 1e-13);
  }
  {                                                 // line
    const Vector3d dir = Vector3d(-0.6, 0.0, 0.8);  // largest |component| is z: kept positive
    const Matrix3Xd p = LinePoints(origin, dir, 9);
    const FitResult r = FitLine(p);
    EXPECT_LE((r.values.segment<3>(3) - dir).norm(), 1e-14);
    EXPECT_LE((r.values.head<3>() - p.rowwise().mean()).norm(), 1e-14);
    EXPECT_LE(r.values(6), 1e-14);
  }
}

TEST(Fits, KnownResidualStatistics) {
  // Plane z = 0: heights (+1, -1, +1, -1, 0) um on a symmetric square pattern keep the fitted
  // plane at z = 0 (zero mean, no tilt), so flatness = 2 um and rms = sqrt(4/5) um.
  Matrix3Xd p(3, 5);
  p << 1, -1, -1, 1, 0, 1, 1, -1, -1, 0, 1e-6, -1e-6, 1e-6, -1e-6, 0;
  const FitResult plane = FitPlane(p);
  EXPECT_NEAR(plane.values(6), 2e-6, 1e-18);
  EXPECT_NEAR(plane.values(7), std::sqrt(4e-12 / 5.0), 1e-18);
  // Line along x (offsets 1, -2, 1 um at x = -1, 0, 1: zero mean, zero slope): the largest
  // perpendicular distance is 2 um, straightness = 2 x 2 um.
  Matrix3Xd q(3, 3);
  q << -1, 0, 1, 1e-6, -2e-6, 1e-6, 0, 0, 0;
  const FitResult line = FitLine(q);
  EXPECT_NEAR(line.values(6), 4e-6, 1e-12);
}

TEST(Fits, JacobiansMatchFiniteDifferences) {
  const Vector3d n = Vector3d(0.1, 0.7, -0.5).normalized();
  // Step 1e-7 m, well below the 1e-4 m residuals, so that the curvature of the residual
  // statistics (~1/rms) leaves the truncation error of the central differences negligible.
  ExpectJacobianMatches(TaskKind::kPlane, Noisy(PlanePoints(Vector3d(2, 1, 0), n, 20), 1e-4, 1), 1e-7);
  ExpectJacobianMatches(TaskKind::kSphere, Noisy(SpherePoints(Vector3d(1, -2, 0.5), 0.25, 24, 2.0), 1e-4, 2),
                        1e-7);
  ExpectJacobianMatches(TaskKind::kCircle,
                        Noisy(CirclePoints(Vector3d(0.5, 0.5, 3), n, 0.8, 16, 4.0), 1e-4, 3), 1e-7);
  ExpectJacobianMatches(TaskKind::kLine, Noisy(LinePoints(Vector3d(-1, 2, 1), n, 15), 1e-4, 4), 1e-7);
  // Minimal point sets: exact fits, where only the non-statistic rows exist.
  ExpectJacobianMatches(TaskKind::kSphere, Noisy(SpherePoints(Vector3d(0, 0, 0), 1.0, 4, 2.5), 1e-3, 5),
                        1e-6);
  ExpectJacobianMatches(TaskKind::kCircle, CirclePoints(Vector3d(1, 2, 3), n, 0.5, 3, 3.0), 1e-6);
  ExpectJacobianMatches(TaskKind::kPlane, Noisy(PlanePoints(Vector3d(0, 0, 1), n, 3), 1e-3, 6), 1e-6);
  ExpectJacobianMatches(TaskKind::kLine, Noisy(LinePoints(Vector3d(0, 0, 1), n, 2), 1e-3, 7), 1e-6);
}

// The fitted geometry is a smooth function of the points: the central difference
// fit(p + h e) - fit(p - h e) scales linearly with h from 1e-5 down to 1e-9 m for every
// coordinate e. (The rms row, last, is left out: its curvature ~1/rms = 1e4 /m makes the
// h = 1e-5 reference itself off by ~1e-2 relative; it is a closed form of the geometry.) An iteration that stops short of the stationary point by a path-dependent
// ~1e-11 m would show as a slope error ~1e-11 / 2h, i.e. 5e-3 at h = 1e-9 (the bound below
// allows 1e-6 relative to the row plus 64 ulps of the values over 2h).
void ExpectContinuous(TaskKind kind, const Matrix3Xd& points, const FitOptions& options) {
  const double steps[] = {1e-5, 1e-6, 1e-7, 1e-8, 1e-9};
  const Eigen::VectorXd base = FitTask(kind, points, options).values;
  const double ulp = std::numeric_limits<double>::epsilon() * (1.0 + base.cwiseAbs().maxCoeff());
  for (long j = 0; j < points.cols(); ++j) {
    for (int c = 0; c < 3; ++c) {
      Eigen::VectorXd reference;
      for (double h : steps) {
        Matrix3Xd plus = points, minus = points;
        plus(c, j) += h;
        minus(c, j) -= h;
        const Eigen::VectorXd slope =
            (FitTask(kind, plus, options).values - FitTask(kind, minus, options).values) / (2.0 * h);
        if (reference.size() == 0) {
          reference = slope;
          continue;
        }
        for (long row = 0; row + 1 < slope.size(); ++row) {
          EXPECT_LE(std::abs(slope(row) - reference(row)),
                    1e-6 * reference.cwiseAbs().maxCoeff() + 64.0 * ulp / (2.0 * h))
              << TaskOutputs(kind)[row].name << " of " << static_cast<int>(kind) << ", point " << j
              << " coordinate " << c << ", h = " << h;
        }
      }
    }
  }
}

TEST(Fits, FittedValuesAreContinuous) {
  ExpectContinuous(TaskKind::kSphere, Noisy(SpherePoints(Vector3d(1, -2, 0.5), 0.25, 24, 2.0), 1e-4, 2), {});
  const Vector3d n = Vector3d(0.1, 0.7, -0.5).normalized();
  const Matrix3Xd circle = Noisy(CirclePoints(Vector3d(0.5, 0.5, 3), n, 0.8, 16, 4.0), 1e-4, 3);
  FitOptions options;
  options.orientation = FitCircle(circle).values.segment<3>(4);  // no sign flip between fits
  ExpectContinuous(TaskKind::kCircle, circle, options);
}

TEST(Fits, ExactPlaneStillDifferentiatesCentroidAndNormal) {
  // Nominal points of a plan lie exactly on the feature: flatness and rms have no derivative
  // (flagged, zero rows), centroid and normal do.
  const Vector3d n = Vector3d(0.0, 0.6, 0.8);
  const Matrix3Xd p = PlanePoints(Vector3d(0, 0, 0), n, 10);
  ExpectJacobianMatches(TaskKind::kPlane, p, 1e-6);
  FitOptions options;
  options.jacobian = true;
  const FitResult r = FitPlane(p, options);
  EXPECT_EQ(r.jacobian.row(6).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(r.jacobian.row(7).cwiseAbs().maxCoeff(), 0.0);
}

TEST(Fits, RigidTranslationAndRotation) {
  const Vector3d n = Vector3d(0.3, -0.2, 0.9).normalized();
  const Vector3d t(12.5, -3.25, 0.75);
  const Eigen::Matrix3d rot = Eigen::AngleAxisd(0.7, Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  struct Case {
    TaskKind kind;
    Matrix3Xd points;
    std::vector<int> centre_rows;     // rows that move with the translation (x, y, z)
    std::vector<int> direction_rows;  // unit vectors (rotate, do not translate)
    std::vector<int> invariant_rows;  // radius, flatness, rms, ...
  };
  const Case cases[] = {
      {TaskKind::kPlane,
       Noisy(PlanePoints(Vector3d(1, 0, 0), n, 12), 1e-4, 11),
       {0, 1, 2},
       {3, 4, 5},
       {6, 7}},
      {TaskKind::kSphere,
       Noisy(SpherePoints(Vector3d(0, 1, 0), 0.5, 15, 2.0), 1e-4, 12),
       {0, 1, 2},
       {},
       {3, 4}},
      {TaskKind::kCircle,
       Noisy(CirclePoints(Vector3d(0, 0, 1), n, 0.4, 10, 5.0), 1e-4, 13),
       {0, 1, 2},
       {4, 5, 6},
       {3, 7}},
      {TaskKind::kLine, Noisy(LinePoints(Vector3d(2, 0, 0), n, 10), 1e-4, 14), {0, 1, 2}, {3, 4, 5}, {6, 7}},
  };
  for (const Case& c : cases) {
    FitOptions options;
    options.jacobian = true;
    const FitResult base = FitTask(c.kind, c.points, options);
    const Matrix3Xd moved = c.points.colwise() + t;
    const FitResult shifted = FitTask(c.kind, moved, options);
    Matrix3Xd rotated_points = rot * c.points;
    FitOptions rotated_options = options;
    if (!c.direction_rows.empty()) {
      rotated_options.orientation =
          rot * Vector3d(base.values(c.direction_rows[0]), base.values(c.direction_rows[1]),
                         base.values(c.direction_rows[2]));
    }
    const FitResult rotated = FitTask(c.kind, rotated_points, rotated_options);
    const Vector3d centre(base.values(c.centre_rows[0]), base.values(c.centre_rows[1]),
                          base.values(c.centre_rows[2]));
    const Vector3d centre_shifted(shifted.values(c.centre_rows[0]), shifted.values(c.centre_rows[1]),
                                  shifted.values(c.centre_rows[2]));
    const Vector3d centre_rotated(rotated.values(c.centre_rows[0]), rotated.values(c.centre_rows[1]),
                                  rotated.values(c.centre_rows[2]));
    EXPECT_LE((centre_shifted - centre - t).norm(), 1e-12);
    EXPECT_LE((centre_rotated - rot * centre).norm(), 1e-12);
    for (int row : c.invariant_rows) {
      EXPECT_NEAR(shifted.values(row), base.values(row), 1e-12);
      EXPECT_NEAR(rotated.values(row), base.values(row), 1e-12);
    }
    if (!c.direction_rows.empty()) {
      const Vector3d d(base.values(c.direction_rows[0]), base.values(c.direction_rows[1]),
                       base.values(c.direction_rows[2]));
      const Vector3d d_shift(shifted.values(c.direction_rows[0]), shifted.values(c.direction_rows[1]),
                             shifted.values(c.direction_rows[2]));
      const Vector3d d_rot(rotated.values(c.direction_rows[0]), rotated.values(c.direction_rows[1]),
                           rotated.values(c.direction_rows[2]));
      EXPECT_LE((d_shift - d).norm(), 1e-12);
      EXPECT_LE((d_rot - rot * d).norm(), 1e-12);
    }
    // Jacobian row sums over the points: a common translation dp moves the centre by dp and
    // leaves everything else unchanged, so sum_j dC/dp_j = I and sum_j d(other)/dp_j = 0.
    Eigen::MatrixXd sums = Eigen::MatrixXd::Zero(base.values.size(), 3);
    for (long j = 0; j < c.points.cols(); ++j) sums += base.jacobian.middleCols(3 * j, 3);
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) {
        EXPECT_NEAR(sums(c.centre_rows[a], b), a == b ? 1.0 : 0.0, 1e-10);
      }
    }
    for (int row : c.invariant_rows) EXPECT_LE(sums.row(row).cwiseAbs().maxCoeff(), 1e-9);
    for (int row : c.direction_rows) EXPECT_LE(sums.row(row).cwiseAbs().maxCoeff(), 1e-9);
  }
}

TEST(Fits, OrientationConvention) {
  const Vector3d n = Vector3d(0.2, -0.9, 0.3).normalized();  // largest |component| is y < 0
  const Matrix3Xd p = PlanePoints(Vector3d::Zero(), n, 8);
  const FitResult by_default = FitPlane(p);
  EXPECT_LE((by_default.values.segment<3>(3) + n).norm(), 1e-13);  // flipped: y > 0
  FitOptions options;
  options.orientation = Vector3d(0, 0, 1);  // n.z > 0: kept as given
  EXPECT_LE((FitPlane(p, options).values.segment<3>(3) - n).norm(), 1e-13);
  const FitResult line = FitLine(LinePoints(Vector3d::Zero(), n, 5), options);
  EXPECT_GT(line.values(5), 0.0);
}

template <class Error>
void ExpectRefusal(TaskKind kind, const Matrix3Xd& p, const std::string& needle) {
  try {
    FitTask(kind, p, {}, "job.toml: task 'bore_A'");
    ADD_FAILURE() << "no error for " << needle;
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind("job.toml: task 'bore_A': ", 0), 0u) << what;
    EXPECT_NE(what.find(needle), std::string::npos) << what;
  }
}

TEST(Fits, DegenerateInputsAreRefused) {
  const Vector3d n(0, 0, 1);
  ExpectRefusal<InputError>(TaskKind::kSphere, SpherePoints(Vector3d::Zero(), 1, 3, 2), "at least 4");
  ExpectRefusal<InputError>(TaskKind::kPlane, LinePoints(Vector3d::Zero(), n, 2), "at least 3");
  ExpectRefusal<InputError>(TaskKind::kCircle, LinePoints(Vector3d::Zero(), n, 2), "at least 3");
  ExpectRefusal<InputError>(TaskKind::kLine, LinePoints(Vector3d::Zero(), n, 1), "at least 2");
  ExpectRefusal<InputError>(TaskKind::kDistance, LinePoints(Vector3d::Zero(), n, 3), "exactly 2");
  Matrix3Xd nan_point = PlanePoints(Vector3d::Zero(), n, 5);
  nan_point(1, 3) = std::numeric_limits<double>::quiet_NaN();
  ExpectRefusal<InputError>(TaskKind::kPlane, nan_point, "point 3 has a non-finite");

  ExpectRefusal<NumericalError>(TaskKind::kPlane, LinePoints(Vector3d(1, 2, 3), n, 6), "collinear");
  ExpectRefusal<NumericalError>(TaskKind::kCircle, LinePoints(Vector3d(1, 2, 3), n, 6), "collinear");
  ExpectRefusal<NumericalError>(TaskKind::kSphere, CirclePoints(Vector3d(1, 2, 3), n, 1, 8, 6), "coplanar");
  ExpectRefusal<NumericalError>(TaskKind::kSphere, PlanePoints(Vector3d(1, 2, 3), n, 8), "coplanar");
  Matrix3Xd same(3, 2);
  same << 1, 1, 2, 2, 3, 3;
  ExpectRefusal<NumericalError>(TaskKind::kDistance, same, "coincide");
  ExpectRefusal<NumericalError>(TaskKind::kLine, same, "coincide");
  // The 8 corners of a cube: isotropic scatter, no preferred plane or line.
  Matrix3Xd cube(3, 8);
  for (int i = 0; i < 8; ++i) cube.col(i) = Vector3d(i & 1, (i >> 1) & 1, (i >> 2) & 1);
  ExpectRefusal<NumericalError>(TaskKind::kPlane, cube, "no preferred plane");
  ExpectRefusal<NumericalError>(TaskKind::kLine, cube, "no preferred direction");
}

// The Jacobian of a scan's plane or sphere is computed in chunks side by side (FitOptions::threads,
// issue 33): the same bits for any thread count, and an exact plane's statistic rows still zero
// (its matrix is no longer zeroed before it is filled: the memory a poisoned block left is reused
// where the allocator can).
TEST(Fits, PlaneAndSphereJacobiansAreTheSameOnAnyThreadCount) {
  const int n = 5000;  // 10 chunks of 512 points
  const Vector3d normal = Vector3d(0.3, -0.2, 1.0).normalized();
  // A 4 m x 4 m panel, 71 points a side (the first 5000), scanned with 10 um of noise.
  const auto [u, w] = PlaneBasis(normal);
  Matrix3Xd exact(3, n);
  for (int i = 0; i < n; ++i) {
    exact.col(i) = Vector3d(1, 2, 0) + (4.0 * (i % 71) / 70 - 2) * u + (4.0 * (i / 71) / 70 - 2) * w;
  }
  const Matrix3Xd plane = Noisy(exact, 1e-5, 31);
  const Matrix3Xd sphere = Noisy(SpherePoints(Vector3d(1, -1, 2), 0.4, n, 1.8), 1e-5, 32);
  auto fit = [](TaskKind kind, const Matrix3Xd& points, int threads) {
    { std::vector<double> poison(8 * 3 * static_cast<std::size_t>(n), std::nan("")); }
    FitOptions options;
    options.jacobian = true;
    options.threads = threads;
    return FitTask(kind, points, options);
  };
  using Case = std::pair<TaskKind, const Matrix3Xd*>;
  for (const auto& [kind, points] : {Case{TaskKind::kPlane, &plane}, Case{TaskKind::kPlane, &exact},
                                     Case{TaskKind::kSphere, &sphere}}) {
    const FitResult one = fit(kind, *points, 1);
    ASSERT_TRUE(one.jacobian.allFinite());
    for (const int threads : {2, 3, 16}) {
      const FitResult many = fit(kind, *points, threads);
      ASSERT_EQ(many.jacobian.cols(), 3 * n);
      EXPECT_EQ(many.values, one.values) << threads;
      EXPECT_TRUE(many.jacobian == one.jacobian) << static_cast<int>(kind) << " on " << threads << " threads";
    }
    // Three times: glibc hands a freed block of this size back to the next request most of the
    // time, not always (and a sanitizer's allocator never does).
    for (int again = 0; points == &exact && again < 3; ++again) {
      const FitResult r = fit(kind, *points, 3);
      EXPECT_EQ(r.differentiable[6], false);
      EXPECT_EQ(r.jacobian.bottomRows<2>().cwiseAbs().maxCoeff(), 0.0);
    }
  }
  // And the columns are the derivatives: a few against central differences (the first and last
  // point of a chunk among them).
  FitOptions options;
  options.jacobian = true;
  options.threads = 3;
  const FitResult r = FitPlane(plane, options);
  FitOptions value_only;
  value_only.orientation = r.values.segment<3>(3);
  for (const long j : {0L, 511L, 512L, 2047L, 4999L}) {
    for (int c = 0; c < 3; ++c) {
      Matrix3Xd plus = plane, minus = plane;
      plus(c, j) += 1e-4;
      minus(c, j) -= 1e-4;
      const Eigen::VectorXd fd = (FitPlane(plus, value_only).values - FitPlane(minus, value_only).values) / 2e-4;
      for (int row = 0; row < 6; ++row) {
        // A step of 0.1 mm: the scatter's sums round to about 1e-10 (the normal to 1e-14), the
        // centroid's to 3e-14: under 2e-10 over 2h; the third-order term about h^2 times the slope.
        // The slopes: 1/N = 2e-4 (centroid), about 1e-4 per metre (normal).
        EXPECT_NEAR(r.jacobian(row, 3 * j + c), fd(row), 1e-9 + 1e-6 * std::abs(fd(row)))
            << "row " << row << " point " << j << " coordinate " << c;
      }
    }
  }
}

TEST(Fits, LargePointSetsScale) {
  // 10^5 points: O(N) memory (the Jacobian is k x 3N) and a result close to the truth.
  const int n = 100000;
  const Vector3d normal = Vector3d(0.1, 0.2, 1.0).normalized();
  FitOptions options;
  options.jacobian = true;
  const FitResult plane = FitPlane(Noisy(PlanePoints(Vector3d(0, 0, 0), normal, n), 1e-6, 21), options);
  EXPECT_LE((plane.values.segment<3>(3) - normal).norm(), 1e-6);
  EXPECT_EQ(plane.jacobian.cols(), 3 * n);
  EXPECT_TRUE(plane.jacobian.allFinite());
  const FitResult sphere = FitSphere(Noisy(SpherePoints(Vector3d(1, 1, 1), 0.5, n, 1.5), 1e-6, 22), options);
  EXPECT_NEAR(sphere.values(3), 0.5, 1e-6);
  EXPECT_TRUE(sphere.jacobian.allFinite());
}

}  // namespace
}  // namespace vlt
