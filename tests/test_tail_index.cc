// test_tail_index.cc — outputs without a finite variance (vlt/mcm.h McmOutputResult::tail_index,
// issue 31 item 4): Hill's estimator on samples whose tail index is known in closed form — Cauchy
// (alpha = 1), Student t with 1.5 and 3 degrees of freedom (alpha = nu), normal and uniform
// (every moment finite) — and a custom-model job whose ratio has a divisor whose interval holds 0.
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "mcm/engine.h"
#include "mcm/order.h"
#include "vlt/custom_job.h"
#include "vlt/results.h"

namespace vlt {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kP = 0.95;

// The index and the verdict of M values, as the engine computes them from its sorted tails.
mcm_internal::TailIndexEstimate EstimateOf(const std::vector<float>& values) {
  McmOutputResult out;
  mcm_internal::IntervalsAndTailIndex(std::span<const float>(values), 0.0, kP, out);
  mcm_internal::TailIndexEstimate estimate;
  estimate.index = out.tail_index;
  estimate.infinite_variance = out.infinite_variance;
  return estimate;
}

template <typename Draw>
std::vector<float> Sample(std::int64_t m, Draw draw) {
  std::mt19937_64 rng(20261127);
  std::vector<float> values(static_cast<std::size_t>(m));
  for (float& v : values) v = static_cast<float>(draw(rng));
  return values;
}

double StudentT(std::mt19937_64& rng, double nu) {
  std::normal_distribution<double> z;
  std::chi_squared_distribution<double> w(nu);
  return z(rng) / std::sqrt(w(rng) / nu);
}

TEST(TailIndex, HillRecoversTheIndexOfKnownTails) {
  constexpr std::int64_t m = 1'000'000;  // k = 5000, 1000, 200 values per tail
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::normal_distribution<double> z01;
  const auto cauchy =
      EstimateOf(Sample(m, [&](auto& g) { return 250.0 + 3.0 * std::tan(kPi * (u01(g) - 0.5)); }));
  ASSERT_TRUE(cauchy.index.has_value());
  EXPECT_NEAR(*cauchy.index, 1.0, 0.08);  // 5.7 standard errors (1 / 70.7)
  EXPECT_TRUE(cauchy.infinite_variance);
  const auto t15 = EstimateOf(Sample(m, [&](auto& g) { return StudentT(g, 1.5); }));
  EXPECT_NEAR(*t15.index, 1.5, 0.15);
  EXPECT_TRUE(t15.infinite_variance);
  // A finite variance: never flagged, also where one fraction alone would have been fooled
  // (a lognormal of sigma 1.5, the fifth power of a normal, a 1 % wide component: 1.8, 1.8 and
  // 1.2 at 0.5 %; their estimates rise deeper in the tail, a power tail's do not).
  const auto t3 = EstimateOf(Sample(m, [&](auto& g) { return StudentT(g, 3.0); }));
  EXPECT_GT(*t3.index, 2.5);
  EXPECT_LT(*t3.index, 3.6);
  EXPECT_FALSE(t3.infinite_variance);
  const auto lognormal = EstimateOf(Sample(m, [&](auto& g) { return std::exp(1.5 * z01(g)); }));
  EXPECT_LT(*lognormal.index, 2.0);
  EXPECT_FALSE(lognormal.infinite_variance);
  const auto fifth = EstimateOf(Sample(m, [&](auto& g) { return std::pow(z01(g), 5); }));
  EXPECT_FALSE(fifth.infinite_variance);
  const auto mixture = EstimateOf(Sample(m, [&](auto& g) { return (u01(g) < 0.01 ? 10.0 : 1.0) * z01(g); }));
  EXPECT_FALSE(mixture.infinite_variance);
  std::normal_distribution<double> z(1e3, 1e-3);  // far from 0: measured from the interval's centre
  const auto normal = EstimateOf(Sample(m, [&](auto& g) { return z(g); }));
  EXPECT_GT(*normal.index, 5.0);
  EXPECT_FALSE(normal.infinite_variance);
  const auto uniform = EstimateOf(Sample(m, [&](auto& g) { return u01(g); }));
  EXPECT_GT(*uniform.index, 20.0);  // a bounded tail
  EXPECT_FALSE(uniform.infinite_variance);
  const auto constant = EstimateOf(std::vector<float>(m, 0.0f));  // u = 0: bounded, never NaN
  EXPECT_FALSE(constant.infinite_variance);
  EXPECT_FALSE(std::isnan(constant.index.value_or(0.0)));
}

TEST(TailIndex, EstimatedFrom1e4AndDecidedFrom2point5e5Values) {
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  auto cauchy = [&](auto& g) { return std::tan(kPi * (u01(g) - 0.5)); };
  EXPECT_FALSE(EstimateOf(Sample(9'999, cauchy)).index.has_value());  // k = 49 < 50
  const auto small = EstimateOf(Sample(100'000, cauchy));
  EXPECT_TRUE(small.index.has_value());
  EXPECT_FALSE(small.infinite_variance);  // 20 values at 0.02 %: not decided
  EXPECT_TRUE(EstimateOf(Sample(250'000, cauchy)).infinite_variance);
}

// Twelve ratios y_i = (i + 1) x1 / x2 with x2 ~ N(0.001, 0.01^2): a pole 0.1 u from the estimate,
// Cauchy tails. Twelve outputs on one thread take the engine's per-output path (no shared order
// statistics: docs/monte-carlo.md §4), which must estimate the index as the shared path does.
constexpr int kRatios = 12;
void RatiosJacobians(const double*, const double* x, double* y, double*, double* j) {
  for (int i = 0; i < kRatios; ++i) {
    y[i] = (i + 1) * x[0] / x[1];
    j[i] = (i + 1) / x[1];
    j[kRatios + i] = -(i + 1) * x[0] / (x[1] * x[1]);
  }
}
void RatiosForward(const double* r, const double* x, double* y) {
  double j[2 * kRatios];
  RatiosJacobians(r, x, y, nullptr, j);
}
const QuantityInfo kRatioInputs[] = {{"x1", "1", "dimensionless", "", 1, 0.01, "normal", 0},
                                     {"x2", "1", "dimensionless", "", 0.001, 0.01, "normal", 0}};
const QuantityInfo kRatioOutputs[kRatios] = {{"y1", "1", "dimensionless", "", 0, 0, "normal", 0},
                                             {"y2", "1", "dimensionless", "", 0, 0, "normal", 0},
                                             {"y3", "1", "dimensionless", "", 0, 0, "normal", 0},
                                             {"y4", "1", "dimensionless", "", 0, 0, "normal", 0},
                                             {"y5", "1", "dimensionless", "", 0, 0, "normal", 0},
                                             {"y6", "1", "dimensionless", "", 0, 0, "normal", 0},
                                             {"y7", "1", "dimensionless", "", 0, 0, "normal", 0},
                                             {"y8", "1", "dimensionless", "", 0, 0, "normal", 0},
                                             {"y9", "1", "dimensionless", "", 0, 0, "normal", 0},
                                             {"y10", "1", "dimensionless", "", 0, 0, "normal", 0},
                                             {"y11", "1", "dimensionless", "", 0, 0, "normal", 0},
                                             {"y12", "1", "dimensionless", "", 0, 0, "normal", 0}};
const ModelInfo kRatios12 = {"ratios_test",
                             "custom",
                             "",
                             "",
                             0,
                             2,
                             kRatios,
                             nullptr,
                             kRatioInputs,
                             kRatioOutputs,
                             &RatiosForward,
                             &RatiosJacobians,
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

TEST(TailIndex, ManyOutputsOnOneThreadAreEstimatedAsOnTwo) {
  UncertainInput x1, x2;
  x1.estimate = 1.0;
  x1.u = 0.01;
  x2.estimate = 0.001;
  x2.u = 0.01;
  const std::vector<UncertainInput> inputs = {x1, x2};
  McmSettings settings;
  settings.trials = 300'000;
  settings.seed = 11;
  settings.quiet = true;
  std::vector<std::optional<double>> reference;
  for (const int threads : {1, 2}) {
    settings.num_threads = threads;
    const McmResult r = RunMcmCustom(kRatios12, inputs, {}, settings);
    ASSERT_EQ(r.outputs.size(), static_cast<std::size_t>(kRatios));
    for (int i = 0; i < kRatios; ++i) {
      const McmOutputResult& o = r.outputs[i];
      ASSERT_TRUE(o.tail_index.has_value()) << threads << " threads, " << o.name;
      EXPECT_NEAR(*o.tail_index, 1.0, 0.2) << o.name;
      EXPECT_TRUE(o.infinite_variance) << threads << " threads, " << o.name;
      if (threads == 1) {
        reference.push_back(o.tail_index);
      } else {
        EXPECT_EQ(*o.tail_index, *reference[i]) << o.name;  // the same bits for any thread count
      }
    }
  }
}

// GUM H.2's model R = V / I cos(phi), X = V / I sin(phi), Z = V / I with u(I) = I: the divisor's
// interval holds 0, the ratios have Cauchy tails (alpha = 1). Adaptive Monte Carlo: each output
// is said to have no finite variance and is not validated, instead of "inconclusive".
TEST(TailIndex, ARatioWhoseDivisorMayBeZeroHasNoFiniteVariance) {
  const std::string text = R"(
[job]
name = "ratio"
[model]
name = "gum_h2_impedance"
[inputs.V]
estimate = 4.999
u = 0.0032
[inputs.I_amp]
estimate = 0.019661
u = 0.02
[inputs.phi]
estimate = 1.04446
u = 0.00075
[monte_carlo]
adaptive = true
seed = 7
)";
  const CustomJob job = ParseCustomJob(text, "ratio.toml", ".");
  RunOptions options;
  options.threads = 2;
  const CustomResults r = RunCustomJob(job, options);
  ASSERT_EQ(r.outputs.size(), 3u);
  for (const CustomOutputResult& o : r.outputs) {
    ASSERT_TRUE(o.has_mcm);
    ASSERT_TRUE(o.mcm.tail_index.has_value()) << o.gum.name;
    EXPECT_NEAR(*o.mcm.tail_index, 1.0, 0.2) << o.gum.name;
    EXPECT_TRUE(o.mcm.infinite_variance) << o.gum.name;
    EXPECT_EQ(o.validation.outcome, "not validated") << o.gum.name;
    EXPECT_NE(o.validation.verdict.find("no finite variance"), std::string::npos) << o.validation.verdict;
  }
}

}  // namespace
}  // namespace vlt
