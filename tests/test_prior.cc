// Priors from a datasheet's MPE statements (vlt prior, docs/profiles.md). References: closed forms
// of the Gaussian norm's distribution, the equal-share optimum of one binding statement, and a
// Monte Carlo of the nonlinear simulated tests with parameters drawn from the derived prior.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include <gtest/gtest.h>

#include "mcm/random.h"
#include "vlt/calibration.h"
#include "vlt/error.h"
#include "vlt/gum.h"

namespace vlt {
namespace {

const std::string kProfiles = std::string(VLT_SOURCE_DIR) + "/profiles/";

TEST(ProbabilityWithinSphere, MatchesClosedForms) {
  // Isotropic: |x|^2 / s^2 ~ chi-square(3).
  EXPECT_NEAR(ProbabilityWithinSphere(Eigen::Vector3d(4.0, 4.0, 4.0), 5.0), ChiSquareCdf(25.0 / 4.0, 3), 1e-12);
  // Two equal axes, the third zero: 1 - exp(-r^2 / 2 s^2).
  EXPECT_NEAR(ProbabilityWithinSphere(Eigen::Vector3d(0.0, 2.0, 2.0), 1.5), 1.0 - std::exp(-1.5 * 1.5 / 4.0), 1e-10);
  // One axis: 2 Phi(r / s) - 1.
  EXPECT_NEAR(ProbabilityWithinSphere(Eigen::Vector3d(0.0, 0.0, 9.0), 4.0), std::erf(4.0 / 3.0 / std::sqrt(2.0)),
              1e-9);
  EXPECT_EQ(ProbabilityWithinSphere(Eigen::Vector3d(1.0, 1.0, 1.0), 0.0), 0.0);
}

TEST(ProbabilityWithinSphere, MatchesMonteCarloForUnequalAxes) {
  const Eigen::Vector3d variances(0.3, 1.7, 5.2);
  const double r = 3.1;
  std::mt19937_64 rng(7);
  std::normal_distribution<double> normal;
  const int n = 2000000;
  int inside = 0;
  for (int i = 0; i < n; ++i) {
    double q = 0.0;
    for (int a = 0; a < 3; ++a) q += variances(a) * std::pow(normal(rng), 2);
    inside += q <= r * r;
  }
  const double p = static_cast<double>(inside) / n;
  EXPECT_NEAR(ProbabilityWithinSphere(variances, r), p, 4.0 * std::sqrt(p * (1 - p) / n));
}

// A one-test layout: one ranging test against one statement. The maximum-entropy optimum of one
// constraint gives every free parameter the same share of the budget (1 / v_k = 2 lambda a_k).
TEST(DerivePrior, OneStatementSharesItsBudgetEqually) {
  PriorJob job = LoadPriorJob(kProfiles + "leica-at500.toml");
  TestLayout one = job.layout;
  one.tests.erase(std::remove_if(one.tests.begin(), one.tests.end(),
                                 [](const StandardTest& t) { return t.name != "RG8"; }),
                  one.tests.end());
  ASSERT_EQ(one.tests.size(), 1u);
  job.layout = one;
  job.settings.bound = 1000.0;  // no bound reached
  const PriorResult r = DerivePrior(job);
  ASSERT_EQ(r.tests.size(), 1u);
  const PriorTest& t = r.tests[0];
  EXPECT_TRUE(t.binding);
  EXPECT_NEAR(t.conformance, job.settings.conformance_probability, 1e-12);
  double first = -1.0;
  int free = 0;
  double held = 0.0;
  for (std::size_t k = 0; k < r.parameters.size(); ++k) {
    if (r.parameters[k].status == PriorStatus::kNotConstrained) held += t.share(k);
    if (r.parameters[k].status != PriorStatus::kFromMpe) continue;
    ++free;
    if (first < 0) first = t.share(k);
    EXPECT_NEAR(t.share(k), first, 1e-6 * first) << r.parameters[k].name;
  }
  ASSERT_GE(free, 2);
  // The shares and the noise's fill the test's variance exactly at the MPE.
  const double noise = t.u_noise * t.u_noise / (t.u * t.u);
  EXPECT_NEAR(free * first + held + noise, 1.0, 1e-9);
  EXPECT_NEAR(r.z * t.u, t.mpe, 1e-9 * t.mpe);
}

// Every shipped profile: every test meets its statement at the stated probability (exactly for the
// Gaussian), the binding ones at it, and no parameter's u exceeds its bound.
TEST(DerivePrior, ShippedProfilesMeetEveryStatement) {
  int profiles = 0;
  for (const auto& entry : std::filesystem::directory_iterator(kProfiles)) {
    if (entry.path().extension() != ".toml") continue;
    ++profiles;
    const PriorJob job = LoadPriorJob(entry.path().string());
    const PriorResult r = DerivePrior(job);
    const double p = job.settings.conformance_probability;
    int binding = 0;
    for (const PriorTest& t : r.tests) {
      EXPECT_GE(t.conformance, p - 1e-9) << entry.path() << " " << t.name;
      if (t.binding) {
        ++binding;
        EXPECT_NEAR(t.conformance, p, 1e-6) << entry.path() << " " << t.name;
      }
    }
    EXPECT_GT(binding, 0) << entry.path();
    for (const PriorParameter& q : r.parameters) {
      if (q.status == PriorStatus::kFromMpe || q.status == PriorStatus::kAtBound) {
        EXPECT_LE(q.u, q.bound * (1 + 1e-12)) << entry.path() << " " << q.name;
      }
    }
  }
  EXPECT_GE(profiles, 3);
}

// The derivation is linear in the parameters; the tests are not. Trackers drawn from the derived
// prior (parameters ~ N(compensation, u^2)), each test simulated exactly with the drawn error state
// plus the reading noise: the fraction within the MPE is the conformance probability (binding
// tests at p, all at least p), within the Monte Carlo's standard error.
void ExpectDrawnTrackersConform(const PriorJob& job, int draws) {
  const PriorResult prior = DerivePrior(job);
  const mcm_internal::KeyedStream stream(2026);
  auto normal = [&](std::uint64_t trial, std::uint64_t input) {
    double z[4];
    stream.Normals(trial / 4, input, z);
    return z[trial % 4];
  };
  std::vector<int> inside(prior.tests.size(), 0);
  for (int d = 0; d < draws; ++d) {
    MeasurementSetup tracker = job.tracker;
    for (std::size_t k = 0; k < tracker.params.size(); ++k)
      tracker.params[k].estimate = prior.parameters[k].estimate + prior.parameters[k].u * normal(d, k);
    const std::vector<TestResult> sim = SimulateTests(tracker, job.layout, job.mpe);
    std::size_t i = 0;
    for (std::size_t s = 0; s < sim.size(); ++s) {
      if (sim[s].mpe <= 0.0) continue;
      const TestResult& t = sim[s];
      double error = 0.0;
      if (t.kind == TestKind::kTwoFace) {
        const Eigen::Matrix3d l = t.two_face_noise.llt().matrixL();
        const Eigen::Vector3d z(normal(d, 100 + 3 * s), normal(d, 101 + 3 * s), normal(d, 102 + 3 * s));
        error = (t.two_face + l * z).norm();
      } else {
        error = t.error + t.u_noise * normal(d, 100 + 3 * s);
      }
      inside[i++] += std::abs(error) <= t.mpe;
    }
    ASSERT_EQ(i, prior.tests.size());
  }
  const double p = job.settings.conformance_probability;
  const double se = std::sqrt(p * (1 - p) / draws);
  for (std::size_t i = 0; i < prior.tests.size(); ++i) {
    const double fraction = static_cast<double>(inside[i]) / draws;
    EXPECT_GE(fraction, prior.tests[i].conformance - 4.0 * se) << prior.tests[i].name << " p = " << p;
    if (prior.tests[i].binding) {
      EXPECT_LE(fraction, p + 4.0 * se) << prior.tests[i].name << " p = " << p;
    }
  }
}

TEST(DerivePrior, DrawnTrackersMeetTheStatementsAtTheStatedProbability) {
  ExpectDrawnTrackersConform(LoadPriorJob(kProfiles + "leica-at500.toml"), 2000);
}

// One standard deviation (ISO 17123 statements; the two-face factor is then above z) and 0.99.
TEST(DerivePrior, DrawnTrackersConformAtOtherProbabilities) {
  for (const double p : {0.6827, 0.99}) {
    PriorJob job = LoadPriorJob(kProfiles + "leica-at500.toml");
    job.settings.conformance_probability = p;
    ExpectDrawnTrackersConform(job, 1000);
  }
}

// The mirror model with all three statements at p = 0.99: the two-face factors reach their fixed
// point (slowly: about 0.7 per round) and every test meets its statement.
TEST(DerivePrior, MirrorWithEveryStatementConverges) {
  PriorJob job = LoadPriorJob(kProfiles + "mirror-15um-6um.toml");
  job.mpe.two_face = Mpe{true, 30e-6, 12e-6};
  job.settings.conformance_probability = 0.99;
  const PriorResult r = DerivePrior(job);
  int two_face = 0;
  for (const PriorTest& t : r.tests) {
    EXPECT_GE(t.conformance, 0.99 - 1e-12) << t.name;
    two_face += t.kind == TestKind::kTwoFace;
  }
  EXPECT_EQ(two_face, 36);
  ExpectDrawnTrackersConform(job, 500);
}

// The noise alone is judged by the exact probability of |Delta|: angle noise of 0.95 arcsec gives
// z sqrt(tr C) above the 6 m two-face MPE while P(|Delta_noise| <= MPE) is still above 0.95.
TEST(DerivePrior, TwoFaceNoiseIsJudgedExactly) {
  PriorJob job = LoadPriorJob(kProfiles + "leica-at500.toml");
  job.tracker.noise.azimuth = job.tracker.noise.elevation = 0.95 * 4.84813681109536e-6;
  job.mpe.ranging = Mpe{};
  const PriorResult r = DerivePrior(job);
  bool beyond_z = false;
  for (const PriorTest& t : r.tests) {
    EXPECT_GE(t.conformance, 0.95 - 1e-12) << t.name;
    beyond_z = beyond_z || r.z * t.u_noise > t.mpe;
  }
  EXPECT_TRUE(beyond_z) << "the case must have a test whose noise trace is beyond z";
}

// A statement no parameter can reach: nothing is sized by it, nothing is refused.
TEST(DerivePrior, GenerousStatementsConstrainNothing) {
  PriorJob job = LoadPriorJob(kProfiles + "leica-at500.toml");
  job.mpe.ranging = Mpe{true, 1.0, 0.0};
  job.mpe.two_face = Mpe{true, 1.0, 0.0};
  const PriorResult r = DerivePrior(job);
  for (const PriorParameter& q : r.parameters) {
    EXPECT_EQ(q.status, PriorStatus::kNotConstrained) << q.name;
    EXPECT_EQ(q.u, q.u0) << q.name;
  }
  for (const PriorTest& t : r.tests) EXPECT_GT(t.conformance, 0.999999) << t.name;
}

// No noise and one parameter: a test that parameter does not see has no spread at all; its shares
// are 0, not NaN, and it conforms with certainty.
TEST(DerivePrior, TestsWithoutSpreadHaveFiniteShares) {
  PriorJob job = LoadPriorJob(kProfiles + "leica-at500.toml");
  job.tracker.noise = ReadingNoise{};
  for (UncertainInput& in : job.tracker.params) in.u = in.name == "ex" ? 2e-6 : 0.0;
  const PriorResult r = DerivePrior(job);
  for (const PriorTest& t : r.tests) {
    EXPECT_TRUE(t.share.allFinite()) << t.name;
    EXPECT_TRUE(std::isfinite(t.conformance)) << t.name;
  }
}

TEST(DerivePrior, NoiseAboveTheStatementIsRefused) {
  PriorJob job = LoadPriorJob(kProfiles + "leica-at500.toml");
  job.tracker.noise.range_a = 20e-6;  // 20 um of range noise against a 10 um ranging MPE
  try {
    DerivePrior(job);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("the reading noise alone"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace vlt
