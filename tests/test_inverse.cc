// vlt/inverse.h: the readings a tracker shows when locked on a point.
// Reference: the generated forward model itself — forward(inverse(p)) must give p back to
// 1e-12 m — and, with zero errors, the closed-form spherical inverse.
#include "vlt/inverse.h"

#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "vlt/error.h"
#include "vlt/models.h"

namespace {

constexpr double kPi = 3.14159265358979323846;

std::vector<std::array<double, 3>> GridPoints() {
  std::vector<std::array<double, 3>> points;
  for (double range : {0.5, 1.3, 4.0, 12.0, 40.0}) {
    for (double a = -3.1; a < 3.2; a += 0.55) {
      for (double e = -1.2; e <= 1.35; e += 0.25) {
        points.push_back(
            {range * std::cos(e) * std::cos(a), range * std::cos(e) * std::sin(a), range * std::sin(e)});
      }
    }
  }
  return points;
}

void RoundTrip(const char* name, double scale, std::uint64_t seed) {
  const vlt::ModelInfo* model = vlt::FindModel(name);
  ASSERT_NE(model, nullptr);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<double> params(model->num_params);
  for (int k = 0; k < model->num_params; ++k) params[k] = scale * model->params[k].default_u * normal(rng);
  for (const auto& p : GridPoints()) {
    for (vlt::Face face : {vlt::Face::kFront, vlt::Face::kBack}) {
      const auto r = vlt::InverseReadings(*model, params.data(), p, face);
      double out[3];
      model->forward(r.data(), params.data(), out);
      for (int i = 0; i < 3; ++i) {
        EXPECT_NEAR(out[i], p[i], 1e-12) << name << " face " << vlt::FaceName(face);
      }
      EXPECT_GE(r[1], 0.0);
      EXPECT_LT(r[1], 2 * kPi);
      if (face == vlt::Face::kFront) {
        EXPECT_LE(std::abs(r[2]), kPi / 2);
      } else {
        EXPECT_GE(r[2], kPi / 2);
        EXPECT_LE(r[2], 3 * kPi / 2);
      }
      if (scale == 0.0) {  // zero errors: the closed form exactly
        const auto ideal = vlt::IdealReadings(p, face);
        EXPECT_NEAR(r[0], ideal[0], 1e-12);
        EXPECT_NEAR(std::remainder(r[1] - ideal[1], 2 * kPi), 0.0, 1e-13);
        EXPECT_NEAR(r[2], ideal[2], 1e-13);
      }
    }
  }
}

TEST(Inverse, MirrorZeroErrorsRoundTrip) { RoundTrip("mirror", 0.0, 1); }
TEST(Inverse, MirrorRealisticErrorsRoundTrip) { RoundTrip("mirror", 1.0, 2); }
TEST(Inverse, MirrorLargeErrorsRoundTrip) { RoundTrip("mirror", 100.0, 3); }
TEST(Inverse, HeadZeroErrorsRoundTrip) { RoundTrip("head", 0.0, 4); }
TEST(Inverse, HeadRealisticErrorsRoundTrip) { RoundTrip("head", 1.0, 5); }
TEST(Inverse, HeadLargeErrorsRoundTrip) { RoundTrip("head", 100.0, 6); }

TEST(Inverse, IdealClosedFormAndFaces) {
  const std::array<double, 3> p = {1.0, -1.0, std::sqrt(2.0)};  // range 2, A = -45 deg, E = 45 deg
  const auto front = vlt::IdealReadings(p, vlt::Face::kFront);
  EXPECT_NEAR(front[0], 2.0, 1e-15);
  EXPECT_NEAR(front[1], 2 * kPi - kPi / 4, 1e-15);  // azimuth normalised to [0, 2pi)
  EXPECT_NEAR(front[2], kPi / 4, 1e-15);
  const auto back = vlt::IdealReadings(p, vlt::Face::kBack);
  EXPECT_NEAR(back[1], 3 * kPi / 4, 1e-15);  // A + pi, wrapped
  EXPECT_NEAR(back[2], 3 * kPi / 4, 1e-15);  // pi - E
}

TEST(Inverse, SingularPointsAreErrorsNotNaN) {
  const vlt::ModelInfo* model = vlt::FindModel("mirror");
  ASSERT_NE(model, nullptr);
  std::vector<double> params(model->num_params, 0.0);
  EXPECT_THROW(vlt::InverseReadings(*model, params.data(), {0.0, 0.0, 5.0}, vlt::Face::kFront),
               vlt::NumericalError);  // on the vertical axis
  EXPECT_THROW(vlt::InverseReadings(*model, params.data(), {1e-7, 0.0, -3.0}, vlt::Face::kBack),
               vlt::NumericalError);  // 0.1 um from the axis
  EXPECT_THROW(vlt::InverseReadings(*model, params.data(), {0.0, 0.0, 0.0}, vlt::Face::kFront),
               vlt::NumericalError);  // at the origin
  try {
    vlt::InverseReadings(*model, params.data(), {0.0, 0.0, 5.0}, vlt::Face::kFront);
  } catch (const vlt::NumericalError& e) {
    EXPECT_NE(std::string(e.what()).find("vertical axis"), std::string::npos) << e.what();
  }
  // 2 um from the axis is still defined (documented tolerance 1 um).
  const auto r = vlt::InverseReadings(*model, params.data(), {2e-6, 0.0, 5.0}, vlt::Face::kFront);
  EXPECT_NEAR(r[0], 5.0, 1e-9);
}

TEST(Inverse, CustomModelIsAnInputError) {
  const vlt::ModelInfo* model = vlt::FindModel("jcgm101_additive");
  ASSERT_NE(model, nullptr);
  const double x[4] = {0, 0, 0, 0};
  EXPECT_THROW(vlt::InverseReadings(*model, x, {1.0, 0.0, 0.0}, vlt::Face::kFront), vlt::InputError);
}

TEST(Inverse, NormalizeAzimuth) {
  EXPECT_EQ(vlt::NormalizeAzimuth(0.0), 0.0);
  EXPECT_NEAR(vlt::NormalizeAzimuth(-kPi / 2), 1.5 * kPi, 1e-15);
  EXPECT_NEAR(vlt::NormalizeAzimuth(5 * kPi), kPi, 1e-14);
  EXPECT_LT(vlt::NormalizeAzimuth(-1e-300), 2 * kPi);
}

}  // namespace
