// Fits weighted by the points' covariance (vlt/fits.h FitOptions::covariance; docs/tasks.md "Fits
// weighted by the points' covariance"), checked against independent references:
//  - closed forms where the weighted fit has one: independent points with isotropic covariance
//    sigma_i^2 I give the weighted total-least-squares plane and line (eigenvectors of the scatter
//    about the weighted centroid) and the weighted Procrustes alignment (SVD of the weighted
//    cross-covariance);
//  - equal isotropic covariance gives the ordinary fit, for every kind;
//  - the Jacobians against central differences of the whole weighted fit (weights held fixed);
//  - the same covariance given dense and as blocks + shared factor gives the same fit;
//  - a simulation with a known truth: the spread of the weighted fit over 4000 draws of correlated,
//    unequal point errors matches its GUM covariance G V G^T, and is below the ordinary fit's
//    (Gauss-Markov);
//  - refusals: kinds that are not least-squares fits, weights made for other points;
//  - on a tracker job (weighting = "both"): the weighted plane's GUM uncertainty against its Monte
//    Carlo (every trial refits with the same weights), and below the ordinary plane's.
#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "test_frame_helpers.h"
#include "vlt/error.h"
#include "vlt/fits.h"
#include "vlt/job.h"
#include "vlt/results.h"

namespace vlt {
namespace {

using Eigen::Matrix3d;
using Eigen::Matrix3Xd;
using Eigen::Vector3d;

using test::Rotation;

// Distinct form values (m), well apart so that no extreme changes point under a 1e-6 m step (the
// plane's permutation too after the weighted fit's tilt: its two largest residuals 23 um apart).
double Form(int i, int n, int permutation = 7) { return 1e-4 * (((permutation * i) % n) - 0.5 * n) / n; }

// Points of each feature in a tilted pose, with form error.
Matrix3Xd Posed(const Matrix3Xd& local) {
  const Matrix3d r = Rotation(0.3, -0.2, 0.7);
  return (r * local).colwise() + Vector3d(2.0, -1.0, 0.5);
}

Matrix3Xd PlanePoints(int n) {
  Matrix3Xd p(3, n);
  for (int i = 0; i < n; ++i) p.col(i) << 0.9 * (i % 4) / 3.0, 0.6 * (i / 4) / 2.0, Form(i, n, 5);
  return Posed(p);
}

Matrix3Xd LinePoints(int n) {
  Matrix3Xd p(3, n);
  for (int i = 0; i < n; ++i) p.col(i) << 2.0 * i / (n - 1), Form(i, n), Form(n - 1 - i, n);
  return Posed(p);
}

// Radial form on a sphere cap / circle / cylinder / cone of radius r at angles a.
Matrix3Xd SpherePoints(int n) {
  Matrix3Xd p(3, n);
  for (int i = 0; i < n; ++i) {
    const double a = 2.0 * M_PI * i / n, b = 0.3 + 0.8 * (i % 3) / 2.0, r = 0.1 + Form(i, n);
    p.col(i) << r * std::cos(b) * std::cos(a), r * std::cos(b) * std::sin(a), r * std::sin(b);
  }
  return Posed(p);
}

Matrix3Xd CirclePoints(int n, bool coplanar) {
  Matrix3Xd p(3, n);
  for (int i = 0; i < n; ++i) {
    const double a = 2.0 * M_PI * i / n + 0.1 * (i % 2), r = 0.15 + Form(i, n);
    p.col(i) << r * std::cos(a), r * std::sin(a), coplanar ? 0.0 : Form(n - 1 - i, n);
  }
  return Posed(p);
}

Matrix3Xd AxialPoints(int n, double half_angle) {
  Matrix3Xd p(3, n);
  for (int i = 0; i < n; ++i) {
    const double a = 2.0 * M_PI * (i % 4) / 4.0 + 0.4 * (i / 4), z = 0.3 * (i / 4) - 0.3;
    const double r = 0.2 + z * std::tan(half_angle) + Form(i, n);
    p.col(i) << r * std::cos(a), r * std::sin(a), z;
  }
  return Posed(p);
}

// A nominal panel and its measurement: turned, moved, with deviations.
Matrix3Xd PanelNominal(int n) {
  Matrix3Xd p(3, n);
  for (int i = 0; i < n; ++i) p.col(i) << 2.0 * (i % 4) / 3.0, 1.0 * (i / 4) / 2.0, 0.1 * (i % 3);
  return p;
}
Matrix3Xd PanelMeasured(const Matrix3Xd& nominal) {
  Matrix3Xd x = (Rotation(0.2, 0.1, -0.4) * nominal).colwise() + Vector3d(3.0, 1.0, -0.5);
  for (int i = 0; i < x.cols(); ++i)
    x.col(i) += Vector3d(Form(i, 12), Form(11 - i, 12), Form((i + 5) % 12, 12));
  return x;
}

std::shared_ptr<NominalGeometry> Nominal(const Matrix3Xd& positions, bool scale = false,
                                         std::vector<std::array<bool, 3>> holds = {}) {
  auto g = std::make_shared<NominalGeometry>();
  g->positions = positions;
  g->alignment_points = static_cast<int>(positions.cols());
  g->scale = scale;
  g->holds = std::move(holds);
  return g;
}

// Independent isotropic points: sigma_i^2 I.
std::shared_ptr<PointCovariance> Isotropic(const std::vector<double>& sigma) {
  auto v = std::make_shared<PointCovariance>();
  for (double s : sigma) v->blocks.push_back(s * s * Matrix3d::Identity());
  return v;
}

// Correlated, unequal, anisotropic: each point's own block and a rank-r shared part (a tracker's
// scale and angle errors act like this), at the size of a tracker's uncertainties (um).
std::shared_ptr<PointCovariance> Correlated(long n, int rank, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> z;
  auto v = std::make_shared<PointCovariance>();
  for (long i = 0; i < n; ++i) {
    Matrix3d a;
    for (int k = 0; k < 9; ++k) a(k) = z(rng);
    a *= 2e-6 * (1.0 + 2.0 * (i % 3));
    v->blocks.push_back(a * a.transpose() + 1e-12 * Matrix3d::Identity());
  }
  v->shared.resize(3 * n, rank);
  for (long k = 0; k < v->shared.size(); ++k) v->shared(k) = 5e-6 * z(rng);
  return v;
}

Eigen::MatrixXd Dense(const PointCovariance& v) {
  const long n = static_cast<long>(v.blocks.size());
  Eigen::MatrixXd d = v.shared.size() > 0 ? Eigen::MatrixXd(v.shared * v.shared.transpose())
                                          : Eigen::MatrixXd::Zero(3 * n, 3 * n);
  for (long i = 0; i < n; ++i) d.block<3, 3>(3 * i, 3 * i) += v.blocks[static_cast<std::size_t>(i)];
  return d;
}

FitOptions Weighted(std::shared_ptr<const PointCovariance> v, bool jacobian,
                    std::shared_ptr<const NominalGeometry> nominal = nullptr) {
  FitOptions o;
  o.covariance = std::move(v);
  o.jacobian = jacobian;
  o.nominal = std::move(nominal);
  return o;
}

// Unit vector with the sign of `like`.
Vector3d Like(const Vector3d& v, const Vector3d& like) { return v.dot(like) < 0.0 ? Vector3d(-v) : v; }

// The weighted centroid and the eigenvectors (ascending) of the weighted scatter about it.
struct WeightedScatter {
  Vector3d centroid;
  Matrix3d vectors;
};
WeightedScatter Scatter(const Matrix3Xd& x, const std::vector<double>& sigma) {
  WeightedScatter s;
  double total = 0.0;
  s.centroid.setZero();
  for (long i = 0; i < x.cols(); ++i) {
    const double w = 1.0 / (sigma[static_cast<std::size_t>(i)] * sigma[static_cast<std::size_t>(i)]);
    s.centroid += w * x.col(i);
    total += w;
  }
  s.centroid /= total;
  Matrix3d m = Matrix3d::Zero();
  for (long i = 0; i < x.cols(); ++i) {
    const Vector3d d = x.col(i) - s.centroid;
    m += d * d.transpose() / (sigma[static_cast<std::size_t>(i)] * sigma[static_cast<std::size_t>(i)]);
  }
  s.vectors = Eigen::SelfAdjointEigenSolver<Matrix3d>(m).eigenvectors();
  return s;
}

std::vector<double> UnequalSigmas(long n) {
  std::vector<double> sigma;
  for (long i = 0; i < n; ++i) sigma.push_back(1e-6 * (1.0 + 4.0 * ((3 * i) % 5)));
  return sigma;
}

TEST(WeightedFits, IsotropicPointsGiveTheWeightedTotalLeastSquaresPlaneAndLine) {
  const Matrix3Xd plane = PlanePoints(12);
  const std::vector<double> sigma = UnequalSigmas(12);
  const FitResult fit = FitPlane(plane, Weighted(Isotropic(sigma), false));
  const WeightedScatter s = Scatter(plane, sigma);
  const Vector3d normal = Like(s.vectors.col(0), fit.values.segment<3>(3));
  EXPECT_LT((fit.values.segment<3>(3) - normal).norm(), 1e-10);
  // The reported point: the (unweighted) centroid's foot on the weighted plane.
  const Vector3d centroid = plane.rowwise().mean();
  const Vector3d foot = centroid - normal.dot(centroid - s.centroid) * normal;
  EXPECT_LT((fit.values.head<3>() - foot).norm(), 1e-11);
  // And it differs from the ordinary plane by far more than that (the test can fail).
  EXPECT_GT((FitPlane(plane).values.segment<3>(3) - normal).norm(), 1e-6);

  const Matrix3Xd line = LinePoints(10);
  const std::vector<double> line_sigma = UnequalSigmas(10);
  const FitResult lfit = FitLine(line, Weighted(Isotropic(line_sigma), false));
  const WeightedScatter ls = Scatter(line, line_sigma);
  const Vector3d direction = Like(ls.vectors.col(2), lfit.values.segment<3>(3));
  EXPECT_LT((lfit.values.segment<3>(3) - direction).norm(), 1e-10);
  const Vector3d lc = line.rowwise().mean();
  EXPECT_LT((lfit.values.head<3>() - (ls.centroid + direction * direction.dot(lc - ls.centroid))).norm(),
            1e-11);
}

TEST(WeightedFits, IsotropicPointsGiveTheWeightedProcrustesAlignment) {
  const Matrix3Xd nominal = PanelNominal(12);
  const Matrix3Xd measured = PanelMeasured(nominal);
  const std::vector<double> sigma = UnequalSigmas(12);
  const FitResult fit = FitBestFit(measured, Weighted(Isotropic(sigma), false, Nominal(nominal)));
  // Closed form: R from the SVD of sum w (n - n_w)(x - x_w)^T, t = n_w - R x_w.
  const Vector3d x_w = Scatter(measured, sigma).centroid, n_w = Scatter(nominal, sigma).centroid;
  Matrix3d cross = Matrix3d::Zero();
  for (long i = 0; i < 12; ++i) {
    cross += (nominal.col(i) - n_w) * (measured.col(i) - x_w).transpose() /
             (sigma[static_cast<std::size_t>(i)] * sigma[static_cast<std::size_t>(i)]);
  }
  const Eigen::JacobiSVD<Matrix3d> svd(cross, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const double det = (svd.matrixU() * svd.matrixV().transpose()).determinant();
  const Matrix3d r = svd.matrixU() * Vector3d(1.0, 1.0, det).asDiagonal() * svd.matrixV().transpose();
  const Vector3d t = n_w - r * x_w;
  EXPECT_LT((fit.values.head<3>() - t).norm(), 1e-10);
  const Matrix3d fitted = Rotation(fit.values(3), fit.values(4), fit.values(5));
  EXPECT_LT((fitted - r).norm(), 1e-11);
  EXPECT_GT((FitBestFit(measured, Weighted(nullptr, false, Nominal(nominal))).values.head<3>() - t).norm(),
            1e-7);
}

// Every kind, with its points and options.
struct Case {
  TaskKind kind;
  Matrix3Xd points;
  std::shared_ptr<const NominalGeometry> nominal;
};
std::vector<Case> Cases(bool coplanar_circle) {
  const Matrix3Xd nominal = PanelNominal(12);
  const Matrix3Xd measured = PanelMeasured(nominal);
  std::vector<std::array<bool, 3>> holds = {{true, true, true},
                                            {false, true, true},
                                            {false, false, true},
                                            {false, true, true},
                                            {true, false, true}};
  return {
      {TaskKind::kPlane, PlanePoints(12), nullptr},
      {TaskKind::kLine, LinePoints(10), nullptr},
      {TaskKind::kSphere, SpherePoints(12), nullptr},
      {TaskKind::kCircle, CirclePoints(10, coplanar_circle), nullptr},
      {TaskKind::kCylinder, AxialPoints(16, 0.0), nullptr},
      {TaskKind::kCone, AxialPoints(16, 0.15), nullptr},
      {TaskKind::kBestFit, measured, Nominal(nominal)},
      {TaskKind::kBestFitScale, measured, Nominal(nominal, true)},
      {TaskKind::kRps, measured.leftCols(5), Nominal(nominal.leftCols(5), false, holds)},
  };
}

TEST(WeightedFits, EqualIsotropicCovarianceGivesTheOrdinaryFit) {
  for (const Case& c : Cases(true)) {
    SCOPED_TRACE(std::string(TaskKindName(c.kind)));
    FitOptions ordinary;
    ordinary.nominal = c.nominal;
    const FitResult plain = FitTask(c.kind, c.points, ordinary);
    const FitResult weighted = FitTask(
        c.kind, c.points, Weighted(Isotropic(std::vector<double>(c.points.cols(), 3e-6)), false, c.nominal));
    ASSERT_EQ(plain.values.size(), weighted.values.size());
    // The plane's and line's point: the centroid in both (it lies on the ordinary feature).
    EXPECT_LT((plain.values - weighted.values).cwiseAbs().maxCoeff(), 1e-10)
        << plain.values.transpose() << "\n"
        << weighted.values.transpose();
    EXPECT_TRUE(weighted.weights != nullptr);
    EXPECT_GT(weighted.chi2, 0.0);
  }
}

TEST(WeightedFits, JacobiansMatchCentralDifferences) {
  for (const Case& c : Cases(false)) {
    SCOPED_TRACE(std::string(TaskKindName(c.kind)));
    const long n = c.points.cols();
    const FitResult fit = FitTask(c.kind, c.points, Weighted(Correlated(n, 3, 11), true, c.nominal));
    FitOptions fixed;
    fixed.nominal = c.nominal;
    fixed.weights = fit.weights;  // the estimator the Jacobian belongs to: these weights
    // Fourth-order central differences: with form errors ten times the points' uncertainties the
    // weighted solution curves on the scale of a few um, too fast for a two-point difference. Their
    // floor here is 2e-6 (the fit's convergence, 1e-10 standard uncertainties, over h); a Hessian
    // without its residual terms is off by ~1e-4 (form / size).
    constexpr double h = 1e-6;
    auto at = [&](long col, double step) {
      Matrix3Xd moved = c.points;
      moved(col % 3, col / 3) += step;
      return Eigen::VectorXd(FitTask(c.kind, moved, fixed).values);
    };
    double worst = 0.0;
    for (long col = 0; col < 3 * n; ++col) {
      const Eigen::VectorXd fd =
          (8.0 * (at(col, h) - at(col, -h)) - (at(col, 2 * h) - at(col, -2 * h))) / (12.0 * h);
      for (long q = 0; q < fd.size(); ++q) {
        if (!fit.differentiable[static_cast<std::size_t>(q)]) continue;
        worst =
            std::max(worst, std::abs(fd(q) - fit.jacobian(q, col)) / (1.0 + std::abs(fit.jacobian(q, col))));
      }
    }
    EXPECT_LT(worst, 5e-6);
  }
}

TEST(WeightedFits, DenseAndStructuredCovarianceGiveTheSameFit) {
  for (const Case& c : Cases(false)) {
    SCOPED_TRACE(std::string(TaskKindName(c.kind)));
    const auto structured = Correlated(c.points.cols(), 4, 5);
    auto dense = std::make_shared<PointCovariance>();
    dense->dense = Dense(*structured);
    const FitResult a = FitTask(c.kind, c.points, Weighted(structured, true, c.nominal));
    const FitResult b = FitTask(c.kind, c.points, Weighted(dense, true, c.nominal));
    EXPECT_LT((a.values - b.values).cwiseAbs().maxCoeff(), 1e-11);
    EXPECT_LT((a.jacobian - b.jacobian).cwiseAbs().maxCoeff(),
              1e-6 * (1.0 + a.jacobian.cwiseAbs().maxCoeff()));
    EXPECT_NEAR(a.chi2, b.chi2, 1e-8 * a.chi2);
  }
}

// Truth on the feature (no form error), points drawn with covariance V: the weighted fit's spread
// is its GUM covariance G V G^T (within the 4000-draw sampling error, ~2.2 % in u), and no larger
// than the ordinary fit's.
TEST(WeightedFits, SpreadOverDrawsIsTheGumCovarianceAndBelowTheOrdinaryFit) {
  struct Truth {
    TaskKind kind;
    Matrix3Xd points;
    std::shared_ptr<const NominalGeometry> nominal;
    std::vector<int> parameters;  // outputs that are the feature's parameters (Gauss-Markov applies)
  };
  Matrix3Xd flat = PlanePoints(12);
  {
    const FitResult p = FitPlane(flat);
    for (long i = 0; i < flat.cols(); ++i) {
      const Vector3d n = p.values.segment<3>(3);
      flat.col(i) -= n.dot(flat.col(i) - p.values.head<3>()) * n;
    }
  }
  const Matrix3Xd nominal = PanelNominal(12);
  const Matrix3Xd exact = (Rotation(0.2, 0.1, -0.4) * nominal).colwise() + Vector3d(3.0, 1.0, -0.5);
  const std::vector<Truth> truths = {
      {TaskKind::kPlane, flat, nullptr, {3, 4, 5}},  // the point is the centroid's foot: not a parameter
      {TaskKind::kBestFit, exact, Nominal(nominal), {0, 1, 2, 3, 4, 5}},
  };
  for (const Truth& t : truths) {
    SCOPED_TRACE(std::string(TaskKindName(t.kind)));
    const long n = t.points.cols();
    // Strongly unequal points and a shared part.
    auto v = Correlated(n, 2, 3);
    for (long i = 0; i < n; ++i) v->blocks[static_cast<std::size_t>(i)] *= (i % 4 == 0) ? 25.0 : 1.0;
    const Eigen::MatrixXd vd = Dense(*v);
    const Eigen::MatrixXd l = vd.llt().matrixL();
    const FitResult gls = FitTask(t.kind, t.points, Weighted(v, true, t.nominal));
    FitOptions ordinary;
    ordinary.nominal = t.nominal;
    ordinary.jacobian = true;
    const FitResult ols = FitTask(t.kind, t.points, ordinary);
    const Eigen::MatrixXd cov_gls = gls.jacobian * vd * gls.jacobian.transpose();
    const Eigen::MatrixXd cov_ols = ols.jacobian * vd * ols.jacobian.transpose();
    FitOptions trial;
    trial.nominal = t.nominal;
    trial.weights = gls.weights;
    trial.orientation = t.kind == TaskKind::kPlane ? Vector3d(gls.values.segment<3>(3)) : Vector3d::Zero();
    std::mt19937_64 rng(2024);
    std::normal_distribution<double> z;
    constexpr int kDraws = 4000;
    Eigen::MatrixXd values(gls.values.size(), kDraws);
    for (int d = 0; d < kDraws; ++d) {
      Eigen::VectorXd e(3 * n);
      for (long k = 0; k < e.size(); ++k) e(k) = z(rng);
      const Eigen::VectorXd shift = l * e;
      const Matrix3Xd drawn = t.points + Eigen::Map<const Matrix3Xd>(shift.data(), 3, n);
      values.col(d) = FitTask(t.kind, drawn, trial).values;
    }
    const Eigen::VectorXd mean = values.rowwise().mean();
    for (int q : t.parameters) {
      const double u_gum = std::sqrt(cov_gls(q, q));
      const double u_draws = std::sqrt((values.row(q).array() - mean(q)).square().sum() / (kDraws - 1));
      EXPECT_NEAR(u_draws / u_gum, 1.0, 0.07) << "output " << q;
      EXPECT_LE(cov_gls(q, q), cov_ols(q, q) * (1.0 + 1e-9)) << "output " << q;
      EXPECT_NEAR(mean(q), gls.values(q), 4.0 * u_gum / std::sqrt(kDraws)) << "output " << q;
    }
    // Gauss-Markov for the parameters together: cov_ols - cov_gls is positive semi-definite.
    const Eigen::VectorXi p =
        Eigen::Map<const Eigen::VectorXi>(t.parameters.data(), static_cast<long>(t.parameters.size()));
    const Eigen::MatrixXd diff = cov_ols(p, p) - cov_gls(p, p);
    EXPECT_GT(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(diff).eigenvalues().minCoeff(),
              -1e-9 * cov_ols(p, p).norm());
  }
}

// The weighted line does not depend on the frame it is given in, also where its direction's two
// smallest components swap (a basis rebuilt from each direction turned there by 90 degrees, and
// the 2 x 2 weights then weighted the wrong rows: up to 11 u off, found by a review). Each line is
// fitted as given and turned by R (points R x, covariance R V R^T) and turned back.
TEST(WeightedFits, TheWeightedLineIsTheSameInAnyFrameAlsoWhereItsBasisWouldSwap) {
  // Lines along x with 20 um of scatter: the direction's y and z components are both ~1e-5 and swap
  // in size from line to line and during a fit (the review's case: 87 of 300 lines off by > 1e-3 u,
  // up to 11 u). Anisotropic, unequal points: sigma_z up to 20 sigma_y.
  const Matrix3d turn = Rotation(0.4, -0.9, 1.3);
  std::mt19937_64 rng(7);
  std::normal_distribution<double> z;
  double worst = 0.0;
  for (int line = 0; line < 60; ++line) {
    Matrix3Xd points(3, 10);
    for (int i = 0; i < 10; ++i) points.col(i) << 2.0 * i / 9.0, 2e-5 * z(rng), 2e-5 * z(rng);
    auto v = std::make_shared<PointCovariance>();
    auto turned = std::make_shared<PointCovariance>();
    for (int i = 0; i < 10; ++i) {
      const Vector3d sigma(3e-6, 1e-6 * (1 + i % 3), 10e-6 * (1 + i % 2));
      v->blocks.push_back(sigma.cwiseAbs2().asDiagonal());
      turned->blocks.push_back(turn * v->blocks.back() * turn.transpose());
    }
    const FitResult a = FitLine(points, Weighted(v, true));
    const FitResult b = FitLine(turn * points, Weighted(turned, false));
    const Vector3d da = a.values.segment<3>(3), db = Like(turn.transpose() * b.values.segment<3>(3), da);
    const Eigen::MatrixXd cov =
        a.jacobian.middleRows(3, 3) * Dense(*v) * a.jacobian.middleRows(3, 3).transpose();
    for (int c = 1; c < 3; ++c) worst = std::max(worst, std::abs(da(c) - db(c)) / std::sqrt(cov(c, c)));
  }
  EXPECT_LT(worst, 1e-6);
}

TEST(WeightedFits, RefusesWhatIsNotALeastSquaresFitAndWeightsOfOtherPoints) {
  const Matrix3Xd plane = PlanePoints(12);
  EXPECT_THROW(FitTask(TaskKind::kDistance, plane.leftCols(2), Weighted(Correlated(2, 1, 1), false)),
               InputError);
  EXPECT_THROW(FitTask(TaskKind::kFlatness, plane, Weighted(Correlated(12, 1, 1), false)), InputError);
  const FitResult fit = FitPlane(plane, Weighted(Correlated(12, 1, 1), false));
  FitOptions other;
  other.weights = fit.weights;
  EXPECT_THROW(FitPlane(plane.leftCols(10), other), InputError);
  EXPECT_FALSE(Weightable(TaskKind::kFeatures));
  EXPECT_TRUE(Weightable(TaskKind::kRps));
  // A point covariance without each point's own part cannot be factored point by point; a dense
  // singular one refuses with a message, never NaN.
  auto singular = std::make_shared<PointCovariance>();
  singular->dense = Eigen::MatrixXd::Zero(36, 36);
  EXPECT_THROW(FitPlane(plane, Weighted(singular, true)), NumericalError);
}

// A plan of ten points on a flat panel seen from one station: the tracker's covariance (shared
// angle and range errors, each point's own noise) weights the plane.
std::string PanelJob(const std::string& weighting, const std::string& kind = "plane") {
  std::string job = R"(
[job]
name = "weighted"
[tracker]
model = "mirror"
[tracker.noise]
range = "5 um + 0.5 um/m"
azimuth = "0.5 arcsec"
elevation = "0.5 arcsec"
[plan]
point = [ {name = "P1", x = 2, y = -1, z = 0}, {name = "P2", x = 2.5, y = -0.5, z = 0.02},
          {name = "P3", x = 3, y = 0, z = 0.04}, {name = "P4", x = 3.5, y = 0.5, z = 0.06},
          {name = "P5", x = 6, y = 1, z = 0.16}, {name = "P6", x = 2, y = 1, z = 0},
          {name = "P7", x = 3, y = 1.5, z = 0.04}, {name = "P8", x = 7, y = -1.5, z = 0.2},
          {name = "P9", x = 2.2, y = 0.2, z = 0.008}, {name = "P10", x = 5, y = 0, z = 0.12} ]
[[task]]
name = "panel"
points = ["P1", "P2", "P3", "P4", "P5", "P6", "P7", "P8", "P9", "P10"]
[monte_carlo]
trials = 40000
seed = 5
)";
  job += "";
  const std::string task =
      "points = [\"P1\", \"P2\", \"P3\", \"P4\", \"P5\", \"P6\", \"P7\", \"P8\", \"P9\", \"P10\"]\n";
  job.insert(job.find(task) + task.size(), "kind = \"" + kind + "\"\n" + weighting);
  return job;
}

TEST(WeightedFits, OnATrackerJobTheGumAgreesWithMonteCarloAndWeightingHelps) {
  const Job job = ParseJob(PanelJob("weighting = \"both\"\n"), "weighted.toml", ".");
  ASSERT_EQ(job.tasks.size(), 2u);
  EXPECT_EQ(job.tasks[0].name, "panel");
  EXPECT_FALSE(job.tasks[0].weighted);
  EXPECT_EQ(job.tasks[1].name, "panel_weighted");
  EXPECT_TRUE(job.tasks[1].weighted);
  RunOptions options;
  options.compute_map = false;
  options.threads = 2;
  const Results r = RunJob(job, options);
  const TaskResult& ordinary = r.tasks[0];
  const TaskResult& weighted = r.tasks[1];
  ASSERT_TRUE(weighted.has_mcm);
  // Nominal points on a plane: the tracker's errors make the only scatter, so both fits find the
  // same plane at the estimates; their uncertainties differ.
  for (int q = 3; q < 6; ++q) {  // the normal
    EXPECT_NEAR(weighted.gum.value(q), ordinary.gum.value(q), 1e-12);
    EXPECT_NEAR(weighted.mcm[static_cast<std::size_t>(q)].u / weighted.gum.u(q), 1.0, 0.03) << q;
    EXPECT_LE(weighted.gum.u(q), ordinary.gum.u(q) * (1.0 + 1e-9)) << q;
  }
  // Noise-free points: r^T W r = 0, ten residuals less three parameters.
  EXPECT_LT(weighted.gum.chi2, 1e-12);
  EXPECT_EQ(weighted.gum.degrees_of_freedom, 7);
  const nlohmann::json j = nlohmann::json::parse(ResultsJson(r));
  EXPECT_EQ(j["tasks"][0]["weighting"], "none");
  EXPECT_EQ(j["tasks"][1]["weighting"], "covariance");
  EXPECT_EQ(j["tasks"][1]["weighted_fit"]["degrees_of_freedom"], 7);
}

// One InputError whose message holds `fragment`.
void ExpectRefused(const std::string& text, const std::string& fragment) {
  try {
    ParseJob(text, "weighted.toml", ".");
    ADD_FAILURE() << "accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

// weighting = "both" on an alignment: the deviations' weighted twins name the weighted frame.
TEST(WeightedFits, TheWeightedTwinsOfDeviationsNameTheWeightedAlignment) {
  std::string text = R"(
[tracker]
model = "mirror"
[tracker.noise]
range = "3 um"
azimuth = "0.4 arcsec"
elevation = "0.4 arcsec"
[readings]
csv = "panel_readings.csv"
columns = { name = "name", range = "distance", azimuth = "azimuth", elevation = "elevation" }
units = { range = "mm", azimuth = "deg", elevation = "deg" }
[nominal]
csv = "panel_nominal.csv"
unit = "mm"
[[alignment]]
name = "holes"
kind = "best_fit"
points = ["T1", "T2", "T3", "T4"]
weighting = "both"
[[deviation]]
name = "dev"
points = ["T1", "S08"]
)";
  const Job job = ParseJob(text, "twins.toml", std::string(VLT_SOURCE_DIR) + "/examples/alignment");
  std::vector<std::string> names, frames;
  for (const TaskSpec& t : job.tasks) {
    names.push_back(t.name);
    frames.push_back(t.nominal ? t.nominal->alignment : std::string());
  }
  EXPECT_EQ(names, (std::vector<std::string>{"holes", "holes_weighted", "dev.T1", "dev_weighted.T1",
                                             "dev.S08", "dev_weighted.S08"}));
  EXPECT_EQ(frames, (std::vector<std::string>{"", "", "holes", "holes_weighted", "holes", "holes_weighted"}));
  EXPECT_FALSE(job.tasks[2].weighted);
  EXPECT_TRUE(job.tasks[3].weighted);
}

TEST(WeightedFits, JobRefusesAnUnknownWeightingAndAKindThatIsNoFit) {
  ExpectRefused(PanelJob("weighting = \"gls\"\n"),
                "weighted.toml: task[0].weighting: unknown weighting 'gls'");
  ExpectRefused(PanelJob("weighting = \"covariance\"\n", "flatness"),
                "task[0].weighting: a flatness task is not a least-squares fit");
}

}  // namespace
}  // namespace vlt
