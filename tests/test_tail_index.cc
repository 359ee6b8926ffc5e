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
std::optional<double> IndexOf(const std::vector<float>& values) {
  mcm_internal::Tails<float> tails;
  mcm_internal::GatherIntervalTails(std::span<const float>(values), kP, 1, &tails);
  mcm_internal::FinishTail(&tails, 0);
  mcm_internal::FinishTail(&tails, 1);
  return mcm_internal::TailIndex(tails, static_cast<std::int64_t>(values.size()), kP);
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
  constexpr std::int64_t m = 1'000'000;  // k = 5000 values per tail: standard error alpha / 70.7
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  const auto cauchy =
      IndexOf(Sample(m, [&](auto& g) { return 250.0 + 3.0 * std::tan(kPi * (u01(g) - 0.5)); }));
  ASSERT_TRUE(cauchy.has_value());
  EXPECT_NEAR(*cauchy, 1.0, 0.08);
  EXPECT_TRUE(mcm_internal::InfiniteVariance(*cauchy, m));
  const auto t15 = IndexOf(Sample(m, [&](auto& g) { return StudentT(g, 1.5); }));
  EXPECT_NEAR(*t15, 1.5, 0.15);
  EXPECT_TRUE(mcm_internal::InfiniteVariance(*t15, m));
  // A finite variance: never flagged.
  const auto t3 = IndexOf(Sample(m, [&](auto& g) { return StudentT(g, 3.0); }));
  EXPECT_GT(*t3, 2.5);
  EXPECT_LT(*t3, 3.6);
  EXPECT_FALSE(mcm_internal::InfiniteVariance(*t3, m));
  std::normal_distribution<double> z(1e3, 1e-3);  // far from 0: measured from the interval's centre
  const auto normal = IndexOf(Sample(m, [&](auto& g) { return z(g); }));
  EXPECT_GT(*normal, 5.0);
  EXPECT_FALSE(mcm_internal::InfiniteVariance(*normal, m));
  const auto uniform = IndexOf(Sample(m, [&](auto& g) { return u01(g); }));
  EXPECT_GT(*uniform, 20.0);  // a bounded tail
  EXPECT_FALSE(mcm_internal::InfiniteVariance(*uniform, m));
}

TEST(TailIndex, NotEstimatedFromTooFewValues) {
  std::normal_distribution<double> z;
  EXPECT_FALSE(IndexOf(Sample(9'999, [&](auto& g) { return z(g); })).has_value());  // k = 49 < 50
  EXPECT_TRUE(IndexOf(Sample(10'000, [&](auto& g) { return z(g); })).has_value());
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
