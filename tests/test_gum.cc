// GUM engine (vlt/gum.h) on the hand-written ideal spherical tracker: closed forms, finite
// differences and brute-force 3N x 3N references.
#include "vlt/gum.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "test_gum_ideal_tracker.h"
#include "vlt/error.h"
#include "vlt/models.h"

namespace vlt {
namespace {

UncertainInput In(double estimate, double u) {
  UncertainInput in;
  in.estimate = estimate;
  in.u = u;
  return in;
}

// Only the listed parameter is uncertain; no reading noise.
MeasurementSetup OnlyParam(int index, double u) {
  MeasurementSetup s;
  s.model = &test::kIdealTracker;
  s.params = {In(0, 0), In(0, 0), In(0, 0), In(0, 0)};
  s.params[index].u = u;
  return s;
}

MeasurementSetup FullSetup(bool correlated) {
  MeasurementSetup s;
  s.model = &test::kIdealTracker;
  s.params = {In(2e-6, 5e-6), In(1e-6, 2e-6), In(-3e-6, 4e-6), In(1e-6, 3e-6)};
  if (correlated) {
    Eigen::MatrixXd range(2, 2), angles(2, 2);
    range << 1.0, -0.6, -0.6, 1.0;
    angles << 1.0, 0.4, 0.4, 1.0;
    s.correlations = {{"range", {"r0", "mu"}, range, "", ""},
                      {"angles", {"azimuth_index", "elevation_index"}, angles, "", ""}};
  }
  s.noise = {3e-6, 0.5e-6, 2e-6, 2.5e-6};
  Environment e;
  e.temperature = In(21.0, 0.3);
  e.pressure = In(100800.0, 40.0);
  e.humidity = In(40.0, 8.0);
  e.co2 = In(450e-6, 40e-6);
  s.environment = e;
  StationPose p;
  p.rx = In(0.002, 4e-6);
  p.ry = In(-0.001, 4e-6);
  p.rz = In(0.5, 6e-6);
  p.tx = In(1.0, 5e-6);
  p.ty = In(2.0, 5e-6);
  p.tz = In(-0.3, 5e-6);
  s.pose = p;
  PartThermal t;
  t.cte = In(23e-6, 1e-6);
  t.temperature = In(21.5, 0.2);
  s.thermal = t;
  return s;
}

std::vector<PointReadings> SomePoints(int n, unsigned seed = 7) {
  std::mt19937 gen(seed);
  std::uniform_real_distribution<double> range(1.5, 20.0), az(-3.0, 3.0), el(-0.5, 0.8);
  std::vector<PointReadings> points;
  for (int i = 0; i < n; ++i) {
    PointReadings p;
    p.name = std::to_string(i + 1);
    p.name.insert(0, 1, 'P');  // (not "P" + ...: GCC 12 -Wrestrict false positive)
    p.readings = Eigen::Vector3d(range(gen), az(gen), el(gen));
    points.push_back(p);
  }
  return points;
}

// Independent Jacobian of y w.r.t. all inputs of a point (3 readings, S shared) by central
// differences of Evaluate.
Eigen::MatrixXd FiniteDifferenceJacobian(const MeasurementModel& m, const Eigen::Vector3d& r0) {
  const int s = m.num_shared();
  Eigen::MatrixXd j(3, 3 + s);
  Eigen::VectorXd x = m.shared_estimates();
  Eigen::Vector3d r = r0;
  auto column = [&](double* v, double h) {
    const double keep = *v;
    Eigen::Vector3d yp, ym;
    *v = keep + h;
    m.Evaluate(r.data(), x.data(), yp.data());
    *v = keep - h;
    m.Evaluate(r.data(), x.data(), ym.data());
    *v = keep;
    return Eigen::Vector3d((yp - ym) / (2 * h));
  };
  for (int k = 0; k < 3; ++k) j.col(k) = column(&r(k), k == 0 ? 1e-6 * r(0) : 1e-7);
  for (int k = 0; k < s; ++k) {
    const UncertainInput& in = m.shared_inputs()[k];
    const double h = in.group == "parameter" ? 1e-5 : std::max(in.u, 1e-9);
    j.col(3 + k) = column(&x(k), h);
  }
  return j;
}

// Covariance of all inputs of one point: diag(u_r^2) (+) U_s.
Eigen::MatrixXd InputCovariance(const MeasurementModel& m, double range) {
  const int s = m.num_shared();
  Eigen::MatrixXd cov = Eigen::MatrixXd::Zero(3 + s, 3 + s);
  cov.topLeftCorner(3, 3) = m.reading_uncertainty(range).cwiseAbs2().asDiagonal();
  Eigen::VectorXd u(s);
  for (int k = 0; k < s; ++k) u(k) = m.shared_inputs()[k].u;
  cov.bottomRightCorner(s, s) = u.asDiagonal() * m.shared_correlation() * u.asDiagonal();
  return cov;
}

// Brute-force joint covariance of N points (3N x 3N) from the full Jacobian [J_r blockdiag | J_s].
Eigen::MatrixXd JointCovariance(const MeasurementModel& m, const std::vector<PointReadings>& pts) {
  const int n = static_cast<int>(pts.size()), s = m.num_shared();
  Eigen::MatrixXd j = Eigen::MatrixXd::Zero(3 * n, 3 * n + s);
  Eigen::MatrixXd cov = Eigen::MatrixXd::Zero(3 * n + s, 3 * n + s);
  for (int i = 0; i < n; ++i) {
    const Eigen::MatrixXd ji = FiniteDifferenceJacobian(m, pts[i].readings);
    j.block(3 * i, 3 * i, 3, 3) = ji.leftCols(3);
    j.block(3 * i, 3 * n, 3, s) = ji.rightCols(s);
    const Eigen::MatrixXd ci = InputCovariance(m, pts[i].readings(0));
    cov.block(3 * i, 3 * i, 3, 3) = ci.topLeftCorner(3, 3);
    cov.bottomRightCorner(s, s) = ci.bottomRightCorner(s, s);
  }
  return j * cov * j.transpose();
}

Eigen::MatrixXd DistanceG(const Eigen::Vector3d& p1, const Eigen::Vector3d& p2) {
  const Eigen::Vector3d d = (p2 - p1).normalized();
  Eigen::MatrixXd g(1, 6);
  g << -d.transpose(), d.transpose();
  return g;
}

TEST(GumCoverage, FactorsComputedFromTheDistributions) {
  EXPECT_NEAR(NormalCoverageFactor(0.95), 1.959963984540054, 1e-12);
  EXPECT_NEAR(NormalCoverageFactor(0.99), 2.575829303548901, 1e-12);
  EXPECT_NEAR(NormalCoverageFactor(0.6826894921370859), 1.0, 1e-12);
  // chi^2 quantiles (JCGM 102 6.5.2.3: 2.448 for m = 2, 2.796 for m = 3 at 95 %).
  EXPECT_NEAR(ChiSquareCoverageFactor(0.95, 1), 1.959963984540054, 1e-12);
  EXPECT_NEAR(ChiSquareCoverageFactor(0.95, 2), std::sqrt(-2.0 * std::log(0.05)), 1e-12);
  EXPECT_NEAR(ChiSquareCoverageFactor(0.95, 3), std::sqrt(7.814727903251178), 1e-12);
  EXPECT_NEAR(ChiSquareCoverageFactor(0.95, 3), 2.796, 1e-3);  // published to 3 decimals
  EXPECT_NEAR(ChiSquareCoverageFactor(0.99, 4) * ChiSquareCoverageFactor(0.99, 4), 13.276704135987622, 1e-9);
  EXPECT_THROW(NormalCoverageFactor(1.0), std::invalid_argument);
}

TEST(GumUnits, SensitivityUnitStrings) {
  EXPECT_EQ(SensitivityUnit("m", "rad"), "m/rad");
  EXPECT_EQ(SensitivityUnit("m", "m"), "m/m");
  EXPECT_EQ(SensitivityUnit("m", "1"), "m");
  EXPECT_EQ(SensitivityUnit("m", "degC"), "m/K");
  EXPECT_EQ(SensitivityUnit("m", "Pa"), "m/Pa");
  EXPECT_EQ(SensitivityUnit("m", "%"), "m/%");
  EXPECT_EQ(SensitivityUnit("m", "1/K"), "m*K");
  EXPECT_EQ(SensitivityUnit("1", "m"), "1/m");
  EXPECT_EQ(SensitivityUnit("1", "1/K"), "K");
}

TEST(GumTask, RangeScaleOnOneLineOfSightIsFullyCorrelated) {
  const double u_mu = 3e-6;
  MeasurementModel m(OnlyParam(1, u_mu));
  const double rho1 = 2.5, rho2 = 17.0;
  const std::vector<PointReadings> pts = {{"near", {rho1, 0.4, 0.1}}, {"far", {rho2, 0.4, 0.1}}};
  const auto y = PointEstimates(m, pts);
  TaskUncertainty t;
  t.name = "d";
  const int idx[] = {0, 1};
  PropagateTaskCovariance(m, pts, idx, DistanceG(y[0], y[1]), {}, t);
  // Closed form: d = (1 + mu)(rho2 - rho1) -> u(d) = u(mu) |rho2 - rho1| (not the RSS of points).
  EXPECT_NEAR(t.u(0), u_mu * (rho2 - rho1), 1e-12 * u_mu * (rho2 - rho1) + 1e-20);
  const auto points = PropagatePoints(m, pts);
  EXPECT_NEAR(points[0].los_tracker.u_radial, u_mu * rho1, 1e-18);
  const double rss = std::hypot(u_mu * rho1, u_mu * rho2);
  EXPECT_GT(std::abs(t.u(0) - rss), 1e-6);
}

TEST(GumTask, AzimuthIndexLeavesDistanceAtSameRangeUnchanged) {
  MeasurementModel m(OnlyParam(2, 5e-6));
  const std::vector<PointReadings> pts = {{"A", {8.0, -1.0, 0.2}}, {"B", {8.0, 1.3, 0.2}}};
  const auto points = PropagatePoints(m, pts);
  EXPECT_GT(points[0].u_part.norm(), 1e-5);
  EXPECT_GT(points[1].u_part.norm(), 1e-5);
  const auto y = PointEstimates(m, pts);
  TaskUncertainty t;
  const int idx[] = {0, 1};
  PropagateTaskCovariance(m, pts, idx, DistanceG(y[0], y[1]), {}, t);
  const double d = (y[1] - y[0]).norm();
  EXPECT_LE(t.u(0), 1e-15 * d);
}

TEST(GumPoint, CovarianceEqualsFiniteDifferencePropagation) {
  for (bool correlated : {false, true}) {
    MeasurementModel m(FullSetup(correlated));
    const auto pts = SomePoints(5);
    const auto res = PropagatePoints(m, pts);
    for (std::size_t i = 0; i < pts.size(); ++i) {
      const Eigen::MatrixXd j = FiniteDifferenceJacobian(m, pts[i].readings);
      const Eigen::Matrix3d ref = j * InputCovariance(m, pts[i].readings(0)) * j.transpose();
      EXPECT_LE((res[i].cov_part - ref).norm(), 1e-6 * ref.norm()) << pts[i].name;
      EXPECT_NEAR(res[i].U_part(0), 1.959963984540054 * std::sqrt(ref(0, 0)), 1e-6 * std::sqrt(ref(0, 0)));
    }
  }
}

TEST(GumPoint, TrackerFrameCovarianceIsTheInstrumentPart) {
  MeasurementSetup full = FullSetup(true);
  MeasurementSetup instrument = full;
  instrument.pose.reset();
  instrument.thermal.reset();
  MeasurementModel m(full), mi(instrument);
  const auto pts = SomePoints(4);
  const auto a = PropagatePoints(m, pts), b = PropagatePoints(mi, pts);
  for (std::size_t i = 0; i < pts.size(); ++i) {
    EXPECT_LE((a[i].cov_tracker - b[i].cov_part).norm(), 1e-10 * b[i].cov_part.norm());
    EXPECT_LE((a[i].tracker - b[i].part).norm(), 1e-12);
    EXPECT_NEAR(a[i].los_tracker.u_radial, b[i].los_part.u_radial, 1e-12);
  }
}

TEST(GumPoint, LineOfSightSplitClosedForm) {
  // Reading noise only: u_radial = u(range), u_h = rho cos E u(A), u_v = rho u(E).
  MeasurementSetup s = OnlyParam(0, 0.0);
  s.noise = {2e-6, 1e-6, 3e-6, 4e-6};
  StationPose p;
  p.rz = In(1.1, 0.0);
  p.rx = In(0.2, 0.0);
  s.pose = p;
  MeasurementModel m(s);
  const double rho = 6.0, e = 0.35;
  const std::vector<PointReadings> pts = {{"Q", {rho, 2.0, e}}};
  const auto r = PropagatePoints(m, pts)[0];
  for (const LineOfSightSplit& split : {r.los_tracker, r.los_part}) {
    EXPECT_NEAR(split.u_radial, 2e-6 + 1e-6 * rho, 1e-15);
    EXPECT_NEAR(split.u_horizontal, rho * std::cos(e) * 3e-6, 1e-15);
    EXPECT_NEAR(split.u_vertical, rho * 4e-6, 1e-15);
  }
  // The ellipsoid's semi-axes are k3 times the three line-of-sight u's.
  const double k3 = ChiSquareCoverageFactor(0.95, 3);
  EXPECT_NEAR(r.ellipsoid.semi_axes(0), k3 * rho * 4e-6, 1e-14);
  EXPECT_NEAR(r.ellipsoid.semi_axes(1), k3 * rho * std::cos(e) * 3e-6, 1e-14);
  EXPECT_NEAR(r.ellipsoid.semi_axes(2), k3 * (2e-6 + 1e-6 * rho), 1e-14);
  EXPECT_NEAR(std::abs(r.ellipsoid.directions.col(2).dot(r.los_part.directions.col(0))), 1.0, 1e-9);
}

// The budget lists its rows by share of trace(U_y), largest first; rows of equal share (inputs
// that do not vary: 0) keep the inputs' order (range, azimuth, elevation, then the shared inputs
// as the model lists them), and each row carries its own input's estimate and u.
TEST(GumBudget, EqualSharesKeepTheInputOrder) {
  MeasurementSetup s = FullSetup(false);
  s.params[3].u = 0.0;
  s.params[1].u = 0.0;
  s.pose->ry.u = 0.0;
  s.pose->tx.u = 0.0;
  MeasurementModel m(s);
  std::vector<std::string> input_order = {"range", "azimuth", "elevation"};
  for (const UncertainInput& in : m.shared_inputs()) input_order.push_back(in.name);
  auto position = [&](const std::string& name) {
    return std::find(input_order.begin(), input_order.end(), name) - input_order.begin();
  };
  const auto pts = SomePoints(3);
  const auto res = PropagatePoints(m, pts);
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const auto& budget = res[i].budget;
    ASSERT_EQ(budget.size(), input_order.size());
    int zero_rows = 0;
    for (std::size_t b = 0; b < budget.size(); ++b) {
      const BudgetRow& row = budget[b];
      const auto at = position(row.input);
      ASSERT_LT(at, static_cast<std::ptrdiff_t>(input_order.size())) << row.input;
      if (at >= 3) {
        EXPECT_EQ(row.u, m.shared_inputs()[at - 3].u) << row.input;
        EXPECT_EQ(row.estimate, m.shared_inputs()[at - 3].estimate) << row.input;
      } else {
        EXPECT_EQ(row.estimate, pts[i].readings(at)) << row.input;
      }
      if (b == 0) continue;
      EXPECT_GE(budget[b - 1].share_total, row.share_total);
      if (budget[b - 1].share_total == row.share_total) {
        EXPECT_LT(position(budget[b - 1].input), at);
      }
      if (row.share_total == 0.0) ++zero_rows;
    }
    EXPECT_EQ(zero_rows, 4);
  }
}

TEST(GumBudget, SensitivitiesUnitsAndShares) {
  for (bool correlated : {false, true}) {
    MeasurementModel m(FullSetup(correlated));
    const auto pts = SomePoints(3);
    const auto res = PropagatePoints(m, pts);
    for (std::size_t i = 0; i < pts.size(); ++i) {
      const Eigen::MatrixXd j = FiniteDifferenceJacobian(m, pts[i].readings);
      const auto& budget = res[i].budget;
      ASSERT_EQ(budget.size(), 3u + m.num_shared() + (correlated ? 1u : 0u));
      Eigen::Vector3d share_sum = Eigen::Vector3d::Zero();
      for (std::size_t b = 0; b < budget.size(); ++b) {
        const BudgetRow& row = budget[b];
        share_sum += row.share;
        if (b > 0) {
          EXPECT_GE(budget[b - 1].share_total, row.share_total);
        }
        if (row.group == "correlation") {
          EXPECT_EQ(row.input, "correlations");
          continue;
        }
        int col = -1;
        if (row.input == "range") col = 0;
        if (row.input == "azimuth") col = 1;
        if (row.input == "elevation") col = 2;
        for (int k = 0; k < m.num_shared(); ++k) {
          if (m.shared_inputs()[k].name == row.input) col = 3 + k;
        }
        ASSERT_GE(col, 0) << row.input;
        const Eigen::Vector3d fd = j.col(col);
        // 1e-5: truncation error of the central difference with step u (n(t) is curved).
        EXPECT_LE((row.sensitivity - fd).norm(), 1e-5 * fd.norm() + 1e-12) << row.input;
        EXPECT_LE((row.contribution - row.sensitivity * row.u).norm(), 1e-20);
      }
      EXPECT_NEAR(share_sum(0), 1.0, 1e-12);
      EXPECT_NEAR(share_sum(1), 1.0, 1e-12);
      EXPECT_NEAR(share_sum(2), 1.0, 1e-12);
      auto unit_of = [&](const std::string& name) {
        for (const BudgetRow& row : budget) {
          if (row.input == name) return row.sensitivity_unit;
        }
        return std::string("missing");
      };
      EXPECT_EQ(unit_of("range"), "m/m");
      EXPECT_EQ(unit_of("azimuth"), "m/rad");
      EXPECT_EQ(unit_of("r0"), "m/m");
      EXPECT_EQ(unit_of("mu"), "m");
      EXPECT_EQ(unit_of("environment.temperature"), "m/K");
      EXPECT_EQ(unit_of("environment.pressure"), "m/Pa");
      EXPECT_EQ(unit_of("environment.humidity"), "m/%");
      EXPECT_EQ(unit_of("thermal.cte"), "m*K");
      EXPECT_EQ(unit_of("pose.rz"), "m/rad");
    }
    EXPECT_NE(res[0].correlation_handling.find(correlated ? "correlations" : "uncorrelated"),
              std::string::npos);
  }
}

TEST(GumPoint, SingularPointsNameThePoint) {
  MeasurementModel m(FullSetup(false));
  std::vector<PointReadings> pts = {
      {"ok", {5.0, 0.1, 0.1}}, {"zenith", {3.0, 0.2, std::numbers::pi / 2 - 1e-6}}};  // E' = E + 1e-6 index
  try {
    PropagatePoints(m, pts);
    FAIL() << "no exception";
  } catch (const NumericalError& e) {
    EXPECT_NE(std::string(e.what()).find("'zenith'"), std::string::npos) << e.what();
  }
  pts[1] = {"zero", {0.0, 0.2, 0.1}};
  try {
    PropagatePoints(m, pts);
    FAIL() << "no exception";
  } catch (const NumericalError& e) {
    EXPECT_NE(std::string(e.what()).find("'zero'"), std::string::npos) << e.what();
  }
  const std::vector<Eigen::Vector3d> field = {{2.0, 0.0, 0.0}, {0.0, 0.0, 0.0}};
  EXPECT_THROW(ExpandedUncertaintyField(m, field), NumericalError);
  // A part point that lies on the standing axis once the pose and thermal are undone.
  const Eigen::VectorXd x = m.shared_estimates();
  const Eigen::Vector3d on_axis =
      m.ThermalScale(x.data()) *
      (m.PoseRotation(x.data()) * Eigen::Vector3d(0, 0, 2.0) + m.PoseTranslation(x.data()));
  try {
    ReadingsForPartPoint(m, on_axis, false, "top");
    FAIL() << "no exception";
  } catch (const NumericalError& e) {
    EXPECT_NE(std::string(e.what()).find("'top'"), std::string::npos) << e.what();
  }
}

TEST(GumTask, CovarianceEqualsBruteForceJointCovariance) {
  for (bool correlated : {false, true}) {
    MeasurementModel m(FullSetup(correlated));
    const auto pts = SomePoints(6);
    const Eigen::MatrixXd joint = JointCovariance(m, pts);
    // An arbitrary task Jacobian (4 quantities) over points 5, 1, 3, 0 (in that order).
    const int idx[] = {5, 1, 3, 0};
    std::mt19937 gen(3);
    std::normal_distribution<double> nd;
    Eigen::MatrixXd g(4, 12);
    for (int i = 0; i < g.size(); ++i) g.data()[i] = nd(gen);
    Eigen::MatrixXd g_full = Eigen::MatrixXd::Zero(4, 18);
    for (int j = 0; j < 4; ++j) g_full.middleCols(3 * idx[j], 3) = g.middleCols(3 * j, 3);
    const Eigen::MatrixXd ref = g_full * joint * g_full.transpose();
    TaskUncertainty t;
    PropagateTaskCovariance(m, pts, idx, g, {}, t);
    EXPECT_LE((t.covariance - ref).norm(), 1e-6 * ref.norm());
    // The group budget adds up to the total.
    Eigen::VectorXd sum = Eigen::VectorXd::Zero(4);
    for (const auto& group : t.budget) sum += group.variance;
    EXPECT_LE((sum - t.covariance.diagonal()).norm(), 1e-12 * sum.norm());
    // Per-input variances plus the correlation column give the shared part.
    const Eigen::VectorXd shared = t.shared_input_variance.rowwise().sum();
    Eigen::VectorXd shared_groups = Eigen::VectorXd::Zero(4);
    for (const auto& group : t.budget) {
      if (group.group != "readings") shared_groups += group.variance;
    }
    EXPECT_LE((shared - shared_groups).norm(), 1e-12 * shared.norm());
  }
}

TEST(GumTask, ThreadCountDoesNotChangeTheResult) {
  MeasurementModel m(FullSetup(true));
  const auto pts = SomePoints(5000);
  std::vector<int> idx(pts.size());
  for (std::size_t i = 0; i < idx.size(); ++i) idx[i] = static_cast<int>(i);
  Eigen::MatrixXd g = Eigen::MatrixXd::Constant(3, 3 * pts.size(), 1e-3);
  TaskUncertainty a, b;
  GumOptions one, two;
  one.threads = 1;
  two.threads = 2;
  PropagateTaskCovariance(m, pts, idx, g, one, a);
  PropagateTaskCovariance(m, pts, idx, g, two, b);
  EXPECT_EQ(a.covariance, b.covariance);
  const auto pa = PropagatePoints(m, pts, one), pb = PropagatePoints(m, pts, two);
  EXPECT_EQ(pa[4321].cov_part, pb[4321].cov_part);
}

TEST(GumTask, LowRankPathHandlesHundredThousandPoints) {
  // A 3N x 3N joint covariance would need 720 GB here; the low-rank path needs O(N + k S).
  MeasurementModel m(OnlyParam(1, 2e-6));
  const int n = 100000;
  std::vector<PointReadings> pts(n);
  for (int i = 0; i < n; ++i) pts[i] = {"", {1.0 + 1e-4 * i, 0.3, 0.05}};
  std::vector<int> idx(n);
  for (int i = 0; i < n; ++i) idx[i] = i;
  // Mean range of all points: G = (1/n) d_i^T per point; closed form u = u(mu) * mean(rho).
  const Eigen::Vector3d d(std::cos(0.05) * std::cos(0.3), std::cos(0.05) * std::sin(0.3), std::sin(0.05));
  Eigen::MatrixXd g(1, 3 * n);
  for (int i = 0; i < n; ++i) g.middleCols(3 * i, 3) = d.transpose() / n;
  TaskUncertainty t;
  PropagateTaskCovariance(m, pts, idx, g, {}, t);
  const double mean_rho = 1.0 + 1e-4 * (n - 1) / 2.0;
  EXPECT_NEAR(t.u(0), 2e-6 * mean_rho, 1e-9 * 2e-6 * mean_rho);
}

TEST(GumField, EqualsFullPropagation) {
  for (bool correlated : {false, true}) {
    MeasurementModel m(FullSetup(correlated));
    const auto pts = SomePoints(50);
    std::vector<Eigen::Vector3d> readings;
    for (const auto& p : pts) readings.push_back(p.readings);
    const auto field = ExpandedUncertaintyField(m, readings, 0.95);
    GumOptions lean;
    lean.budgets = false;
    const auto full = PropagatePoints(m, pts, lean);
    for (std::size_t i = 0; i < pts.size(); ++i) {
      EXPECT_LE((field[i] - full[i].U_part).norm(), 1e-12 * full[i].U_part.norm());
      EXPECT_TRUE(full[i].budget.empty());
    }
  }
}

// The lean covariance path against the full propagation (an independent summation: Eigen's
// products there, scalar sums here), with correlated inputs, and with the generated mirror model
// at its nominal parameters, where the points go through the SIMD lanes (61 points: 15 batches of
// 4 and one of 1; an invalid point in a batch reports its own index, as one by one).
TEST(GumCovarianceField, EqualsFullPropagation) {
  std::vector<MeasurementSetup> setups = {FullSetup(false), FullSetup(true)};
  MeasurementSetup mirror = FullSetup(false);
  mirror.model = FindModel("mirror");
  mirror.params.clear();
  for (int k = 0; k < mirror.model->num_params; ++k)
    mirror.params.push_back(In(0.0, mirror.model->params[k].default_u));
  setups.push_back(mirror);
  for (const MeasurementSetup& setup : setups) {
    MeasurementModel m(setup);
    const auto pts = SomePoints(61);
    std::vector<Eigen::Vector3d> readings;
    for (const auto& p : pts) readings.push_back(p.readings);
    GumOptions lean;
    lean.budgets = false;
    const auto full = PropagatePoints(m, pts, lean);
    for (int threads : {1, 2}) {
      const auto cov = CovarianceField(m, readings, threads);
      ASSERT_EQ(cov.size(), pts.size());
      for (std::size_t i = 0; i < pts.size(); ++i) {
        EXPECT_LE((cov[i] - full[i].cov_part).norm(), 1e-13 * full[i].cov_part.norm()) << i;
        EXPECT_EQ(cov[i], cov[i].transpose());
      }
    }
    readings[37](0) = -1.0;
    try {
      CovarianceField(m, readings, 1);
      ADD_FAILURE() << "no error for a negative range";
    } catch (const NumericalError& e) {
      EXPECT_NE(std::string(e.what()).find("point #38:"), std::string::npos) << e.what();
    }
  }
}

TEST(GumPlan, ReadingsReproduceTheNominalPoint) {
  // Non-zero parameter estimates: the Newton inverse must account for them.
  MeasurementModel m(FullSetup(false));
  const Eigen::VectorXd x = m.shared_estimates();
  for (bool back : {false, true}) {
    for (const Eigen::Vector3d& part : {Eigen::Vector3d(4.0, -2.0, 0.5), Eigen::Vector3d(-3.0, 7.0, 2.0)}) {
      const Eigen::Vector3d r = ReadingsForPartPoint(m, part, back, "N");
      Eigen::Vector3d y;
      m.Evaluate(r.data(), x.data(), y.data());
      EXPECT_LE((y - part).norm(), 1e-11) << back;
      if (back) {
        EXPECT_GT(r(2), std::numbers::pi / 2);
      }
    }
  }
}

// JCGM 101 9.2 additive model through the custom-model path (hand-written ModelInfo here; the
// generated jcgm101_additive is tested in test_gum_generated.cc).
void AdditiveJacobians(const double*, const double* x, double* y, double*, double* j) {
  y[0] = x[0] + x[1] + x[2] + x[3];
  for (int k = 0; k < 4; ++k) j[k] = 1.0;
}
void AdditiveForward(const double* r, const double* x, double* y) {
  double j[4];
  AdditiveJacobians(r, x, y, nullptr, j);
}
const QuantityInfo kAdditiveInputs[] = {{"x1", "1", "dimensionless", "", 0, 1, "normal", 0},
                                        {"x2", "1", "dimensionless", "", 0, 1, "normal", 0},
                                        {"x3", "1", "dimensionless", "", 0, 1, "normal", 0},
                                        {"x4", "1", "dimensionless", "", 0, 1, "normal", 0}};
const QuantityInfo kAdditiveOutputs[] = {{"y", "1", "dimensionless", "", 0, 0, "normal", 0}};
const ModelInfo kAdditive = {"additive_test",
                             "custom",
                             "",
                             "",
                             0,
                             4,
                             1,
                             nullptr,
                             kAdditiveInputs,
                             kAdditiveOutputs,
                             &AdditiveForward,
                             &AdditiveJacobians,
                             nullptr,
                             nullptr,
                             nullptr,
                             nullptr,
                             nullptr,
                             nullptr,
                             0,
                             0,
                             0,
                             0};

TEST(GumCustom, Jcgm101AdditiveModel) {
  std::vector<UncertainInput> in = {In(0, 1), In(0, 1), In(0, 1), In(0, 1)};
  auto r = PropagateCustom(kAdditive, in);
  EXPECT_NEAR(r.outputs[0].u, 2.0, 1e-15);
  EXPECT_NEAR(r.outputs[0].U, 3.92, 0.005);
  in[3].u = 10.0;
  r = PropagateCustom(kAdditive, in);
  EXPECT_NEAR(r.outputs[0].u, std::sqrt(103.0), 1e-13);
  EXPECT_NEAR(r.outputs[0].u, 10.15, 0.005);
  EXPECT_NEAR(r.outputs[0].U, 19.89, 0.005);
  EXPECT_EQ(r.outputs[0].budget[0].input, "x4");
  EXPECT_NEAR(r.outputs[0].budget[0].share(0), 100.0 / 103.0, 1e-14);
  // Correlated inputs: the correlation row carries 2 c1 c2 u1 u2 r12.
  Eigen::MatrixXd c = Eigen::MatrixXd::Identity(4, 4);
  c(0, 1) = c(1, 0) = 0.5;
  r = PropagateCustom(kAdditive, in, c);
  EXPECT_NEAR(r.outputs[0].u * r.outputs[0].u, 104.0, 1e-12);
  double sum = 0.0;
  for (const auto& row : r.outputs[0].budget) {
    sum += row.share(0);
    if (row.input == "correlations") {
      EXPECT_NEAR(row.variance(0), 1.0, 1e-12);
    }
  }
  EXPECT_NEAR(sum, 1.0, 1e-14);
}

}  // namespace
}  // namespace vlt
