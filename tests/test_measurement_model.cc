// MeasurementModel: exact evaluation and the chain-rule Jacobian, every block checked against
// central finite differences of Evaluate (independent reference), plus closed forms for the
// pose and thermal stages.
#include "vlt/measurement_model.h"

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Geometry>
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

MeasurementSetup IdealSetup(bool pose, bool thermal, bool environment) {
  MeasurementSetup s;
  s.model = &test::kIdealTracker;
  s.params = {In(3e-6, 1e-6), In(2e-6, 1e-6), In(4e-6, 1e-6), In(-5e-6, 1e-6)};
  s.noise = {1e-6, 1e-7, 2e-6, 3e-6};
  if (pose) {
    StationPose p;
    p.rx = In(0.01, 1e-5);
    p.ry = In(-0.02, 1e-5);
    p.rz = In(0.7, 1e-5);
    p.tx = In(1.0, 1e-5);
    p.ty = In(-2.0, 1e-5);
    p.tz = In(0.5, 1e-5);
    s.pose = p;
  }
  if (thermal) {
    PartThermal t;
    t.cte = In(11.5e-6, 1e-6);
    t.temperature = In(22.5, 0.1);
    s.thermal = t;
  }
  if (environment) {
    Environment e;
    e.temperature = In(21.0, 0.2);
    e.pressure = In(100500.0, 30.0);
    e.humidity = In(45.0, 5.0);
    e.co2 = In(450e-6, 50e-6);
    s.environment = e;
  }
  return s;
}

// Central differences of Evaluate w.r.t. readings and shared inputs vs EvaluateWithJacobian.
void CheckJacobian(const MeasurementModel& m, const double* readings, const double* shared_in,
                   double rel_tol) {
  const int num_shared = m.num_shared();
  std::vector<double> shared(shared_in, shared_in + num_shared);
  double y[3], jr[9];
  std::vector<double> js(3 * num_shared);
  m.EvaluateWithJacobian(readings, shared.data(), y, jr, js.data());
  double y0[3];
  m.Evaluate(readings, shared.data(), y0);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(y[i], y0[i], 1e-12 * (1 + std::abs(y0[i])));

  auto fd = [&](double* x, double h, double* col) {
    const double keep = *x;
    double yp[3], ym[3];
    *x = keep + h;
    m.Evaluate(readings, shared.data(), yp);
    *x = keep - h;
    m.Evaluate(readings, shared.data(), ym);
    *x = keep;
    for (int i = 0; i < 3; ++i) col[i] = (yp[i] - ym[i]) / (2 * h);
  };
  double r[3] = {readings[0], readings[1], readings[2]};
  for (int k = 0; k < 3; ++k) {
    double col[3];
    const double h = k == 0 ? 1e-6 * std::abs(r[0]) : 1e-7;
    const double* saved = readings;
    readings = r;
    fd(&r[k], h, col);
    readings = saved;
    const double scale = Eigen::Map<const Eigen::Vector3d>(jr + 3 * k).norm() + 1e-12;
    for (int i = 0; i < 3; ++i) {
      EXPECT_NEAR(jr[3 * k + i], col[i], rel_tol * scale) << "reading " << k << " axis " << i;
    }
  }
  for (int k = 0; k < num_shared; ++k) {
    const UncertainInput& in = m.shared_inputs()[k];
    double h = std::max(in.u, 1e-9 * (1 + std::abs(in.estimate)));
    if (in.group == "parameter") h = 1e-5;  // exact Jacobian of a smooth model; any small step
    double col[3];
    fd(&shared[k], h, col);
    const double scale = Eigen::Map<const Eigen::Vector3d>(js.data() + 3 * k).norm() +
                         Eigen::Map<const Eigen::Vector3d>(col).norm() * 1e-3 + 1e-15;
    for (int i = 0; i < 3; ++i) {
      EXPECT_NEAR(js[3 * k + i], col[i], rel_tol * scale) << "shared input " << in.name << " axis " << i;
    }
  }
}

TEST(MeasurementModel, SharedInputOrderAndNames) {
  MeasurementModel m(IdealSetup(true, true, false));
  ASSERT_EQ(m.num_shared(), 4 + 6 + 2);
  EXPECT_EQ(m.shared_inputs()[0].name, "r0");
  EXPECT_EQ(m.shared_inputs()[0].group, "parameter");
  EXPECT_EQ(m.shared_inputs()[4].name, "pose.rx");
  EXPECT_EQ(m.shared_inputs()[9].name, "pose.tz");
  EXPECT_EQ(m.shared_inputs()[10].name, "thermal.cte");
  EXPECT_EQ(m.shared_inputs()[10].unit, "1/K");
  EXPECT_EQ(m.shared_inputs()[11].group, "thermal");
  EXPECT_EQ(m.pose_offset(), 4);
  EXPECT_EQ(m.thermal_offset(), 10);
  EXPECT_EQ(m.environment_offset(), -1);
  EXPECT_TRUE(m.shared_correlation().isIdentity());
  const Eigen::Vector3d u = m.reading_uncertainty(10.0);
  EXPECT_DOUBLE_EQ(u(0), 1e-6 + 1e-7 * 10.0);
  EXPECT_DOUBLE_EQ(u(1), 2e-6);
  EXPECT_DOUBLE_EQ(u(2), 3e-6);
}

TEST(MeasurementModel, EvaluateClosedFormPoseAndThermal) {
  MeasurementModel m(IdealSetup(true, true, false));
  const Eigen::VectorXd x = m.shared_estimates();
  const double readings[3] = {5.0, 0.3, 0.2};
  double y[3];
  m.Evaluate(readings, x.data(), y);
  // Independent reference: Eigen's AngleAxis rotations and the ideal spherical model.
  const double rho = (1 + 2e-6) * 5.0 + 3e-6, a = 0.3 + 4e-6, e = 0.2 - 5e-6;
  const Eigen::Vector3d xt(rho * std::cos(e) * std::cos(a), rho * std::cos(e) * std::sin(a),
                           rho * std::sin(e));
  const Eigen::Matrix3d r =
      (Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(-0.02, Eigen::Vector3d::UnitY()) *
       Eigen::AngleAxisd(0.01, Eigen::Vector3d::UnitX()))
          .toRotationMatrix();
  const Eigen::Vector3d expected = (r * xt + Eigen::Vector3d(1.0, -2.0, 0.5)) / (1 + 11.5e-6 * (22.5 - 20.0));
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(y[i], expected(i), 1e-13);
  double xtr[3];
  m.EvaluateTracker(readings, x.data(), xtr);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(xtr[i], xt(i), 1e-14);
}

TEST(MeasurementModel, JacobianMatchesFiniteDifferencesAllStages) {
  for (bool pose : {false, true}) {
    for (bool thermal : {false, true}) {
      MeasurementModel m(IdealSetup(pose, thermal, false));
      const Eigen::VectorXd x = m.shared_estimates();
      for (const Eigen::Vector3d& r : {Eigen::Vector3d(5.0, 0.3, 0.2), Eigen::Vector3d(30.0, -2.5, -0.6),
                                       Eigen::Vector3d(1.2, 3.0, 1.3)}) {
        SCOPED_TRACE(testing::Message() << "pose " << pose << " thermal " << thermal);
        CheckJacobian(m, r.data(), x.data(), 1e-7);
      }
    }
  }
}

TEST(MeasurementModel, EnvironmentScalesRangeAndJacobianMatchesFiniteDifferences) {
  for (auto equation : {Environment::Equation::kCiddor, Environment::Equation::kEdlenBoensch}) {
    MeasurementSetup s = IdealSetup(true, true, true);
    s.environment->equation = equation;
    MeasurementModel m(s);
    EXPECT_EQ(m.environment_offset(), 4);
    EXPECT_EQ(m.shared_inputs()[5].name, "environment.pressure");
    EXPECT_GT(m.refractive_index_estimate(), 1.0002);
    EXPECT_LT(m.refractive_index_estimate(), 1.0003);
    Eigen::VectorXd x = m.shared_estimates();
    const double readings[3] = {12.0, -0.8, 0.1};
    CheckJacobian(m, readings, x.data(), 1e-6);
    // At the estimates the air correction is exactly 1: y equals the no-environment model.
    MeasurementModel plain(IdealSetup(true, true, false));
    const Eigen::VectorXd xp = plain.shared_estimates();
    double y[3], y_plain[3];
    m.Evaluate(readings, x.data(), y);
    plain.Evaluate(readings, xp.data(), y_plain);
    for (int i = 0; i < 3; ++i) EXPECT_EQ(y[i], y_plain[i]);
    // +1 K air temperature: the range grows by about 0.95 um/m (reference notes, section 3).
    x(4) += 1.0;
    double xt[3], xt0[3];
    m.EvaluateTracker(readings, x.data(), xt);
    x(4) -= 1.0;
    m.EvaluateTracker(readings, x.data(), xt0);
    const double dr = Eigen::Map<Eigen::Vector3d>(xt).norm() - Eigen::Map<Eigen::Vector3d>(xt0).norm();
    EXPECT_NEAR(dr / 12.0, 0.95e-6, 0.05e-6);
  }
}

// An absolute distance meter's range is optical path over the GROUP index (docs/units.md "Group
// index"): the model's index at the estimates is the group index, and warmer air lengthens the
// range by -(dn_g/dT) / n_g per K instead of -(dn/dT) / n (about 3 % more at 633 nm); the Jacobian is
// still right (finite differences), and an interferometer keeps the phase index.
TEST(MeasurementModel, AbsoluteDistanceMeterUsesTheGroupIndex) {
  const double readings[3] = {12.0, -0.8, 0.1};
  double growth[2] = {0.0, 0.0};
  for (const Ranging ranging : {Ranging::kInterferometer, Ranging::kAbsoluteDistanceMeter}) {
    MeasurementSetup s = IdealSetup(true, true, true);
    s.ranging = ranging;
    MeasurementModel m(s);
    const RangingIndex index = IndexOf(ranging);
    const RefractiveIndex n = AirRefractiveIndex(EquationOf(*s.environment), AirAtEstimates(*s.environment),
                                                 "test", index);
    EXPECT_EQ(m.refractive_index_estimate(), n.n);
    Eigen::VectorXd x = m.shared_estimates();
    CheckJacobian(m, readings, x.data(), 1e-6);
    double xt[3], xt0[3];
    m.EvaluateTracker(readings, x.data(), xt0);
    x(4) += 0.01;  // K
    m.EvaluateTracker(readings, x.data(), xt);
    const double dr = Eigen::Map<Eigen::Vector3d>(xt).norm() - Eigen::Map<Eigen::Vector3d>(xt0).norm();
    // range' = range n(T0) / n(T0 + dT): to first order d range / range = -(dn/dT) / n dT (the
    // second order is 3e-5 of it at dT = 0.01 K).
    EXPECT_NEAR(dr / Eigen::Map<Eigen::Vector3d>(xt0).norm() / 0.01, -n.dn_dtemperature / n.n,
                1e-3 * std::abs(n.dn_dtemperature));
    growth[ranging == Ranging::kInterferometer ? 0 : 1] = dr;
  }
  EXPECT_NEAR(growth[1] / growth[0], 1.03, 0.005);
  EXPECT_EQ(ParseRanging("adm", "t"), Ranging::kAbsoluteDistanceMeter);
  EXPECT_EQ(IndexOf(Ranging::kAbsoluteInterferometer), RangingIndex::kGroup);
  EXPECT_THROW(ParseRanging("laser", "t"), InputError);
}

TEST(MeasurementModel, JacobianAwayFromEstimates) {
  // The MCM evaluates at sampled inputs: the Jacobian must be right there too.
  MeasurementModel m(IdealSetup(true, true, false));
  Eigen::VectorXd x = m.shared_estimates();
  x(0) = 1e-4;
  x(2) = 0.01;
  x(4) = 0.3;
  x(5) = -0.4;
  x(11) = 35.0;
  const double readings[3] = {8.0, 1.0, -0.3};
  CheckJacobian(m, readings, x.data(), 1e-7);
}

TEST(MeasurementModel, EveryGeneratedTrackerModelJacobian) {
  int checked = 0;
  for (const ModelInfo* info : AllModels()) {
    if (info == nullptr || std::string(info->kind) != "tracker") continue;
    MeasurementSetup s;
    s.model = info;
    for (int k = 0; k < info->num_params; ++k) {
      // Non-zero parameter values exercise the general (not nominal) Jacobian kernel.
      s.params.push_back(In(info->params[k].default_u, info->params[k].default_u));
    }
    StationPose p;
    p.rx = In(0.01, 1e-5);
    p.ry = In(0.02, 1e-5);
    p.rz = In(-1.0, 1e-5);
    s.pose = p;
    MeasurementModel m(s);
    const Eigen::VectorXd x = m.shared_estimates();
    const double readings[3] = {7.0, 0.4, 0.25};
    SCOPED_TRACE(info->name);
    CheckJacobian(m, readings, x.data(), 1e-6);
    // All parameters exactly zero: the nominal (specialised) kernel is used.
    Eigen::VectorXd x0 = x;
    x0.head(info->num_params).setZero();
    CheckJacobian(m, readings, x0.data(), 1e-6);
    ++checked;
  }
  SUCCEED() << checked << " generated tracker models checked";
}

// The SIMD path at the nominal parameters gives the numbers of EvaluateWithJacobian bit for
// bit, for 1..kLanes points, with every stage (air, pose, thermal) at and away from the estimates:
// y, d y / d readings, the non-parameter columns of d y / d shared, and linear_map times the lanes'
// d x_t / d params for the parameters' columns. It declines non-zero parameters.
TEST(MeasurementModel, EvaluateNominalLanesEqualsEvaluateWithJacobianBitForBit) {
  constexpr int L = MeasurementModel::kLanes;
  const double readings[3 * L] = {7.0, 0.4, 0.25, 31.0, -2.9, -0.6, 1.1, 3.05, 1.4, 12.0, 1.7, 2.9};
  int checked = 0;
  for (const char* name : {"mirror", "head"}) {
    for (bool stations : {false, true}) {
      MeasurementSetup s = IdealSetup(stations, stations, stations);
      s.model = FindModel(name);
      ASSERT_NE(s.model, nullptr) << name;
      const int np = s.model->num_params;
      s.params.clear();
      for (int k = 0; k < np; ++k) s.params.push_back(In(0.0, s.model->params[k].default_u));
      const MeasurementModel m(s);
      const int shared = m.num_shared();
      const Eigen::VectorXd at_estimates = m.shared_estimates();
      Eigen::VectorXd away = at_estimates;  // air and pose off their estimates
      if (stations) {
        away(m.environment_offset()) += 1.5;
        away(m.pose_offset()) += 1e-3;
        away(m.thermal_offset() + 1) += 0.7;
      }
      for (const Eigen::VectorXd* x : {&at_estimates, static_cast<const Eigen::VectorXd*>(&away)}) {
        for (int count = 1; count <= L; ++count) {
          std::vector<double> y(3 * L), jr(9 * L), js(3 * shared * L), jp(3 * np * L);
          Eigen::Matrix3d linear_map;
          ASSERT_TRUE(m.EvaluateNominalLanes(count, readings, x->data(), y.data(), jr.data(), js.data(),
                                             jp.data(), linear_map));
          for (int i = 0; i < count; ++i) {
            double y1[3], jr1[9];
            std::vector<double> js1(3 * shared);
            m.EvaluateWithJacobian(readings + 3 * i, x->data(), y1, jr1, js1.data());
            SCOPED_TRACE(testing::Message()
                         << name << " stations " << stations << " count " << count << " point " << i);
            for (int q = 0; q < 3; ++q) ASSERT_EQ(y[3 * i + q], y1[q]);
            for (int q = 0; q < 9; ++q) ASSERT_EQ(jr[9 * i + q], jr1[q]);
            for (int q = 3 * np; q < 3 * shared; ++q) ASSERT_EQ(js[3 * shared * i + q], js1[q]) << q;
            for (int p = 0; p < np; ++p) {
              Eigen::Vector3d column;
              for (int r = 0; r < 3; ++r) column(r) = jp[L * (3 * p + r) + i];
              const Eigen::Vector3d dy = stations ? Eigen::Vector3d(linear_map * column) : column;
              for (int r = 0; r < 3; ++r) ASSERT_EQ(dy(r), js1[3 * p + r]) << "parameter " << p;
            }
            ++checked;
          }
        }
      }
      Eigen::VectorXd nonzero = at_estimates;
      nonzero(1) = 3e-6;
      std::vector<double> y(3 * L), jr(9 * L), js(3 * shared * L), jp(3 * np * L);
      Eigen::Matrix3d linear_map;
      EXPECT_FALSE(m.EvaluateNominalLanes(L, readings, nonzero.data(), y.data(), jr.data(), js.data(),
                                          jp.data(), linear_map));
    }
  }
  EXPECT_EQ(checked, 2 * 2 * 2 * (1 + 2 + 3 + 4));
  MeasurementModel m(IdealSetup(false, false, false));
  double y[3 * (L + 1)], jr[9 * (L + 1)], js[12 * (L + 1)], jp[12 * (L + 1)];
  Eigen::Matrix3d linear_map;
  EXPECT_THROW(m.EvaluateNominalLanes(0, nullptr, nullptr, y, jr, js, jp, linear_map), std::invalid_argument);
  EXPECT_THROW(m.EvaluateNominalLanes(L + 1, nullptr, nullptr, y, jr, js, jp, linear_map),
               std::invalid_argument);
  // The ideal test tracker has no batch kernel: declined.
  const Eigen::VectorXd x0 = Eigen::VectorXd::Zero(m.num_shared());
  const double r[3 * L] = {1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0};
  EXPECT_FALSE(m.EvaluateNominalLanes(L, r, x0.data(), y, jr, js, jp, linear_map));
}

TEST(MeasurementModel, RejectsBadSetup) {
  MeasurementSetup s = IdealSetup(false, false, false);
  s.params.pop_back();
  EXPECT_THROW(MeasurementModel{s}, InputError);
  s = IdealSetup(false, false, false);
  s.params[1].u = -1.0;
  EXPECT_THROW(MeasurementModel{s}, InputError);
  s = IdealSetup(false, false, false);
  s.correlations = {{"g", {"r0", "mu"}, Eigen::MatrixXd::Identity(3, 3), "", ""}};  // wrong size
  EXPECT_THROW(MeasurementModel{s}, InputError);
  Eigen::MatrixXd r = Eigen::MatrixXd::Identity(2, 2);
  r(0, 1) = 0.5;  // not symmetric
  s.correlations = {{"g", {"r0", "mu"}, r, "", ""}};
  EXPECT_THROW(MeasurementModel{s}, InputError);
  r(1, 0) = 0.5;
  s.correlations = {{"g", {"r0", "nu"}, r, "", ""}};  // unknown input
  EXPECT_THROW(MeasurementModel{s}, InputError);
  s.correlations = {{"g", {"r0", "mu"}, r, "", ""}};
  MeasurementModel ok(s);
  EXPECT_DOUBLE_EQ(ok.shared_correlation()(1, 0), 0.5);
}

}  // namespace
}  // namespace vlt
