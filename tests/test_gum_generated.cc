// GUM engine on the generated models: the published JCGM 101 9.2 and GUM H.1 examples through
// the custom-model path, and the tracker models (mirror, head) against finite differences.
#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "vlt/error.h"
#include "vlt/gum.h"
#include "vlt/models.h"

namespace vlt {
namespace {

std::vector<UncertainInput> Defaults(const ModelInfo& model) {
  std::vector<UncertainInput> in;
  for (int k = 0; k < model.num_params; ++k) {
    UncertainInput u;
    u.name = model.params[k].name;
    u.unit = model.params[k].unit;
    u.estimate = model.params[k].default_estimate;
    u.u = model.params[k].default_u;
    u.distribution = model.params[k].default_distribution;
    in.push_back(u);
  }
  return in;
}

TEST(GumGenerated, Jcgm101AdditiveModel) {
  const ModelInfo* model = FindModel("jcgm101_additive");
  ASSERT_NE(model, nullptr);
  std::vector<UncertainInput> in = Defaults(*model);
  for (auto& x : in) {
    x.estimate = 0.0;
    x.u = 1.0;
  }
  // JCGM 101 9.2.2: four N(0, 1) inputs: u(y) = 2, GUM 95 % interval +-3.92.
  CustomUncertainty r = PropagateCustom(*model, in);
  ASSERT_EQ(r.outputs.size(), 1u);
  EXPECT_NEAR(r.outputs[0].estimate, 0.0, 1e-15);
  EXPECT_NEAR(r.outputs[0].u, 2.0, 1e-14);
  EXPECT_NEAR(r.outputs[0].U, 3.92, 0.005);
  // JCGM 101 9.2.4: X4 rectangular with standard deviation 10: u(y) = 10.15, GUM +-19.89.
  in[3].distribution = "rectangular";
  in[3].u = 10.0;
  r = PropagateCustom(*model, in);
  EXPECT_NEAR(r.outputs[0].u, 10.15, 0.005);
  EXPECT_NEAR(r.outputs[0].U, 19.89, 0.005);
  EXPECT_EQ(r.outputs[0].budget[0].input, in[3].name);
  EXPECT_EQ(r.outputs[0].budget[0].sensitivity_unit, "1");
}

TEST(GumGenerated, GumH1EndGauge) {
  const ModelInfo* model = FindModel("gum_h1_end_gauge");
  ASSERT_NE(model, nullptr);
  const std::vector<UncertainInput> in = Defaults(*model);
  const CustomUncertainty r = PropagateCustom(*model, in);
  ASSERT_EQ(r.outputs.size(), 1u);
  // GUM H.1.5: l = 50.000 838 mm, u_c(l) = 32 nm (first-order terms only).
  EXPECT_NEAR((r.outputs[0].estimate - 0.05) * 1e9, 838.0, 0.5);
  EXPECT_NEAR(r.outputs[0].u * 1e9, 32.0, 0.5);
  // Budget: sensitivity units derived from the output unit "m".
  auto unit_of = [&](const std::string& name) {
    for (const BudgetRow& row : r.outputs[0].budget) {
      if (row.input == name) return row.sensitivity_unit;
    }
    return std::string("missing");
  };
  EXPECT_EQ(unit_of("l_s"), "m/m");
  EXPECT_EQ(unit_of("theta"), "m/K");
  EXPECT_EQ(unit_of("alpha_s"), "m*K");
  double share = 0.0;
  for (const BudgetRow& row : r.outputs[0].budget) share += row.share(0);
  EXPECT_NEAR(share, 1.0, 1e-12);
}

// Every generated tracker model with its full default error set: the budget's sensitivity
// coefficients equal central differences of MeasurementModel::Evaluate.
TEST(GumGenerated, TrackerBudgetsMatchFiniteDifferences) {
  int checked = 0;
  for (const ModelInfo* info : AllModels()) {
    if (std::string(info->kind) != "tracker") continue;
    ++checked;
    MeasurementSetup s;
    s.model = info;
    s.params = Defaults(*info);
    s.noise = {5e-6, 0.5e-6, 1e-6, 1e-6};
    StationPose pose;
    pose.rz.estimate = 0.3;
    pose.rz.u = 5e-6;
    pose.tx.estimate = 2.0;
    pose.tx.u = 1e-5;
    s.pose = pose;
    MeasurementModel m(s);
    const std::vector<PointReadings> pts = {{"A", {4.0, 0.5, 0.1}}, {"B", {12.0, -2.0, -0.3}}};
    const auto res = PropagatePoints(m, pts);
    const Eigen::VectorXd x0 = m.shared_estimates();
    for (std::size_t i = 0; i < pts.size(); ++i) {
      double share = 0.0;
      for (const BudgetRow& row : res[i].budget) {
        share += row.share.sum() / 3.0;
        int col = -1;
        for (int k = 0; k < m.num_shared(); ++k) {
          if (m.shared_inputs()[k].name == row.input) col = k;
        }
        if (col < 0) continue;  // readings are checked in test_measurement_model
        Eigen::VectorXd x = x0;
        const double h = row.group == "parameter" ? 1e-6 : std::max(row.u, 1e-9);
        Eigen::Vector3d yp, ym;
        x(col) = x0(col) + h;
        m.Evaluate(pts[i].readings.data(), x.data(), yp.data());
        x(col) = x0(col) - h;
        m.Evaluate(pts[i].readings.data(), x.data(), ym.data());
        const Eigen::Vector3d fd = (yp - ym) / (2 * h);
        EXPECT_LE((row.sensitivity - fd).norm(), 1e-6 * fd.norm() + 1e-9) << info->name << " " << row.input;
      }
      EXPECT_NEAR(share, 1.0, 1e-12);
    }
  }
  EXPECT_GE(checked, 2);
}

// Mirror model, pure range scale (mu): the distance between two points on one line of sight
// has u = u(mu) |rho2 - rho1| (fully correlated), through the task path with the fits.
TEST(GumGenerated, MirrorRangeScaleDistance) {
  const ModelInfo* info = FindModel("mirror");
  ASSERT_NE(info, nullptr);
  MeasurementSetup s;
  s.model = info;
  s.params = Defaults(*info);
  for (auto& p : s.params) {
    p.estimate = 0.0;
    p.u = 0.0;
  }
  const int mu = FindParam(*info, "mu");
  ASSERT_GE(mu, 0);
  s.params[mu].u = 1e-6;
  MeasurementModel m(s);
  const std::vector<PointReadings> pts = {{"P1", {3.0, 0.7, 0.2}}, {"P2", {11.0, 0.7, 0.2}}};
  TaskSpec task{"d12", TaskKind::kDistance, {"P1", "P2"}, {}};
  const TaskUncertainty t = PropagateTask(m, pts, task);
  EXPECT_NEAR(t.value(0), 8.0, 1e-9);
  EXPECT_NEAR(t.u(0), 1e-6 * 8.0, 1e-6 * 8.0 * 1e-9);
}

}  // namespace
}  // namespace vlt
