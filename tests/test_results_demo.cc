// test_results_demo.cc — the numbers of the demo job (`vlt demo`, runtime/src/job/default_job.cc).
//
// 1. Independent closed-form bounds. With independent inputs the variance of a point along a unit
//    direction d is sum_i (c_i . d)^2 u_i^2. For the ideal mirror tracker at the job's estimates,
//    the first-order effect of some inputs on the point follows from the conventions alone
//    (docs/conventions.md, models/mirror.toml): azimuth reading noise and a0 move the point by
//    r cos(E) delta along the horizontal transverse direction; eac, eas by r cos(E) cos(A) / sin(A);
//    elevation reading noise by r delta along the vertical transverse direction; the transit
//    (mirror-angle) terms e0, eec, ees by 2 r delta (times cos(E/2), sin(E/2)); the SMR dihedral
//    error sdh by (2 sqrt(6)/3) r delta; range noise, R0, srr and the scale mu (times r) along the
//    beam. Keeping only those terms gives a LOWER bound of u along each direction. An UPPER bound
//    adds every other input with the largest gain it can have: 2 r for an angle (a mirror doubles
//    angles), 2 for an offset, and the refractive-index sensitivities of the air (|dn/dt| < 1e-6/K,
//    |dn/dp| < 3e-9/Pa, |dn/dRH| < 1e-8/%, |dn/dx_CO2| < 2e-4 at 633 nm near 20 degC, 101 kPa,
//    50 %: bounds on the derivatives of Ciddor's equation, Appl. Opt. 35 (1996) 1566) times r.
//    The GUM results along the line of sight must lie between the two.
// 2. The plausibility the demo promises (docs/job-file.md): transverse expanded uncertainties of
//    the order of a commercial tracker's specification 15 um + 6 um/m (the MPE of the Leica
//    Absolute Tracker AT500 product specification, ISO 10360-10 Annex D; typical results about
//    half of it), radial ones of the order of the ADM's
//    10 um + 0.3 um/m: within [0.6, 1.4] and [0.5, 2] of those.
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "vlt/job.h"
#include "vlt/models.h"
#include "vlt/results.h"

namespace vlt {
namespace {

double U(const Job& job, const char* name) {
  int k = FindParam(*job.setup.model, name);
  EXPECT_GE(k, 0) << name;
  return k < 0 ? 0.0 : job.setup.params[static_cast<std::size_t>(k)].u;
}

TEST(DemoJob, GumWithinClosedFormBoundsAndSpecification) {
  Job job = ParseJob(DefaultJobToml(), kDefaultJobName, ".");
  ASSERT_STREQ(job.setup.model->name, "mirror");
  ASSERT_FALSE(job.setup.pose.has_value());  // part frame = tracker frame below
  ASSERT_FALSE(job.setup.thermal.has_value());
  ASSERT_TRUE(job.setup.correlations.empty());  // independent inputs
  RunOptions options;
  options.monte_carlo = false;
  options.compute_map = false;
  Results results = RunJob(job, options);
  const double k = results.k_axis;
  EXPECT_NEAR(k, 1.959964, 1e-6);

  const ReadingNoise& noise = job.setup.noise;
  const Environment& env = *job.setup.environment;
  const double gain_dihedral = 2.0 * std::sqrt(6.0) / 3.0;
  // Inputs whose effect is only bounded: angles (gain <= 2 r) and offsets (gain <= 2).
  const char* other_angles[] = {"rhv", "rmv", "rbh", "rbv"};
  const char* offsets[] = {"thv", "tmv", "tbw", "tbv", "srh", "srv"};
  int checked = 0;
  double max_u_norm = 0.0, max_spec_ratio = 0.0;
  const std::vector<PointUncertainty> details = PointDetails(results);
  for (std::size_t i = 0; i < results.points.size(); ++i) {
    const PointResult& p = results.points[i];
    if (p.input.name[0] != 'P') continue;  // the 36 grid points of the panel
    const Eigen::Vector3d x = p.input.nominal;
    const double r = x.norm();
    const double a = std::atan2(x.y(), x.x());
    const double e = std::atan2(x.z(), std::hypot(x.x(), x.y()));
    const double ce = std::cos(e);

    const double var_h_known = std::pow(r * ce, 2) * (std::pow(noise.azimuth, 2) + std::pow(U(job, "a0"), 2) +
                                                      std::pow(std::cos(a) * U(job, "eac"), 2) +
                                                      std::pow(std::sin(a) * U(job, "eas"), 2));
    const double var_v_known =
        r * r *
        (std::pow(noise.elevation, 2) + std::pow(2 * U(job, "e0"), 2) +
         std::pow(2 * std::cos(e / 2) * U(job, "eec"), 2) + std::pow(2 * std::sin(e / 2) * U(job, "ees"), 2) +
         std::pow(gain_dihedral * U(job, "sdh"), 2));
    const double var_r_known = std::pow(noise.range_a + noise.range_b * r, 2) + std::pow(U(job, "R0"), 2) +
                               std::pow(r * U(job, "mu"), 2) + std::pow(U(job, "srr"), 2);
    double var_bounded = 0.0;
    for (const char* n : other_angles) var_bounded += std::pow(2 * r * U(job, n), 2);
    for (const char* n : offsets) var_bounded += std::pow(2 * U(job, n), 2);
    var_bounded += std::pow(
        r * (1e-6 * env.temperature.u + 3e-9 * env.pressure.u + 1e-8 * env.humidity.u + 2e-4 * env.co2.u), 2);
    // Upper bound in any direction: every input at its largest possible gain.
    const double var_upper = var_h_known + var_v_known + var_r_known + var_bounded;

    const LineOfSightSplit& los = details[i].los_tracker;
    SCOPED_TRACE(p.input.name + " r = " + std::to_string(r) + " m");
    EXPECT_GE(los.u_horizontal, std::sqrt(var_h_known) * (1 - 1e-6));
    EXPECT_GE(los.u_vertical, std::sqrt(var_v_known) * (1 - 1e-6));
    EXPECT_GE(los.u_radial, std::sqrt(var_r_known) * (1 - 1e-6));
    EXPECT_LE(los.u_horizontal, std::sqrt(var_upper));
    EXPECT_LE(los.u_vertical, std::sqrt(var_upper));
    EXPECT_LE(los.u_radial, std::sqrt(var_r_known + var_bounded + 1e-24));
    // Total: trace of the covariance between the sum of the lower bounds and 3x the upper one.
    const double u_norm = std::sqrt(p.gum.cov_part.trace());
    EXPECT_GE(u_norm, std::sqrt(var_h_known + var_v_known + var_r_known) * (1 - 1e-6));

    // The specification band of the demo.
    const double spec_transverse = 15e-6 + 6e-6 * r;
    const double spec_radial = 10e-6 + 0.3e-6 * r;
    for (double u_t : {los.u_horizontal, los.u_vertical}) {
      EXPECT_GE(k * u_t / spec_transverse, 0.6);
      EXPECT_LE(k * u_t / spec_transverse, 1.4);
      max_spec_ratio = std::max(max_spec_ratio, k * u_t / spec_transverse);
    }
    EXPECT_GE(k * los.u_radial / spec_radial, 0.5);
    EXPECT_LE(k * los.u_radial / spec_radial, 2.0);
    max_u_norm = std::max(max_u_norm, k * u_norm);
    ++checked;
  }
  EXPECT_EQ(checked, 36);
  // The farthest grid points are ~7.1 m away: |U| must be of the order of sqrt(2) x the
  // transverse spec there (two transverse axes) plus the radial part: 60 .. 120 um.
  EXPECT_GT(max_u_norm, 60e-6);
  EXPECT_LT(max_u_norm, 120e-6);
  EXPECT_GT(max_spec_ratio, 0.8);  // the far points use most of the spec
}

}  // namespace
}  // namespace vlt
