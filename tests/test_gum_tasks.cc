// GUM task propagation (PropagateTask: fits.h features over correlated points) against an
// independent brute-force reference: the 3N x 3N joint covariance of the points from central-
// difference Jacobians of MeasurementModel::Evaluate, and G from central differences of the fit
// values, cov = G U_joint G^T. Plus closed forms on 10^5 points (low-rank path).
#include <cmath>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "vlt/fits.h"
#include "vlt/gum.h"
#include "vlt/models.h"

namespace vlt {
namespace {

UncertainInput In(double estimate, double u) {
  UncertainInput in;
  in.estimate = estimate;
  in.u = u;
  return in;
}

MeasurementSetup MirrorSetup() {
  const ModelInfo* info = FindModel("mirror");
  MeasurementSetup s;
  s.model = info;
  for (int k = 0; k < info->num_params; ++k) {
    // Non-zero estimates so the general (not nominal) Jacobian kernel is used.
    s.params.push_back(In(0.3 * info->params[k].default_u, info->params[k].default_u));
  }
  Eigen::MatrixXd r(2, 2);
  r << 1.0, 0.5, 0.5, 1.0;
  s.correlations = {{"pair", {info->params[0].name, info->params[3].name}, r, "", ""}};
  s.noise = {5e-6, 0.5e-6, 1.5e-6, 1.5e-6};
  Environment e;
  e.temperature = In(20.5, 0.2);
  e.pressure = In(101000.0, 50.0);
  e.humidity = In(45.0, 10.0);
  e.co2 = In(450e-6, 50e-6);
  s.environment = e;
  StationPose p;
  p.rx = In(0.001, 3e-6);
  p.ry = In(0.002, 3e-6);
  p.rz = In(-0.4, 5e-6);
  p.tx = In(3.0, 8e-6);
  p.ty = In(-1.0, 8e-6);
  p.tz = In(0.2, 8e-6);
  s.pose = p;
  PartThermal t;
  t.cte = In(11.5e-6, 1e-6);
  t.temperature = In(20.8, 0.1);
  s.thermal = t;
  return s;
}

std::vector<PointReadings> Plan(const MeasurementModel& m, const std::vector<Eigen::Vector3d>& part) {
  std::vector<PointReadings> pts;
  for (std::size_t i = 0; i < part.size(); ++i) {
    std::string name = std::to_string(i);
    name.insert(0, 1, 'P');
    pts.push_back({name, ReadingsForPartPoint(m, part[i], false, name)});
  }
  return pts;
}

Eigen::MatrixXd FdPointJacobian(const MeasurementModel& m, const Eigen::Vector3d& r0) {
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
    j.col(3 + k) = column(&x(k), in.group == "parameter" ? 1e-6 : std::max(0.1 * in.u, 1e-9));
  }
  return j;
}

// Brute force: 3N x 3N covariance of all points of `pts`.
Eigen::MatrixXd JointCovariance(const MeasurementModel& m, const std::vector<PointReadings>& pts) {
  const int n = static_cast<int>(pts.size()), s = m.num_shared();
  Eigen::MatrixXd j = Eigen::MatrixXd::Zero(3 * n, 3 * n + s);
  Eigen::MatrixXd cov = Eigen::MatrixXd::Zero(3 * n + s, 3 * n + s);
  Eigen::VectorXd u(s);
  for (int k = 0; k < s; ++k) u(k) = m.shared_inputs()[k].u;
  cov.bottomRightCorner(s, s) = u.asDiagonal() * m.shared_correlation() * u.asDiagonal();
  for (int i = 0; i < n; ++i) {
    const Eigen::MatrixXd ji = FdPointJacobian(m, pts[i].readings);
    j.block(3 * i, 3 * i, 3, 3) = ji.leftCols(3);
    j.block(3 * i, 3 * n, 3, s) = ji.rightCols(s);
    cov.block(3 * i, 3 * i, 3, 3) = m.reading_uncertainty(pts[i].readings(0)).cwiseAbs2().asDiagonal();
  }
  return j * cov * j.transpose();
}

// G by central differences of the fit values.
Eigen::MatrixXd FdFitJacobian(TaskKind kind, const Eigen::Matrix3Xd& points) {
  FitOptions options;
  const FitResult base = FitTask(kind, points, options);
  // Keep the sign of normals/directions fixed while differencing.
  if (kind == TaskKind::kPlane || kind == TaskKind::kCircle) {
    options.orientation = base.values.segment<3>(kind == TaskKind::kPlane ? 3 : 4);
  }
  if (kind == TaskKind::kLine || kind == TaskKind::kCylinder || kind == TaskKind::kCone) {
    options.orientation = base.values.segment<3>(3);
  }
  Eigen::MatrixXd g(base.values.size(), points.size());
  for (int c = 0; c < points.size(); ++c) {
    Eigen::Matrix3Xd p = points;
    const double h = 1e-7;
    p.data()[c] += h;
    const Eigen::VectorXd plus = FitTask(kind, p, options).values;
    p.data()[c] -= 2 * h;
    const Eigen::VectorXd minus = FitTask(kind, p, options).values;
    g.col(c) = (plus - minus) / (2 * h);
  }
  return g;
}

class GumTaskBruteForce : public testing::TestWithParam<TaskKind> {};

TEST_P(GumTaskBruteForce, EqualsJointCovariance) {
  const TaskKind kind = GetParam();
  MeasurementModel m(MirrorSetup());
  std::mt19937 gen(11);
  std::normal_distribution<double> noise(0.0, 2e-4);
  std::vector<Eigen::Vector3d> part;
  const int n = kind == TaskKind::kDistance || kind == TaskKind::kTwoFace ? 2 : 8;
  for (int i = 0; i < n; ++i) {
    const double t = 2.0 * std::numbers::pi * i / n;
    Eigen::Vector3d p = Eigen::Vector3d::Zero();
    switch (kind) {
      case TaskKind::kDistance: p = Eigen::Vector3d(2.0 + 3.0 * i, 1.0, 0.5 * i); break;
      case TaskKind::kPlane: p = Eigen::Vector3d(1.0 + 0.3 * i, 0.5 * std::sin(3.0 * i), 0.1); break;
      case TaskKind::kSphere: {
        // Spread over more than a hemisphere (well-conditioned centre and radius).
        const double el = -0.6 + 1.8 * i / (n - 1);
        p = Eigen::Vector3d(2.0, 1.0, 0.3) + 0.2 * Eigen::Vector3d(std::cos(2.4 * i) * std::cos(el),
                                                                   std::sin(2.4 * i) * std::cos(el),
                                                                   std::sin(el));
        break;
      }
      case TaskKind::kCircle:
        p = Eigen::Vector3d(2.5, -0.5, 0.4) +
            0.3 * Eigen::Vector3d(std::cos(t), std::sin(t), 0.1 * std::cos(t));
        break;
      case TaskKind::kLine: p = Eigen::Vector3d(1.0 + 0.5 * i, 0.2 * i, 0.3); break;
      // Two rings of four, 0.2 m apart, about a vertical axis (the cone widens by 0.05 m).
      case TaskKind::kCylinder:
      case TaskKind::kCone: {
        const double height = i < n / 2 ? -0.1 : 0.1;
        const double radius = 0.15 + (kind == TaskKind::kCone && i >= n / 2 ? 0.05 : 0.0);
        const double phi = 4.0 * t + (i < n / 2 ? 0.0 : 0.7);
        p = Eigen::Vector3d(2.0, 0.5, 0.2) + Eigen::Vector3d(radius * std::cos(phi), radius * std::sin(phi), height);
        break;
      }
      // The same point twice (both front face here; tests/test_two_face.cc has the back face):
      // coincident points, where a distance would be refused.
      case TaskKind::kTwoFace: p = Eigen::Vector3d(3.0, 1.5, 0.4); break;
      // The alignment kinds need a nominal geometry: tests/test_alignment.cc.
      case TaskKind::kBestFit:
      case TaskKind::kBestFitScale:
      case TaskKind::kRps:
      case TaskKind::kFeatures:
      case TaskKind::kDeviation:
      case TaskKind::kPosition:
      case TaskKind::kProfile: break;
      // Not differentiable (no GUM value): tests/test_minimum_zone.cc.
      case TaskKind::kFlatness:
      case TaskKind::kStraightness:
      case TaskKind::kRoundness:
      case TaskKind::kCylindricity: break;
    }
    if (kind != TaskKind::kDistance && kind != TaskKind::kTwoFace) {
      p += Eigen::Vector3d(noise(gen), noise(gen), noise(gen));
    }
    part.push_back(p);
  }
  const std::vector<PointReadings> pts = Plan(m, part);
  TaskSpec task{"t", kind, {}, {}};
  for (const auto& p : pts) task.points.push_back(p.name);
  const TaskUncertainty t = PropagateTask(m, pts, task);

  const std::vector<Eigen::Vector3d> y = PointEstimates(m, pts);
  Eigen::Matrix3Xd coords(3, y.size());
  for (std::size_t i = 0; i < y.size(); ++i) coords.col(i) = y[i];
  const Eigen::MatrixXd g = FdFitJacobian(kind, coords);
  const Eigen::MatrixXd ref = g * JointCovariance(m, pts) * g.transpose();
  ASSERT_EQ(t.covariance.rows(), ref.rows());
  // The engine itself, fed the finite-difference G, reproduces the brute force closely ...
  {
    TaskUncertainty fd_task;
    std::vector<int> idx;
    for (int i = 0; i < n; ++i) idx.push_back(i);
    PropagateTaskCovariance(m, pts, idx, g, {}, fd_task);
    EXPECT_LE((fd_task.covariance - ref).norm(), 1e-7 * ref.norm());
  }
  // ... and with the fits' exact G (PropagateTask) to the accuracy of the differenced fit.
  for (int q = 0; q < ref.rows(); ++q) {
    if (!t.differentiable[q]) continue;
    const double u_ref = std::sqrt(ref(q, q));
    EXPECT_NEAR(t.u(q), u_ref, 1e-4 * u_ref + 1e-13) << t.quantities[q];
  }
  EXPECT_TRUE(t.covariance.allFinite());
}

INSTANTIATE_TEST_SUITE_P(AllKinds, GumTaskBruteForce,
                         testing::Values(TaskKind::kDistance, TaskKind::kPlane, TaskKind::kSphere,
                                         TaskKind::kCircle, TaskKind::kLine, TaskKind::kTwoFace,
                                         TaskKind::kCylinder, TaskKind::kCone),
                         [](const testing::TestParamInfo<TaskKind>& info) {
                           return std::string(TaskKindName(info.param));
                         });

TEST(GumTaskLarge, PlaneOverHundredThousandPointsClosedForm) {
  // Only the station height tz is uncertain: a horizontal plane moves rigidly up and down, so
  // u(centroid_z) = u(tz) and the normal is certain. 10^5 points: a 3N x 3N matrix would need
  // 720 GB; the low-rank path runs in well under a second.
  const ModelInfo* info = FindModel("mirror");
  MeasurementSetup s;
  s.model = info;
  for (int k = 0; k < info->num_params; ++k) s.params.push_back(In(0.0, 0.0));
  StationPose p;
  p.tz = In(-1.0, 1e-5);
  s.pose = p;
  MeasurementModel m(s);
  const int n = 100000;
  std::vector<PointReadings> pts(n);
  std::vector<std::string> names(n);
  TaskSpec task{"floor", TaskKind::kPlane, {}, {}};
  task.points.reserve(n);
  for (int i = 0; i < n; ++i) {
    const double a = 0.001 * i, r = 2.0 + 3.0 * (i % 97) / 97.0;
    const Eigen::Vector3d part(r * std::cos(a), r * std::sin(a), 0.01 * std::sin(0.37 * i));
    pts[i].name = std::to_string(i);
    const Eigen::Vector3d xt = part - Eigen::Vector3d(0, 0, -1.0);
    pts[i].readings = {xt.norm(), std::atan2(xt(1), xt(0)), std::atan2(xt(2), std::hypot(xt(0), xt(1)))};
    task.points.push_back(pts[i].name);
  }
  const TaskUncertainty t = PropagateTask(m, pts, task);
  EXPECT_NEAR(t.u(2), 1e-5, 1e-12);  // centroid_z
  EXPECT_NEAR(t.u(0), 0.0, 1e-12);
  EXPECT_NEAR(t.u(5), 0.0, 1e-12);  // normal_z
  EXPECT_NEAR(t.u(3), 0.0, 1e-12);  // normal_x
  EXPECT_LT(t.u(6), 1e-12);         // flatness
}

}  // namespace
}  // namespace vlt
