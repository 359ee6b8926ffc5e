// The mirror plane offset tmv in the generated `mirror` model against the closed form of the
// paper (Huo et al. 2010, eq. 10-14), corrected as derived in docs/models.md.
//
// The paper's 2-D situation in our conventions: azimuth 0 (the x-z plane), every error zero
// except tmv; the incident beam goes up the z axis through the rotation centre O; the paper's
// theta is the angle between incident beam and mirror plane, theta = pi/4 - E/2 (E the beam
// elevation), theta0 = pi/4 at home. "The interferometer reading at the initial position is
// zero" = the range is calibrated at home, i.e. counted from the home hit point
// O0 = (0, 0, -tmv/sin(theta0)): in our parametrisation R0 = -tmv/sin(theta0).
// The paper measures range and angle from O0, so the model's true point P is expressed as a
// range |O0 P| and an elevation seen from O0.
//
// Corrected closed form (signed distances, tmv > 0 moves the reflecting surface toward the
// beam, Oi below O0 when theta < theta0):
//   (12') delta = O0Oi = tmv/sin(theta) - tmv/sin(theta0)         (printed with the opposite sign)
//   (11)  rho_m = OiPi - delta            ->  OiPi = rho_m + delta
//   (13)  O0Pi  = sqrt(delta^2 + OiPi^2 - 2 delta OiPi cos(2 theta))
//   (10)  drho  = O0Pi - rho_m
//   (14') phi   = atan2(OiPi sin(2 theta), delta - OiPi cos(2 theta))  (angle at O0 in the
//         triangle O0 Oi Pi), dtheta = theta + phi/2 - pi/2 = (E_true - E_measured)/2.
//         The printed arcsin(OiPi/O0Pi sin 2theta) returns pi - phi when phi > pi/2, i.e. for
//         every beam above the horizon (theta < 45 deg): the printed eq. 14 is wrong there.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "vlt/models.h"

namespace {

constexpr double kPi = 3.14159265358979323846;

struct ClosedForm {
  double drho;            // m: range error seen from O0
  double dtheta;          // rad: mirror-angle-equivalent direction error (half the elevation error)
  double dtheta_printed;  // rad: the printed eq. 14 with arcsin
};

ClosedForm PaperClosedForm(double tmv, double rho_m, double theta) {
  const double theta0 = kPi / 4;
  const double delta = tmv / std::sin(theta) - tmv / std::sin(theta0);
  const double oipi = rho_m + delta;
  const double o0pi = std::sqrt(delta * delta + oipi * oipi - 2 * delta * oipi * std::cos(2 * theta));
  const double phi = std::atan2(oipi * std::sin(2 * theta), delta - oipi * std::cos(2 * theta));
  ClosedForm c;
  c.drho = o0pi - rho_m;
  c.dtheta = theta + phi / 2 - kPi / 2;
  c.dtheta_printed = theta + 0.5 * std::asin(oipi / o0pi * std::sin(2 * theta)) - kPi / 2;
  return c;
}

TEST(GeneratedMirrorOffset, ReproducesCorrectedPaperEquations10To14) {
  const vlt::ModelInfo* model = vlt::FindModel("mirror");
  ASSERT_NE(model, nullptr);
  const int k_tmv = vlt::FindParam(*model, "tmv");
  const int k_r0 = vlt::FindParam(*model, "R0");
  ASSERT_GE(k_tmv, 0);
  ASSERT_GE(k_r0, 0);
  int checked = 0;
  for (double tmv : {5e-6, -20e-6, 1e-3}) {
    std::vector<double> params(model->num_params, 0.0);
    params[k_tmv] = tmv;
    params[k_r0] = -tmv / std::sin(kPi / 4);     // range calibrated at home (reading counts from O0)
    const double z0 = -tmv / std::sin(kPi / 4);  // O0, the home hit point
    for (double rho : {0.5, 3.0, 40.0}) {
      for (double theta_deg = 5; theta_deg <= 85; theta_deg += 2.5) {
        const double theta = theta_deg * kPi / 180;
        const double elevation = kPi / 2 - 2 * theta;
        const double readings[3] = {rho, 0.0, elevation};
        double p[3];
        model->forward(readings, params.data(), p);
        EXPECT_NEAR(p[1], 0.0, 1e-15);  // stays in the x-z plane
        const double range_from_o0 = std::hypot(p[0], p[2] - z0);
        const double elevation_from_o0 = std::atan2(p[2] - z0, p[0]);
        const ClosedForm c = PaperClosedForm(tmv, rho, theta);
        EXPECT_NEAR(range_from_o0 - rho, c.drho, 1e-9) << "tmv " << tmv << " theta " << theta_deg;
        EXPECT_NEAR((elevation_from_o0 - elevation) / 2, c.dtheta, 1e-9)
            << "tmv " << tmv << " theta " << theta_deg;
        if (theta_deg > 45) {
          // Beam below the horizon: the printed arcsin form is right.
          EXPECT_NEAR(c.dtheta_printed, c.dtheta, 1e-9) << theta_deg;
        } else if (theta_deg < 40) {
          // Beam above the horizon: the printed form picks the wrong arcsin branch.
          EXPECT_GT(std::abs(c.dtheta_printed - c.dtheta), 0.1) << theta_deg;
        }
        ++checked;
      }
    }
  }
  EXPECT_EQ(checked, 3 * 3 * 33);
}

// At the home position (theta = theta0) the calibration absorbs the offset completely.
TEST(GeneratedMirrorOffset, NoErrorAtTheCalibrationPosition) {
  const vlt::ModelInfo* model = vlt::FindModel("mirror");
  ASSERT_NE(model, nullptr);
  std::vector<double> params(model->num_params, 0.0);
  const double tmv = 50e-6;
  params[vlt::FindParam(*model, "tmv")] = tmv;
  params[vlt::FindParam(*model, "R0")] = -tmv * std::sqrt(2.0);
  const double readings[3] = {7.0, 0.0, 0.0};
  double p[3];
  model->forward(readings, params.data(), p);
  EXPECT_NEAR(p[0], 7.0, 1e-12);
  EXPECT_NEAR(p[2], -tmv * std::sqrt(2.0), 1e-12);  // the point seen from O0 is exact
}

}  // namespace
