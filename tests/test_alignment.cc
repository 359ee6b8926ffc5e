// Alignment to nominal and deviations (vlt/fits.h FitBestFit, FitDeviation; docs/tasks.md
// "Alignment to nominal"), checked against independent references:
//  - an exact transform is recovered (a closed form: the points were made by it);
//  - Horn's unit-quaternion solution (J. Opt. Soc. Am. A 4 (1987) 629: the eigenvector of the
//    largest eigenvalue of a 4 x 4 matrix, a different algorithm from vlt's SVD) on noisy data;
//  - the Jacobians against central differences of the whole fit;
//  - the GUM covariance of an alignment and of deviations against Monte Carlo on a tracker job;
//  - coverage of the deviations and of the alignment over 200 simulated measurements with a known
//    truth.
#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "test_frame_helpers.h"
#include "test_mcm_helpers.h"
#include "vlt/error.h"
#include "vlt/fits.h"
#include "vlt/gum.h"
#include "vlt/mcm.h"
#include "vlt/measurement_model.h"

namespace vlt {
namespace {

using Eigen::Matrix3d;
using Eigen::Matrix3Xd;
using Eigen::Vector3d;

using test::Rotation;

// A panel's nominal points (part frame, m): a 2 m x 1 m grid with some relief.
Matrix3Xd PanelNominal(int n) {
  Matrix3Xd p(3, n);
  for (int i = 0; i < n; ++i) {
    const double u = (i % 4) / 3.0, v = (i / 4) / std::max(1.0, (n - 1) / 4.0);
    p.col(i) << 2.0 * u, 1.0 * v, 0.05 * std::sin(3.0 * u + 2.0 * v) + 0.2 * (i % 3 == 0);
  }
  return p;
}

std::shared_ptr<NominalGeometry> Geometry(const Matrix3Xd& nominal, int alignment_points, bool scale,
                                          int point = -1, Vector3d normal = Vector3d::Zero()) {
  auto g = std::make_shared<NominalGeometry>();
  g->positions = nominal;
  g->alignment_points = alignment_points;
  g->scale = scale;
  g->point = point;
  g->normal = normal;
  g->position = point >= 0;
  return g;
}

FitOptions Options(std::shared_ptr<NominalGeometry> g, bool jacobian) {
  FitOptions o;
  o.nominal = std::move(g);
  o.jacobian = jacobian;
  return o;
}

// Measured points: nominal moved into a tracker frame by the inverse of (s, R, t), plus noise.
Matrix3Xd Measured(const Matrix3Xd& nominal, double s, const Matrix3d& r, const Vector3d& t, double noise,
                   unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> z(0.0, noise);
  Matrix3Xd x(3, nominal.cols());
  for (Eigen::Index i = 0; i < nominal.cols(); ++i) {
    x.col(i) = r.transpose() * (nominal.col(i) - t) / s + Vector3d(z(rng), z(rng), z(rng));
  }
  return x;
}

// Every Jacobian row of fit(x, true) against central differences of fit(., false) over the first
// `columns` coordinates. h = 1e-7 m: a position (a norm of a 0.2 mm lateral deviation) curves on
// that scale, and a step of 1e-6 m would leave a truncation error of 1e-6.
template <typename Fit>
void ExpectJacobianMatchesCentralDifferences(const Matrix3Xd& x, const Fit& fit, int columns) {
  const FitResult at = fit(x, true);
  const double h = 1e-7;
  for (int col = 0; col < columns; ++col) {
    Matrix3Xd plus = x, minus = x;
    plus(col % 3, col / 3) += h;
    minus(col % 3, col / 3) -= h;
    const Eigen::VectorXd fd = (fit(plus, false).values - fit(minus, false).values) / (2.0 * h);
    for (int q = 0; q < at.values.size(); ++q) {
      EXPECT_NEAR(at.jacobian(q, col), fd(q), 2e-7 + 1e-6 * std::abs(fd(q)))
          << "output " << at.outputs[q].name << ", coordinate " << col;
    }
  }
}

TEST(Alignment, BestFitRecoversAnExactTransform) {
  const Matrix3Xd nominal = PanelNominal(12);
  const Vector3d angles(0.3, -0.4, 2.9), t(4.0, -1.5, 0.8);
  for (const bool scale : {false, true}) {
    const double s = scale ? 1.0 + 37e-6 : 1.0;
    const Matrix3Xd x = Measured(nominal, s, Rotation(angles(0), angles(1), angles(2)), t, 0.0, 1);
    const FitResult fit = FitBestFit(x, Options(Geometry(nominal, 12, scale), false));
    EXPECT_EQ(fit.kind, scale ? TaskKind::kBestFitScale : TaskKind::kBestFit);
    EXPECT_LT((fit.values.head<3>() - t).norm(), 1e-12);
    EXPECT_LT((fit.values.segment<3>(3) - angles).norm(), 1e-12);
    if (scale) {
      EXPECT_NEAR(fit.values(7), s, 1e-14);
    }
    EXPECT_LT(fit.values(6), 1e-12);
    EXPECT_FALSE(fit.differentiable[6]) << "rms of an exact fit has no derivative";
  }
}

// Horn (1987): with M = sum a_i b_i^T (a measured, b nominal, both less their centroids) the
// rotation is the unit quaternion of the largest eigenvalue of the symmetric 4 x 4 matrix N(M);
// for a scale on the measured side s = sum b_i . R a_i / sum |a_i|^2.
TEST(Alignment, BestFitEqualsHornsQuaternionSolution) {
  const Matrix3Xd nominal = PanelNominal(16);
  const Matrix3Xd x = Measured(nominal, 1.0, Rotation(-0.2, 0.1, -1.3), Vector3d(-3, 2, 1), 50e-6, 7);
  const Vector3d xb = x.rowwise().mean(), nb = nominal.rowwise().mean();
  Matrix3d m = Matrix3d::Zero();
  double aa = 0.0;
  for (int i = 0; i < 16; ++i) {
    m += (x.col(i) - xb) * (nominal.col(i) - nb).transpose();
    aa += (x.col(i) - xb).squaredNorm();
  }
  Eigen::Matrix4d horn;
  horn << m(0, 0) + m(1, 1) + m(2, 2), m(1, 2) - m(2, 1), m(2, 0) - m(0, 2), m(0, 1) - m(1, 0),
      m(1, 2) - m(2, 1), m(0, 0) - m(1, 1) - m(2, 2), m(0, 1) + m(1, 0), m(2, 0) + m(0, 2), m(2, 0) - m(0, 2),
      m(0, 1) + m(1, 0), -m(0, 0) + m(1, 1) - m(2, 2), m(1, 2) + m(2, 1), m(0, 1) - m(1, 0),
      m(2, 0) + m(0, 2), m(1, 2) + m(2, 1), -m(0, 0) - m(1, 1) + m(2, 2);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d> eig(horn);
  const Eigen::Vector4d q = eig.eigenvectors().col(3);
  const Matrix3d r = Eigen::Quaterniond(q(0), q(1), q(2), q(3)).toRotationMatrix();
  double bra = 0.0;
  for (int i = 0; i < 16; ++i) bra += (nominal.col(i) - nb).dot(r * (x.col(i) - xb));
  for (const bool scale : {false, true}) {
    const double s = scale ? bra / aa : 1.0;
    const Vector3d t = nb - s * r * xb;
    double sum = 0.0;
    for (int i = 0; i < 16; ++i) sum += (s * r * x.col(i) + t - nominal.col(i)).squaredNorm();
    const FitResult fit = FitBestFit(x, Options(Geometry(nominal, 16, scale), false));
    EXPECT_LT((fit.values.head<3>() - t).norm(), 1e-11);
    const Vector3d a = fit.values.segment<3>(3);
    EXPECT_LT((Rotation(a(0), a(1), a(2)) - r).norm(), 1e-12);
    if (scale) {
      EXPECT_NEAR(fit.values(7), s, 1e-13);
    }
    EXPECT_NEAR(fit.values(6), std::sqrt(sum / 16.0), 1e-13);
    EXPECT_GT(fit.values(6), 20e-6);
  }
}

// d outputs / d coordinates against central differences of the whole fit, with residuals of
// 0.2 mm (the Hessian's residual terms matter) and the deviation point inside and outside the
// alignment.
TEST(Alignment, JacobiansMatchCentralDifferences) {
  const Matrix3Xd nominal = PanelNominal(9);
  const Matrix3Xd x = Measured(nominal, 1.0 + 1e-4, Rotation(0.5, 0.2, 2.0), Vector3d(1, 2, 3), 2e-4, 3);
  const Vector3d normal = Vector3d(0.2, -0.3, 1.0).normalized();
  struct Case {
    const char* name;
    std::shared_ptr<NominalGeometry> geometry;
    bool deviation;
  };
  const std::vector<Case> cases = {
      {"best_fit", Geometry(nominal, 9, false), false},
      {"best_fit_scale", Geometry(nominal, 9, true), false},
      {"deviation of an alignment point", Geometry(nominal, 9, false, 4, normal), true},
      {"deviation of another point, scale", Geometry(nominal, 8, true, 8, normal), true},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    auto fit = [&](const Matrix3Xd& p, bool jacobian) {
      return c.deviation ? FitDeviation(p, Options(c.geometry, jacobian))
                         : FitBestFit(p, Options(c.geometry, jacobian));
    };
    ExpectJacobianMatchesCentralDifferences(x, fit, 3 * 9);
  }
}

std::shared_ptr<NominalGeometry> Rps(const Matrix3Xd& nominal, std::vector<std::array<bool, 3>> holds) {
  auto g = Geometry(nominal, static_cast<int>(holds.size()), false);
  g->holds = std::move(holds);
  return g;
}

// 3-2-1 by its definition: the first point lies on its nominal in x, y and z, the second in y and
// z, the third in z, whatever the other components' errors (the system is exactly determined).
TEST(Alignment, ThreeTwoOneHoldsItsDirectionsExactly) {
  Matrix3Xd nominal = PanelNominal(12);
  const Matrix3Xd x = Measured(nominal, 1.0, Rotation(0.02, -0.03, 1.9), Vector3d(2.5, -1.0, 0.4), 3e-4, 9);
  const std::vector<int> rps = {0, 3, 8};  // far apart, not collinear
  Matrix3Xd nx(3, 4), xx(3, 4);
  for (int k = 0; k < 3; ++k) nx.col(k) = nominal.col(rps[k]), xx.col(k) = x.col(rps[k]);
  nx.col(3) = nominal.col(5);
  xx.col(3) = x.col(5);
  auto g = Rps(nx, {{true, true, true}, {false, true, true}, {false, false, true}});
  g->alignment_points = 3;
  const FitResult fit = FitBestFit(xx.leftCols(3), Options(Rps(nx.leftCols(3), g->holds), false));
  EXPECT_EQ(fit.kind, TaskKind::kRps);
  EXPECT_LT(fit.values(6), 1e-13) << "rms of the held directions";
  for (int k = 0; k < 3; ++k) {
    auto dg = std::make_shared<NominalGeometry>(*g);
    dg->point = k;
    dg->normal = Vector3d::UnitZ();
    const Eigen::VectorXd d = FitDeviation(xx, Options(dg, false)).values;  // deviation, dx, dy, dz
    for (int axis = 0; axis < 3; ++axis) {
      if (g->holds[static_cast<std::size_t>(k)][static_cast<std::size_t>(axis)]) {
        EXPECT_NEAR(d(1 + axis), 0.0, 1e-12) << "point " << k << " axis " << axis;
      } else {
        EXPECT_GT(std::abs(d(1 + axis)), 1e-6) << "a free direction keeps its error";
      }
    }
  }
  // Six directions, none of them x: the part can slide along x.
  EXPECT_THROW(
      FitBestFit(xx.leftCols(3),
                 Options(Rps(nx.leftCols(3), {{false, true, true}, {false, true, true}, {false, true, true}}),
                         false)),
      NumericalError);
}

// An over-determined reference point system (residuals in the held directions): its Jacobian
// against central differences (the weighted Hessian's residual terms).
TEST(Alignment, ReferencePointSystemJacobianMatchesCentralDifferences) {
  const Matrix3Xd nominal = PanelNominal(5);
  const Matrix3Xd x = Measured(nominal, 1.0, Rotation(0.3, 0.1, -2.2), Vector3d(1, -2, 0.5), 2e-4, 13);
  const auto g = Rps(nominal, {{true, true, true},
                               {true, false, true},
                               {false, true, true},
                               {false, false, true},
                               {true, false, false}});
  const FitResult at = FitBestFit(x, Options(g, true));
  EXPECT_GT(at.values(6), 1e-5);
  const double h = 1e-7;
  for (int col = 0; col < 15; ++col) {
    Matrix3Xd plus = x, minus = x;
    plus(col % 3, col / 3) += h;
    minus(col % 3, col / 3) -= h;
    const Eigen::VectorXd fd =
        (FitBestFit(plus, Options(g, false)).values - FitBestFit(minus, Options(g, false)).values) /
        (2.0 * h);
    for (int q = 0; q < at.values.size(); ++q) {
      EXPECT_NEAR(at.jacobian(q, col), fd(q), 2e-7 + 1e-6 * std::abs(fd(q)))
          << at.outputs[q].name << ", " << col;
    }
  }
}

// A profile's extremes are the extremes of its points' deviations (each from FitDeviation), its
// Jacobian rows those of the extreme points (central differences away from ties).
TEST(Alignment, ProfileSpansItsPointsDeviations) {
  const Matrix3Xd nominal = PanelNominal(10);
  const Matrix3Xd x = Measured(nominal, 1.0, Rotation(0.1, 0.0, 0.7), Vector3d(0.5, 0.5, 0.5), 2e-4, 17);
  auto g = Geometry(nominal, 6, false);  // aligned on the first six; the profile over points 3..9
  std::vector<double> single;
  for (int p = 3; p < 10; ++p) {
    const Vector3d normal = Vector3d(0.1 * p, -0.2, 1.0).normalized();
    g->profile.push_back(p);
    g->profile_normals.push_back(normal);
    single.push_back(FitDeviation(x, Options(Geometry(nominal, 6, false, p, normal), false)).values(0));
  }
  const FitResult fit = FitProfile(x, Options(g, true));
  EXPECT_EQ(fit.values(0), *std::min_element(single.begin(), single.end()));
  EXPECT_EQ(fit.values(1), *std::max_element(single.begin(), single.end()));
  EXPECT_EQ(fit.values(2), 2.0 * std::max(std::abs(fit.values(0)), std::abs(fit.values(1))));
  EXPECT_GT(fit.values(1) - fit.values(0), 1e-4);
  const double h = 1e-8;
  for (int col = 0; col < 30; ++col) {
    Matrix3Xd plus = x, minus = x;
    plus(col % 3, col / 3) += h;
    minus(col % 3, col / 3) -= h;
    const Eigen::VectorXd fd =
        (FitProfile(plus, Options(g, false)).values - FitProfile(minus, Options(g, false)).values) /
        (2.0 * h);
    for (int q = 0; q < 3; ++q) {
      EXPECT_NEAR(fit.jacobian(q, col), fd(q), 1e-6 + 1e-6 * std::abs(fd(q)))
          << fit.outputs[q].name << ", " << col;
    }
  }
}

TEST(Alignment, AnglesOfAHalfTurnStayNearTheirReference) {
  const Matrix3Xd nominal = PanelNominal(8);
  const Matrix3Xd x =
      Measured(nominal, 1.0, Rotation(0.0, 0.0, std::numbers::pi - 1e-9), Vector3d(2, 0, 0), 1e-5, 5);
  FitOptions o = Options(Geometry(nominal, 8, false), false);
  // Without a reference the angle comes out on either side of the cut at +-pi; with one, on its side.
  for (const double side : {-1.0, 1.0}) {
    o.reference_angles = Vector3d(0.0, 0.0, side * std::numbers::pi);
    const double rz = FitBestFit(x, o).values(5);
    EXPECT_NEAR(rz, side * std::numbers::pi, 1e-4) << "within pi of the reference";
  }
}

TEST(Alignment, CollinearPointsAndMissingNominalsAreRefused) {
  Matrix3Xd line(3, 4);
  line << 0, 1, 2, 3, 0, 0, 0, 0, 0, 0, 0, 0;
  EXPECT_THROW(FitBestFit(line, Options(Geometry(line, 4, false), false)), NumericalError);
  EXPECT_THROW(FitBestFit(line, FitOptions{}), InputError);
  EXPECT_THROW(FitBestFit(line.leftCols(2), Options(Geometry(line.leftCols(2), 2, false), false)),
               InputError);
}

// --- Alignment by datum features (docs/tasks.md "Alignment by datum features"): a plane of four
// corners, a line of a row of four, a point. Its geometry over `nominal` (the nine datum points).
std::shared_ptr<NominalGeometry> Datums(const Matrix3Xd& nominal) {
  auto g = Geometry(nominal, 9, false);
  g->plane_points = 4;
  g->line_points = 4;
  return g;
}

// The datum points of PanelNominal(12): corners P0, P3, P8, P11 (plane), row P4..P7 (line), P9.
Matrix3Xd DatumPoints(const Matrix3Xd& all) {
  Matrix3Xd d(3, 9);
  const int order[9] = {0, 3, 8, 11, 4, 5, 6, 7, 9};
  for (int i = 0; i < 9; ++i) d.col(i) = all.col(order[i]);
  return d;
}

// By its definition: after the alignment the measured plane's normal is the nominal plane's and
// its centroid lies in the nominal plane, the line's direction lies in the plane spanned by the
// nominal normal and line and its centroid in the nominal line's plane (along e2), the point has
// its nominal coordinate along e1; exact points give the transform back with zero rms.
TEST(Alignment, DatumFeaturesHoldTheirDatums) {
  const Matrix3Xd nominal = DatumPoints(PanelNominal(12));
  const Matrix3d r = Rotation(0.03, -0.02, 2.2);
  const Vector3d t(1.5, -2.0, 0.3);
  const Matrix3Xd exact = Measured(nominal, 1.0, r, t, 0.0, 1);
  const FitResult e = FitBestFit(exact, Options(Datums(nominal), false));
  EXPECT_EQ(e.kind, TaskKind::kFeatures);
  EXPECT_LT((e.values.head<3>() - t).norm(), 1e-12);
  EXPECT_LT((Rotation(e.values(3), e.values(4), e.values(5)) - r).norm(), 1e-12);
  EXPECT_LT(e.values(6), 1e-12);

  const Matrix3Xd x = Measured(nominal, 1.0, r, t, 2e-4, 5);
  const FitResult f = FitBestFit(x, Options(Datums(nominal), false));
  const Matrix3d rf = Rotation(f.values(3), f.values(4), f.values(5));
  const Matrix3Xd aligned = (rf * x).colwise() + Vector3d(f.values.head<3>());
  const FitResult plane = FitPlane(aligned.leftCols(4)), plane_n = FitPlane(nominal.leftCols(4));
  const FitResult line = FitLine(aligned.middleCols(4, 4)), line_n = FitLine(nominal.middleCols(4, 4));
  const Vector3d n = plane_n.values.segment<3>(3), l = line_n.values.segment<3>(3);
  const Vector3d e1 = (l - l.dot(n) * n).normalized(), e2 = n.cross(e1);
  EXPECT_NEAR(std::abs(plane.values.segment<3>(3).dot(n)), 1.0, 1e-14);
  EXPECT_NEAR(n.dot(plane.values.head<3>() - plane_n.values.head<3>()), 0.0, 1e-12);
  EXPECT_NEAR(line.values.segment<3>(3).dot(e2), 0.0, 1e-12);
  EXPECT_NEAR(e2.dot(line.values.head<3>() - line_n.values.head<3>()), 0.0, 1e-12);
  EXPECT_NEAR(e1.dot(aligned.col(8) - nominal.col(8)), 0.0, 1e-12);
  EXPECT_GT(f.values(6), 1e-5);  // the datum points' residuals: the noise is not absorbed
}

TEST(Alignment, DatumFeaturesJacobianMatchesCentralDifferences) {
  const Matrix3Xd all = PanelNominal(12);
  Matrix3Xd nominal(3, 10);
  nominal << DatumPoints(all), all.col(10);
  const Matrix3Xd x = Measured(nominal, 1.0, Rotation(0.03, -0.02, 2.2), Vector3d(1.5, -2.0, 0.3), 2e-4, 8);
  auto deviation = Datums(nominal);
  deviation->point = 9;
  deviation->normal = Vector3d(0.1, 0.2, 1.0).normalized();
  deviation->position = true;
  for (const bool dev : {false, true}) {
    SCOPED_TRACE(dev ? "deviation of a tenth point" : "the alignment");
    auto fit = [&](const Matrix3Xd& p, bool jacobian) {
      return dev ? FitDeviation(p, Options(deviation, jacobian))
                 : FitBestFit(p.leftCols(9), Options(Datums(nominal.leftCols(9)), jacobian));
    };
    ExpectJacobianMatchesCentralDifferences(x, fit, static_cast<int>(fit(x, true).jacobian.cols()));
  }
}

TEST(Alignment, DatumFeaturesRefuseALinePerpendicularToThePlane) {
  Matrix3Xd nominal = DatumPoints(PanelNominal(12));
  const Vector3d normal = FitPlane(nominal.leftCols(4)).values.segment<3>(3);
  for (int i = 4; i < 8; ++i)
    nominal.col(i) = Vector3d(1.0, 0.4, 0.0) + 0.3 * i * normal;  // the line along the normal
  const Matrix3Xd x = Measured(nominal, 1.0, Rotation(0.0, 0.0, 0.5), Vector3d(0.1, 0.2, 0.3), 1e-5, 2);
  EXPECT_THROW(FitBestFit(x, Options(Datums(nominal), false)), NumericalError);
  auto short_line = Datums(nominal);
  short_line->plane_points = 6;  // 6 + 4 + 1 is not 9
  EXPECT_THROW(FitBestFit(x, Options(short_line, false)), InputError);
}

// A panel measured by the mirror tracker (every error parameter at its prior, reading noise):
// nominal points, their readings at the estimates, an alignment and deviations.
struct PanelJob {
  Matrix3Xd nominal;
  Matrix3d to_tracker = Rotation(0.01, -0.02, 2.5);
  Vector3d tracker_origin = Vector3d(3.0, 1.0, -0.5);  // part-frame position of the tracker
  std::vector<TaskSpec> tasks;
  Vector3d normal = Vector3d(0.1, 0.2, 1.0).normalized();

  PanelJob() : nominal(PanelNominal(12)) {
    TaskSpec a;
    a.name = "A";
    a.kind = TaskKind::kBestFitScale;
    for (int i = 0; i < 10; ++i) a.points.push_back(Name(i));
    a.nominal = Geometry(nominal.leftCols(10), 10, true);
    tasks.push_back(a);
    for (const int p : {3, 11}) {
      TaskSpec d;
      d.name = "dev." + Name(p);
      d.kind = TaskKind::kPosition;
      d.points = a.points;
      Matrix3Xd positions = nominal.leftCols(10);
      int index = p;
      if (p >= 10) {
        d.points.push_back(Name(p));
        positions.conservativeResize(3, 11);
        positions.col(10) = nominal.col(p);
        index = 10;
      }
      d.nominal = Geometry(positions, 10, true, index, normal);
      tasks.push_back(d);
    }
  }
  static std::string Name(int i) { return "P" + std::to_string(i); }
  // The point's tracker-frame position (the part frame is the nominal's).
  Vector3d InTracker(const Vector3d& part) const { return to_tracker * (part - tracker_origin); }
};

// The panel's twelve points read by the mirror tracker at its estimates; `tasks` propagated by the
// GUM and by 40 000 Monte Carlo trials (seed `seed`): every differentiable output's u within 5 % and
// mean within 0.1 u. Returns how many outputs were compared.
int CompareGumWithMonteCarlo(const PanelJob& job, const std::vector<TaskSpec>& tasks, std::uint64_t seed) {
  const MeasurementModel model(test::MirrorSetup(false));
  std::vector<PointReadings> points;
  McmJob mcm;
  mcm.model = &model;
  for (int i = 0; i < 12; ++i) {
    const Vector3d r =
        ReadingsForPartPoint(model, job.InTracker(job.nominal.col(i)), false, PanelJob::Name(i));
    points.push_back({PanelJob::Name(i), r});
    mcm.points.push_back({PanelJob::Name(i), r});
  }
  for (const TaskSpec& t : tasks) {
    mcm.fit_tasks.push_back(t);
    std::vector<int> idx;
    for (const std::string& p : t.points) idx.push_back(std::stoi(p.substr(1)));
    mcm.fit_task_points.push_back(idx);
  }
  McmSettings settings;
  settings.trials = 40000;
  settings.seed = seed;
  const McmResult mc = RunMcm(mcm, settings);
  int checked = 0;
  for (const TaskSpec& t : tasks) {
    const TaskUncertainty gum = PropagateTask(model, points, t);
    for (int q = 0; q < gum.value.size(); ++q) {
      const std::string name = t.name + "." + gum.quantities[q];
      if (!gum.differentiable[q]) continue;  // rms, position of nominal points: Monte Carlo only
      for (const McmOutputResult& o : mc.outputs) {
        if (o.name != name) continue;
        SCOPED_TRACE(name);
        EXPECT_NEAR(o.u / gum.u(q), 1.0, 0.05);
        EXPECT_NEAR(o.mean, gum.value(q), 0.1 * gum.u(q));
        ++checked;
      }
    }
  }
  return checked;
}

TEST(Alignment, GumCovarianceAgreesWithMonteCarlo) {
  const PanelJob job;
  EXPECT_EQ(CompareGumWithMonteCarlo(job, job.tasks, 11),
            7 + 4 + 4);  // t, angles, scale; deviation, dx, dy, dz of each point
}

// The same for an alignment by datum features and a position in its frame: 40 000 trials of the
// mirror tracker's panel; the GUM u of the frame (t, angles) and of the deviation within 5 %.
TEST(Alignment, DatumFeaturesGumCovarianceAgreesWithMonteCarlo) {
  const PanelJob job;
  const int order[10] = {0, 3, 8, 11, 4, 5, 6, 7, 9, 10};
  Matrix3Xd nominal(3, 10);
  std::vector<std::string> names;
  for (int i = 0; i < 10; ++i) {
    nominal.col(i) = job.nominal.col(order[i]);
    names.push_back(PanelJob::Name(order[i]));
  }
  TaskSpec frame;
  frame.name = "F";
  frame.kind = TaskKind::kFeatures;
  frame.points.assign(names.begin(), names.begin() + 9);
  frame.nominal = Datums(nominal.leftCols(9));
  TaskSpec position;
  position.name = "dev";
  position.kind = TaskKind::kPosition;
  position.points = names;
  auto g = Datums(nominal);
  g->point = 9;
  g->normal = job.normal;
  g->position = true;
  position.nominal = g;
  EXPECT_EQ(CompareGumWithMonteCarlo(job, {frame, position}, 12), 6 + 4);  // t, angles; deviation, dx, dy, dz
}

// 200 simulated measurements of a panel with a known truth: the true error parameters drawn from
// their priors, the true part off nominal by up to 0.3 mm along the normals, readings with noise.
// The measurand is the deviation after the best fit of the TRUE points; its estimate is the
// deviation after the best fit of the measured points; the GUM U (k = 2) must cover the truth in
// 93-97 % of the cases (binomial sd at 200 seeds: 1.5 %).
TEST(Alignment, DeviationsCoverTheTruth) {
  const PanelJob job;
  const MeasurementSetup prior = test::MirrorSetup(false);
  const MeasurementModel estimate(prior);
  int covered = 0, total = 0, covered_alignment = 0, total_alignment = 0;
  for (unsigned seed = 1; seed <= 200; ++seed) {
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> z(0.0, 1.0);
    MeasurementSetup truth = prior;
    for (UncertainInput& p : truth.params) p.estimate += p.u * z(rng);
    const MeasurementModel true_model(truth);
    std::vector<PointReadings> points;
    Matrix3Xd true_points(3, 12);
    for (int i = 0; i < 12; ++i) {
      const Vector3d part = job.nominal.col(i) + 3e-4 * std::tanh(z(rng)) * job.normal;
      true_points.col(i) = job.InTracker(part);
      Vector3d r = ReadingsForPartPoint(true_model, true_points.col(i), false, PanelJob::Name(i));
      const Eigen::Vector3d u = estimate.reading_uncertainty(r(0));
      for (int c = 0; c < 3; ++c) r(c) += u(c) * z(rng);
      points.push_back({PanelJob::Name(i), r});
    }
    for (std::size_t t = 0; t < job.tasks.size(); ++t) {
      const TaskSpec& spec = job.tasks[t];
      Matrix3Xd truth_cols(3, static_cast<Eigen::Index>(spec.points.size()));
      for (std::size_t k = 0; k < spec.points.size(); ++k) {
        truth_cols.col(static_cast<Eigen::Index>(k)) = true_points.col(std::stoi(spec.points[k].substr(1)));
      }
      const TaskUncertainty gum = PropagateTask(estimate, points, spec);
      // The alignment: t, the angles and the scale (not the rms); a deviation: deviation, dx, dy, dz.
      const bool alignment = t == 0;
      const FitResult truth_fit = FitTask(spec.kind, truth_cols, TrialFitOptions(spec, gum.value));
      int& c = alignment ? covered_alignment : covered;
      int& n = alignment ? total_alignment : total;
      const std::vector<int> quantities =
          alignment ? std::vector<int>{0, 1, 2, 3, 4, 5, 7} : std::vector<int>{0, 1, 2, 3};
      for (const int q : quantities) {
        c += std::abs(gum.value(q) - truth_fit.values(q)) <= gum.U(q) ? 1 : 0;
        ++n;
      }
    }
  }
  const double coverage = static_cast<double>(covered) / total;
  const double coverage_alignment = static_cast<double>(covered_alignment) / total_alignment;
  EXPECT_GE(coverage, 0.93);
  EXPECT_LE(coverage, 0.97);
  EXPECT_GE(coverage_alignment, 0.93);
  EXPECT_LE(coverage_alignment, 0.97);
  std::printf("coverage: deviations %.3f over %d quantities, alignment %.3f over %d\n", coverage, total,
              coverage_alignment, total_alignment);
}

}  // namespace
}  // namespace vlt
