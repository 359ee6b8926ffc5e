// Correlations between any shared inputs of a tracker job ([correlations.<group>] of a job file,
// MeasurementSetup::correlations): the same thermometer reads the air and the part, so
// environment.temperature and thermal.temperature are correlated (docs/job-file.md).
//
//  - GUM against the closed form u^2 = c1^2 u1^2 + c2^2 u2^2 + 2 r c1 c2 u1 u2 (JCGM 100 5.2.2)
//    with c from central differences of MeasurementModel::Evaluate, for a point on the beam and the
//    distance along it: warmer air lengthens the measured range (n falls), a warmer part shrinks
//    the coordinates reduced to 20 degC, so with r = 1 the two partly cancel.
//    The group also holds a parameter with u = 0 (it must change nothing), and the tracker-frame
//    covariance must keep the air only (the instrument inputs' own covariance).
//  - The Monte Carlo engine (Gaussian copula over a singular correlation, r = 1) against the GUM.
// The parsing and the one-line errors of [correlations]: test_job.cc; results.json: test_results.cc.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <gtest/gtest.h>

#include "vlt/gum.h"
#include "vlt/job.h"
#include "vlt/mcm.h"
#include "vlt/measurement_model.h"
#include "vlt/models.h"

namespace vlt {
namespace {

constexpr double kU = 0.5;  // K, u of both temperatures

// Mirror tracker with every error parameter at u = 0, a 1.5 ppm/K part (a carbon-fibre or Invar
// fixture) at 22 degC and air at 22 degC, both read by one thermometer with u = 0.5 K and
// correlation r. Points A and B on the x axis, 2 m and 10 m from the tracker; task AB.
std::string ThermometerJob(double r, const std::string& noise) {
  std::string text = "[tracker]\nmodel = \"mirror\"\n[tracker.parameters]\n";
  const ModelInfo* mirror = FindModel("mirror");
  EXPECT_NE(mirror, nullptr);
  for (int k = 0; mirror != nullptr && k < mirror->num_params; ++k) {
    text += std::string(mirror->params[k].name) + " = { u = 0 }\n";
  }
  // tmv (u = 0 here) is in the group too: an input without uncertainty changes nothing.
  char matrix[160];
  std::snprintf(matrix, sizeof matrix, "matrix = [[1, %.17g, 0.2], [%.17g, 1, 0.2], [0.2, 0.2, 1]]\n", r, r);
  return text + "[tracker.noise]\n" + noise + R"(
[environment]
temperature = { estimate = "22 degC", u = "0.5 K" }
pressure = "1000 hPa"
humidity = "50 %"
[part]
cte = "1.5 ppm/K"
temperature = { estimate = "22 degC", u = "0.5 K" }
[correlations.thermometer]
inputs = ["environment.temperature", "thermal.temperature", "tmv"]
)" + matrix +
         R"(
[plan]
unit = "m"
point = [{name = "A", x = 2, y = 0, z = 0}, {name = "B", x = 10, y = 0, z = 0}]
[[task]]
kind = "distance"
name = "AB"
points = ["A", "B"]
)";
}

const char* const kNoNoise = "range = \"0 um\"\nazimuth = \"0 arcsec\"\nelevation = \"0 arcsec\"\n";

std::vector<PointReadings> Readings(const Job& job, const MeasurementModel& model) {
  std::vector<PointReadings> points;
  for (const JobPoint& p : job.points) {
    points.push_back({p.name, ReadingsForPartPoint(model, p.nominal, false, p.name)});
  }
  return points;
}

// d f / d shared[s] by central differences (step h) of a function of the shared vector.
template <typename F>
double Derivative(const MeasurementModel& model, int s, double h, F f) {
  Eigen::VectorXd plus = model.shared_estimates(), minus = plus;
  plus(s) += h;
  minus(s) -= h;
  return (f(plus) - f(minus)) / (2.0 * h);
}

TEST(GumCorrelations, SameThermometerForAirAndPartMatchesTheClosedForm) {
  for (const double r : {1.0, 0.5, -0.7}) {
    SCOPED_TRACE("r = " + std::to_string(r));
    const Job job = ParseJob(ThermometerJob(r, kNoNoise), "job.toml", std::filesystem::temp_directory_path());
    const MeasurementModel model(job.setup);
    const std::vector<PointReadings> points = Readings(job, model);
    const int t_air = model.environment_offset();
    const int t_part = model.thermal_offset() + 1;
    ASSERT_EQ(model.shared_inputs()[t_air].name, "environment.temperature");
    ASSERT_EQ(model.shared_inputs()[t_part].name, "thermal.temperature");
    EXPECT_DOUBLE_EQ(model.shared_correlation()(t_air, t_part), r);

    auto y = [&](int point, const Eigen::VectorXd& shared) {
      Eigen::Vector3d out;
      model.Evaluate(points[point].readings.data(), shared.data(), out.data());
      return out;
    };
    auto closed_form = [&](double c1, double c2) {
      return c1 * c1 * kU * kU + c2 * c2 * kU * kU + 2.0 * r * c1 * c2 * kU * kU;
    };
    const double h = 1e-2;  // K (truncation error ~ (h / 295 K)^2, round-off ~ 1e-15 m / h)

    // Point B, x = distance along the beam.
    const double c1 = Derivative(model, t_air, h, [&](const Eigen::VectorXd& s) { return y(1, s)(0); });
    const double c2 = Derivative(model, t_part, h, [&](const Eigen::VectorXd& s) { return y(1, s)(0); });
    EXPECT_GT(c1, 0.0);  // warmer air: n falls, the true range is longer
    EXPECT_LT(c2, 0.0);  // warmer part: shorter at 20 degC
    const double expected = closed_form(c1, c2);
    const std::vector<PointUncertainty> gum = PropagatePoints(model, points, GumOptions{});
    const double obtained = gum[1].cov_part(0, 0);
    std::printf(
        "r = %+.1f  point B: c_air = %.6e m/K, c_part = %.6e m/K, u_x expected %.6e m, GUM %.6e m "
        "(uncorrelated %.6e m)\n",
        r, c1, c2, std::sqrt(expected), std::sqrt(obtained),
        std::sqrt(closed_form(c1, c2) - 2 * r * c1 * c2 * kU * kU));
    EXPECT_NEAR(obtained, expected, 1e-6 * expected);
    if (r == 1.0) {
      // The partial cancellation is what is tested: ignoring the correlation would be far off.
      EXPECT_LT(expected, 0.25 * (c1 * c1 + c2 * c2) * kU * kU);
    }
    // The cross term is the budget's "correlations" row.
    bool found = false;
    for (const BudgetRow& row : gum[1].budget) {
      if (row.input != "correlations") continue;
      found = true;
      EXPECT_NEAR(row.variance(0), 2.0 * r * c1 * c2 * kU * kU, 1e-6 * (c1 * c1 + c2 * c2) * kU * kU);
    }
    EXPECT_TRUE(found);
    // Tracker frame: the instrument inputs only (the air), not the part's temperature.
    const double c_t = Derivative(model, t_air, h, [&](const Eigen::VectorXd& s) {
      Eigen::Vector3d x;
      model.EvaluateTracker(points[1].readings.data(), s.data(), x.data());
      return x(0);
    });
    EXPECT_NEAR(gum[1].cov_tracker(0, 0), c_t * c_t * kU * kU, 1e-6 * c_t * c_t * kU * kU);

    // Distance AB along the beam.
    auto distance = [&](const Eigen::VectorXd& s) { return (y(1, s) - y(0, s)).norm(); };
    const double d1 = Derivative(model, t_air, h, distance);
    const double d2 = Derivative(model, t_part, h, distance);
    const double expected_d = closed_form(d1, d2);
    const TaskUncertainty task = PropagateTask(model, points, job.tasks[0], GumOptions{});
    std::printf("r = %+.1f  distance AB: u expected %.6e m, GUM %.6e m\n", r, std::sqrt(expected_d),
                task.u(0));
    EXPECT_NEAR(task.u(0) * task.u(0), expected_d, 1e-6 * expected_d);
    // Budget by group: environment and thermal alone, the cross term in "correlation"; they add up.
    double sum = 0.0, cross = 0.0;
    for (const TaskGroupContribution& g : task.budget) {
      sum += g.variance(0);
      if (g.group == "correlation") cross = g.variance(0);
    }
    EXPECT_NEAR(sum, task.covariance(0, 0), 1e-9 * task.covariance(0, 0));
    EXPECT_NEAR(cross, 2.0 * r * d1 * d2 * kU * kU, 1e-6 * (d1 * d1 + d2 * d2) * kU * kU);
  }
}

TEST(McmCorrelations, SingularCorrelationBetweenGroupsAgreesWithGum) {
  // r = 1: the copula factor of a singular matrix (model/correlation.h), reading noise on.
  const Job job = ParseJob(
      ThermometerJob(1.0, "range = \"0.5 um\"\nazimuth = \"0.2 arcsec\"\nelevation = \"0.2 arcsec\"\n"),
      "job.toml", std::filesystem::temp_directory_path());
  const MeasurementModel model(job.setup);
  const std::vector<PointReadings> points = Readings(job, model);
  const std::vector<PointUncertainty> gum = PropagatePoints(model, points, GumOptions{});
  const TaskUncertainty task = PropagateTask(model, points, job.tasks[0], GumOptions{});

  McmJob mcm_job;
  mcm_job.model = &model;
  for (const PointReadings& p : points) mcm_job.points.push_back({p.name, p.readings});
  mcm_job.fit_tasks = {job.tasks[0]};
  mcm_job.fit_task_points = {{0, 1}};
  McmSettings settings;
  settings.trials = 200'000;
  settings.seed = 12;
  settings.quiet = true;
  const McmResult mcm = RunMcm(mcm_job, settings);
  ASSERT_EQ(mcm.outputs.size(), 7u);  // A.x A.y A.z B.x B.y B.z AB.distance

  // Standard error of a normal sample's standard deviation: u / sqrt(2 (M - 1)); 5 of them.
  const double m = static_cast<double>(settings.trials);
  auto check = [&](const McmOutputResult& out, double u_gum, double u_uncorrelated) {
    std::printf("%s: u GUM %.6e m, MCM %.6e m (uncorrelated GUM %.6e m)\n", out.name.c_str(), u_gum, out.u,
                u_uncorrelated);
    EXPECT_NEAR(out.u, u_gum, 5.0 * u_gum / std::sqrt(2.0 * (m - 1.0))) << out.name;
    EXPECT_NEAR(out.mean, out.value_at_estimates, 5.0 * u_gum / std::sqrt(m)) << out.name;
    EXPECT_GT(std::abs(u_uncorrelated - u_gum), 20.0 * u_gum / std::sqrt(2.0 * (m - 1.0)));
  };
  // The GUM without the correlation, for scale: the same job with r = 0.
  const Job independent = ParseJob(
      ThermometerJob(0.0, "range = \"0.5 um\"\nazimuth = \"0.2 arcsec\"\nelevation = \"0.2 arcsec\"\n"),
      "job.toml", std::filesystem::temp_directory_path());
  const MeasurementModel model0(independent.setup);
  const std::vector<PointUncertainty> gum0 = PropagatePoints(model0, points, GumOptions{});
  const TaskUncertainty task0 = PropagateTask(model0, points, independent.tasks[0], GumOptions{});
  check(mcm.outputs[3], gum[1].u_part(0), gum0[1].u_part(0));
  check(mcm.outputs[6], task.u(0), task0.u(0));
}

}  // namespace
}  // namespace vlt
