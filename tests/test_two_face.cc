// test_two_face.cc — the two_face task (docs/tasks.md "Two-face difference"): d = p2 - p1 of a
// nominal point measured in the front face (p1) and in the back face (p2), outputs dx, dy, dz.
// Every check compares against an independent reference:
//  - FitTwoFace: hand-computed differences and central finite differences of the values, also
//    for coincident points (where FitDistance refuses);
//  - GUM: the covariance of a front/back pair against the brute-force
//      (J2s - J1s) U_s (J2s - J1s)^T + J1r U_r1 J1r^T + J2r U_r2 J2r^T
//    from MeasurementModel::EvaluateWithJacobian; the value against Evaluate(back) - Evaluate(front);
//  - a job file with kind = "two_face" through ParseJob + RunJob with Monte Carlo: MCM standard
//    uncertainties against the GUM ones. (The same through the `vlt` binary: tests/cli.cmake.)
#include <cmath>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "vlt/error.h"
#include "vlt/fits.h"
#include "vlt/gum.h"
#include "vlt/job.h"
#include "vlt/models.h"
#include "vlt/results.h"
#include "vlt/tasks.h"

namespace vlt {
namespace {

using Eigen::Matrix3Xd;
using Eigen::Vector3d;

// ---------------------------------------------------------------------------------------------
// FitTwoFace

// Central differences of the values w.r.t. every coordinate (3 x 6).
Eigen::MatrixXd FiniteDifferences(const Matrix3Xd& points, double h) {
  Eigen::MatrixXd fd(3, 6);
  for (int j = 0; j < 2; ++j) {
    for (int c = 0; c < 3; ++c) {
      Matrix3Xd plus = points, minus = points;
      plus(c, j) += h;
      minus(c, j) -= h;
      fd.col(3 * j + c) = (FitTwoFace(plus).values - FitTwoFace(minus).values) / (2.0 * h);
    }
  }
  return fd;
}

void ExpectValueAndJacobian(const Matrix3Xd& points, const Vector3d& expected) {
  FitOptions options;
  options.jacobian = true;
  const FitResult r = FitTwoFace(points, options);
  EXPECT_EQ(r.kind, TaskKind::kTwoFace);
  ASSERT_EQ(r.values.size(), 3);
  for (int c = 0; c < 3; ++c) EXPECT_DOUBLE_EQ(r.values(c), expected(c)) << c;
  EXPECT_EQ(r.differentiable, std::vector<bool>(3, true));
  ASSERT_EQ(r.jacobian.rows(), 3);
  ASSERT_EQ(r.jacobian.cols(), 6);
  const Eigen::MatrixXd fd = FiniteDifferences(points, 1e-6);
  // Linear: the differences are exact up to rounding of the coordinates (~1e-16 m / 1e-6 m).
  EXPECT_LE((r.jacobian - fd).cwiseAbs().maxCoeff(), 1e-8) << r.jacobian << "\n" << fd;
  // And the closed form [-I, I].
  Eigen::MatrixXd g(3, 6);
  g << -Eigen::Matrix3d::Identity(), Eigen::Matrix3d::Identity();
  EXPECT_EQ(r.jacobian, g);
  // FitTask dispatches to it, without the Jacobian by default.
  const FitResult t = FitTask(TaskKind::kTwoFace, points);
  EXPECT_EQ(t.values, r.values);
  EXPECT_EQ(t.jacobian.size(), 0);
}

TEST(TwoFaceFit, OutputsAndKindName) {
  const auto outputs = TaskOutputs(TaskKind::kTwoFace);
  ASSERT_EQ(outputs.size(), 3u);
  EXPECT_EQ(outputs[0].name, "dx");
  EXPECT_EQ(outputs[1].name, "dy");
  EXPECT_EQ(outputs[2].name, "dz");
  for (const TaskOutput& o : outputs) EXPECT_EQ(o.unit, "m");
  EXPECT_EQ(TaskKindName(TaskKind::kTwoFace), "two_face");
  EXPECT_EQ(ParseTaskKind("two_face", "job.toml"), TaskKind::kTwoFace);
  EXPECT_EQ(MinimumPoints(TaskKind::kTwoFace), 2);
}

TEST(TwoFaceFit, ValueIsSecondMinusFirstWithExactJacobian) {
  Matrix3Xd p(3, 2);
  p << 1.0, 1.5, 2.0, 1.75, 3.0, 2.0;  // p1 = (1, 2, 3), p2 = (1.5, 1.75, 2)
  ExpectValueAndJacobian(p, Vector3d(0.5, -0.25, -1.0));
  // Swapping the points flips the sign.
  Matrix3Xd swapped(3, 2);
  swapped << p.col(1), p.col(0);
  ExpectValueAndJacobian(swapped, Vector3d(-0.5, 0.25, 1.0));
  // A realistic two-face pair: 12 um apart at 5 m.
  Matrix3Xd q(3, 2);
  q.col(0) = Vector3d(4.2, -2.1, 0.35);
  q.col(1) = q.col(0) + Vector3d(12e-6, -3e-6, 5e-6);
  ExpectValueAndJacobian(q, q.col(1) - q.col(0));
}

TEST(TwoFaceFit, CoincidentPointsAreFine) {
  Matrix3Xd same(3, 2);
  same << 1, 1, 2, 2, 3, 3;
  ExpectValueAndJacobian(same, Vector3d::Zero());
  // Where the distance is refused.
  EXPECT_THROW(FitDistance(same), NumericalError);
  Matrix3Xd origin = Matrix3Xd::Zero(3, 2);
  ExpectValueAndJacobian(origin, Vector3d::Zero());
}

TEST(TwoFaceFit, Refusals) {
  Matrix3Xd three = Matrix3Xd::Zero(3, 3);
  try {
    FitTwoFace(three, {}, "job.toml: task 'tf'");
    ADD_FAILURE() << "three points accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("job.toml: task 'tf': two_face needs exactly 2 points, got 3"),
              std::string::npos)
        << e.what();
  }
  EXPECT_THROW(FitTwoFace(Matrix3Xd::Zero(3, 1)), InputError);
  Matrix3Xd nan_point = Matrix3Xd::Zero(3, 2);
  nan_point(2, 1) = std::nan("");
  EXPECT_THROW(FitTwoFace(nan_point), InputError);

  // Point-name resolution: exactly 2, like distance.
  const std::vector<std::string> names = {"A", "B", "C"};
  EXPECT_EQ(ResolveTaskPoints({"tf", TaskKind::kTwoFace, {"B", "A"}, {}}, names, "job.toml"),
            (std::vector<int>{1, 0}));
  for (const std::vector<std::string>& points :
       {std::vector<std::string>{"A"}, std::vector<std::string>{"A", "B", "C"}}) {
    try {
      ResolveTaskPoints({"tf", TaskKind::kTwoFace, points, {}}, names, "job.toml");
      ADD_FAILURE() << points.size() << " points accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("job.toml: task 'tf': two_face needs exactly 2 points, " +
                                           std::to_string(points.size()) + " given"),
                std::string::npos)
          << e.what();
    }
  }
}

// ---------------------------------------------------------------------------------------------
// GUM

UncertainInput In(double estimate, double u) {
  UncertainInput in;
  in.estimate = estimate;
  in.u = u;
  return in;
}

// The laser-in-head tracker with every shared group enabled. `param_scale` multiplies the
// default uncertainty to give each parameter's estimate (0: all error parameters zero).
MeasurementSetup HeadSetup(double param_scale) {
  const ModelInfo* info = FindModel("head");
  EXPECT_NE(info, nullptr);
  MeasurementSetup s;
  s.model = info;
  for (int k = 0; k < info->num_params; ++k) {
    s.params.push_back(In(param_scale * info->params[k].default_u, info->params[k].default_u));
  }
  // A correlation between the transit-axis offset and the beam offset (the factorised path).
  EXPECT_GE(FindParam(*info, "ex"), 0);
  EXPECT_GE(FindParam(*info, "by"), 0);
  Eigen::MatrixXd r(2, 2);
  r << 1.0, 0.4, 0.4, 1.0;
  s.correlations = {{"axis", {"ex", "by"}, r, "", ""}};
  s.noise = {2e-6, 0.3e-6, 2e-6, 2e-6};
  Environment e;
  e.temperature = In(20.4, 0.2);
  e.pressure = In(100500.0, 40.0);
  e.humidity = In(45.0, 8.0);
  e.co2 = In(450e-6, 50e-6);
  s.environment = e;
  StationPose p;
  p.rx = In(0.002, 4e-6);
  p.ry = In(-0.001, 4e-6);
  p.rz = In(0.3, 6e-6);
  p.tx = In(-2.0, 10e-6);
  p.ty = In(1.0, 10e-6);
  p.tz = In(0.4, 10e-6);
  s.pose = p;
  PartThermal t;
  t.cte = In(11.5e-6, 1e-6);
  t.temperature = In(20.6, 0.1);
  s.thermal = t;
  return s;
}

// The front and back readings of one nominal part point, planned with `planning`.
std::vector<PointReadings> TwoFacePair(const MeasurementModel& planning, const Vector3d& part) {
  return {{"P", ReadingsForPartPoint(planning, part, false, "P")},
          {"P_back", ReadingsForPartPoint(planning, part, true, "P_back")}};
}

// Brute force, from the point model's Jacobians only:
//   cov(p2 - p1) = (J2s - J1s) U_s (J2s - J1s)^T + J1r U_r1 J1r^T + J2r U_r2 J2r^T.
Eigen::Matrix3d BruteForceCovariance(const MeasurementModel& m, const std::vector<PointReadings>& pair) {
  const int s = m.num_shared();
  const Eigen::VectorXd x = m.shared_estimates();
  Eigen::VectorXd u(s);
  for (int k = 0; k < s; ++k) u(k) = m.shared_inputs()[k].u;
  const Eigen::MatrixXd u_s = u.asDiagonal() * m.shared_correlation() * u.asDiagonal();
  Eigen::Matrix3d jr[2];
  Eigen::MatrixXd js[2] = {Eigen::MatrixXd(3, s), Eigen::MatrixXd(3, s)};
  Eigen::Matrix3d u_r[2];
  for (int i = 0; i < 2; ++i) {
    Vector3d y;
    m.EvaluateWithJacobian(pair[i].readings.data(), x.data(), y.data(), jr[i].data(), js[i].data());
    u_r[i] = m.reading_uncertainty(pair[i].readings(0)).cwiseAbs2().asDiagonal();
  }
  const Eigen::MatrixXd dj = js[1] - js[0];
  return dj * u_s * dj.transpose() + jr[0] * u_r[0] * jr[0].transpose() + jr[1] * u_r[1] * jr[1].transpose();
}

Vector3d EvaluateAtEstimates(const MeasurementModel& m, const Vector3d& readings) {
  const Eigen::VectorXd x = m.shared_estimates();
  Vector3d y;
  m.Evaluate(readings.data(), x.data(), y.data());
  return y;
}

const TaskSpec kTwoFaceTask{"tf", TaskKind::kTwoFace, {"P", "P_back"}, {}};

TEST(TwoFaceGum, CovarianceEqualsBruteForce) {
  // Non-zero parameter estimates (the general Jacobian kernel) and three points around the
  // tracker: level, high, low.
  for (double scale : {0.0, 0.7}) {
    const MeasurementModel m(HeadSetup(scale));
    for (const Vector3d& part :
         {Vector3d(4.0, 1.0, 0.3), Vector3d(1.0, 3.0, 2.5), Vector3d(-3.0, -4.0, -1.2)}) {
      const std::vector<PointReadings> pair = TwoFacePair(m, part);
      ASSERT_GT(pair[1].readings(2), std::numbers::pi / 2) << "second reading is a back-face one";
      const TaskUncertainty t = PropagateTask(m, pair, kTwoFaceTask);
      ASSERT_EQ(t.quantities, (std::vector<std::string>{"dx", "dy", "dz"}));
      ASSERT_EQ(t.units, (std::vector<std::string>{"m", "m", "m"}));
      const Eigen::Matrix3d ref = BruteForceCovariance(m, pair);
      ASSERT_EQ(t.covariance.rows(), 3);
      ASSERT_EQ(t.covariance.cols(), 3);
      EXPECT_LE((t.covariance - ref).norm(), 1e-9 * ref.norm())
          << "scale " << scale << " at " << part.transpose() << "\n"
          << t.covariance << "\n"
          << ref;
      for (int q = 0; q < 3; ++q) {
        EXPECT_NEAR(t.covariance(q, q), ref(q, q), 1e-9 * ref(q, q)) << t.quantities[q];
        EXPECT_NEAR(t.u(q), std::sqrt(ref(q, q)), 1e-9 * std::sqrt(ref(q, q)));
        EXPECT_GT(t.u(q), 1e-7) << "a two-face difference of a few micrometres";
        EXPECT_TRUE(t.differentiable[q]);
      }
      // Planned with the model's own estimates, both faces hit the same nominal point.
      EXPECT_LT(t.value.cwiseAbs().maxCoeff(), 1e-12) << t.value.transpose();
      // Identical in both faces, pose and part temperature cancel from the difference: the
      // shared variance comes from the tracker's error parameters (and a little from the air).
      double pose_thermal = 0.0;
      for (const TaskGroupContribution& g : t.budget) {
        if (g.group == "pose" || g.group == "thermal") pose_thermal += g.variance.sum();
      }
      EXPECT_LT(pose_thermal, 1e-6 * t.covariance.trace());
    }
  }
}

TEST(TwoFaceGum, ZeroParametersGiveZeroDifference) {
  // All error parameters at zero estimate (pose, air and thermal still non-trivial).
  const MeasurementModel m(HeadSetup(0.0));
  const std::vector<PointReadings> pair = TwoFacePair(m, Vector3d(5.0, -1.5, 0.8));
  const TaskUncertainty t = PropagateTask(m, pair, kTwoFaceTask);
  ASSERT_EQ(t.value.size(), 3);
  EXPECT_LT(t.value.cwiseAbs().maxCoeff(), 1e-12) << t.value.transpose();
  // The distance between the same two points is refused: that is why two_face exists.
  EXPECT_THROW(PropagateTask(m, pair, TaskSpec{"d", TaskKind::kDistance, {"P", "P_back"}, {}}),
               NumericalError);
}

TEST(TwoFaceGum, UncompensatedOffsetsGiveTheTwoFaceError) {
  // The readings are those of a tracker planned without offsets; the model evaluating them has
  // a transit-axis offset ex and a beam offset by (docs/models.md, `head`): both flip sign with
  // the face, so the front and back coordinates of the same readings differ (the B89.4.19
  // two-face error |d| = 2 sqrt(ex^2 + by^2) here).
  const MeasurementModel planning(HeadSetup(0.0));
  MeasurementSetup with_offsets = HeadSetup(0.0);
  const ModelInfo& info = *with_offsets.model;
  with_offsets.params[FindParam(info, "ex")].estimate = 20e-6;
  with_offsets.params[FindParam(info, "by")].estimate = 15e-6;
  const MeasurementModel m(with_offsets);
  for (const Vector3d& part : {Vector3d(4.0, 1.0, 0.3), Vector3d(1.0, 3.0, 2.5)}) {
    const std::vector<PointReadings> pair = TwoFacePair(planning, part);
    const TaskUncertainty t = PropagateTask(m, pair, kTwoFaceTask);
    const Vector3d expected =
        EvaluateAtEstimates(m, pair[1].readings) - EvaluateAtEstimates(m, pair[0].readings);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(t.value(c), expected(c), 1e-15) << c;
    // Closed form from the kinematic chain of docs/models.md (all other parameters zero): the
    // beam leaves from b = Rz(H)(ex, 0, 0) + M (-ex, by, 0) along the same direction in both
    // faces, and the back face (H + pi, pi - E) flips ex and by: back - front =
    // Rz(A) (-2 ex, -2 by, 0) in the tracker frame, whatever the elevation; then s R into the
    // part frame (y = s (R x_t + t)).
    const Eigen::VectorXd x = m.shared_estimates();
    const Vector3d tracker_frame =
        Eigen::AngleAxisd(pair[0].readings(1), Vector3d::UnitZ()) * Vector3d(-2 * 20e-6, -2 * 15e-6, 0.0);
    const Vector3d closed_form = m.ThermalScale(x.data()) * (m.PoseRotation(x.data()) * tracker_frame);
    EXPECT_LE((t.value - closed_form).cwiseAbs().maxCoeff(), 1e-12)
        << t.value.transpose() << " vs " << closed_form.transpose();
    EXPECT_NEAR(t.value.norm(), 2.0 * std::hypot(20e-6, 15e-6), 1e-9);
    // Without the offsets the same readings coincide.
    EXPECT_LT(
        (EvaluateAtEstimates(planning, pair[1].readings) - EvaluateAtEstimates(planning, pair[0].readings))
            .cwiseAbs()
            .maxCoeff(),
        1e-12);
    // The covariance is still the brute-force one.
    const Eigen::Matrix3d ref = BruteForceCovariance(m, pair);
    EXPECT_LE((t.covariance - ref).norm(), 1e-9 * ref.norm());
  }
}

// ---------------------------------------------------------------------------------------------
// A job file through RunJob (GUM + Monte Carlo)

const char* kJob = R"(
[job]
name = "two-face-test"
[tracker]
model = "head"
[tracker.noise]
range = "2 um + 0.3 um/m"
azimuth = "0.4 arcsec"
elevation = "0.4 arcsec"
[tracker.parameters]
ex = { estimate = "3 um", u = "4 um" }
by = { estimate = "-2 um", u = "3 um" }
gamma = { u = "0.8 arcsec" }
[environment]
temperature = { estimate = "20.2 degC", u = "0.15 K" }
pressure = { estimate = "1001 hPa", u = "0.3 hPa" }
humidity = { estimate = "47 %", u = "5 %" }
[plan]
unit = "m"
point = [ {name = "P", x = 4, y = 1, z = 0.3}, {name = "P_back", x = 4, y = 1, z = 0.3, face = "back"},
          {name = "Q", x = 2, y = -3, z = -0.5}, {name = "Q_back", x = 2, y = -3, z = -0.5, face = "b"} ]
[[task]]
kind = "two_face"
name = "P_two_face"
points = ["P", "P_back"]
[[task]]
kind = "two_face"
name = "Q_two_face"
points = ["Q", "Q_back"]
[[task]]
kind = "distance"
name = "PQ_back"
points = ["P_back", "Q_back"]
[monte_carlo]
trials = 40000
seed = 4
n_dig = 1
)";

TEST(TwoFaceJob, ParsesAndRunsWithMonteCarlo) {
  const Job job = ParseJob(kJob, "two_face.toml", ".");
  ASSERT_EQ(job.tasks.size(), 3u);
  EXPECT_EQ(job.tasks[0].kind, TaskKind::kTwoFace);
  EXPECT_EQ(job.task_points[0], (std::vector<int>{0, 1}));
  EXPECT_EQ(job.tasks[1].kind, TaskKind::kTwoFace);
  EXPECT_EQ(job.task_points[1], (std::vector<int>{2, 3}));

  RunOptions options;
  options.threads = 2;
  const Results r = RunJob(job, options);
  ASSERT_TRUE(r.has_mcm);
  ASSERT_EQ(r.tasks.size(), 3u);
  for (int t = 0; t < 2; ++t) {
    const TaskResult& task = r.tasks[t];
    ASSERT_EQ(task.gum.quantities, (std::vector<std::string>{"dx", "dy", "dz"}));
    ASSERT_TRUE(task.has_mcm);
    ASSERT_EQ(task.mcm.size(), 3u);
    for (int q = 0; q < 3; ++q) {
      // Planned at the estimates: the two faces coincide.
      EXPECT_LT(std::abs(task.gum.value(q)), 1e-12);
      // Monte Carlo (40000 trials: relative standard error of u about 0.4 %) agrees with the GUM.
      const double u_gum = task.gum.u(q), u_mcm = task.mcm[q].u;
      EXPECT_GT(u_gum, 1e-7);
      EXPECT_NEAR(u_mcm, u_gum, 0.03 * u_gum) << task.spec.name << "." << task.gum.quantities[q];
      // The MCM mean is the value to within a few standard errors.
      EXPECT_LT(std::abs(task.mcm[q].mean - task.gum.value(q)), 5.0 * u_gum / std::sqrt(40000.0));
      EXPECT_TRUE(task.validation[q].validated) << task.validation[q].verdict;
    }
  }

  // The files carry the new kind and its quantities.
  std::stringstream csv(TasksCsv(r));
  std::string line;
  std::vector<std::string> two_face_rows;
  while (std::getline(csv, line)) {
    if (line.rfind("P_two_face,", 0) == 0) two_face_rows.push_back(line);
  }
  ASSERT_EQ(two_face_rows.size(), 3u);
  EXPECT_EQ(two_face_rows[0].rfind("P_two_face,two_face,dx,mm,", 0), 0u) << two_face_rows[0];
  EXPECT_EQ(two_face_rows[2].rfind("P_two_face,two_face,dz,mm,", 0), 0u) << two_face_rows[2];
  const nlohmann::json j = nlohmann::json::parse(ResultsJson(r));
  EXPECT_EQ(j["tasks"][0]["kind"], "two_face");
  EXPECT_EQ(j["tasks"][0]["quantities"], nlohmann::json::array({"dx", "dy", "dz"}));
  EXPECT_NE(ReportHtml(r).find("two_face"), std::string::npos);
  const std::string summary = SummaryText(r);
  for (const char* q : {"dx", "dy", "dz"}) {
    EXPECT_NE(summary.find(std::string("two_face  ") + q), std::string::npos) << summary;
  }
}

TEST(TwoFaceJob, WrongPointCountIsOneLineError) {
  std::string text = kJob;
  const std::string from = "points = [\"P\", \"P_back\"]";
  text.replace(text.find(from), from.size(), "points = [\"P\", \"P_back\", \"Q\"]");
  try {
    ParseJob(text, "two_face.toml", ".");
    ADD_FAILURE() << "three points accepted";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("task 'P_two_face': two_face needs exactly 2 points, 3 given"), std::string::npos)
        << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
  }
}

}  // namespace
}  // namespace vlt
