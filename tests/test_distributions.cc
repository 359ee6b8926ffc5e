// Distributions of the Monte Carlo engine (vlt/distributions.h): names, parameter checks, CDFs
// against closed forms, quantiles against published values, and the engine's sampling path
// (keyed Philox streams, exact transforms) against each distribution's own CDF by a
// Kolmogorov-Smirnov test, plus sample mean and standard deviation.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <ios>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include <Random123/philox.h>

#include "mcm/engine.h"
#include "mcm/random.h"
#include "vlt/distributions.h"
#include "vlt/error.h"

namespace vlt {
namespace {

constexpr double kPi = 3.141592653589793238462643383279502884;

TEST(DistributionNames, ParsesEveryAcceptedSpelling) {
  EXPECT_EQ(ParseDistribution("normal", "t"), DistributionKind::kNormal);
  EXPECT_EQ(ParseDistribution("Rectangular", "t"), DistributionKind::kRectangular);
  EXPECT_EQ(ParseDistribution("uniform", "t"), DistributionKind::kRectangular);
  EXPECT_EQ(ParseDistribution("triangular", "t"), DistributionKind::kTriangular);
  EXPECT_EQ(ParseDistribution("arcsine", "t"), DistributionKind::kArcsine);
  EXPECT_EQ(ParseDistribution("u-shaped", "t"), DistributionKind::kArcsine);
  EXPECT_EQ(ParseDistribution("student_t", "t"), DistributionKind::kStudentT);
  EXPECT_EQ(ParseDistribution("curvilinear_trapezoid", "t"), DistributionKind::kCurvilinearTrapezoid);
  for (DistributionKind kind :
       {DistributionKind::kNormal, DistributionKind::kRectangular, DistributionKind::kTriangular,
        DistributionKind::kArcsine, DistributionKind::kStudentT, DistributionKind::kCurvilinearTrapezoid}) {
    EXPECT_EQ(ParseDistribution(DistributionName(kind), "t"), kind);
  }
}

TEST(DistributionNames, UnknownNameIsInputErrorNamingWhere) {
  try {
    ParseDistribution("lognormal", "job.toml: tracker.params.tmv");
    FAIL() << "no exception";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("job.toml: tracker.params.tmv"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("lognormal"), std::string::npos);
  }
}

TEST(DistributionParameters, InvalidShapesAndUncertaintiesAreInputErrors) {
  EXPECT_THROW(Distribution(DistributionKind::kStudentT, 0, 1, 2.0), InputError);
  EXPECT_THROW(Distribution(DistributionKind::kStudentT, 0, 1, 0.0), InputError);
  EXPECT_THROW(Distribution(DistributionKind::kCurvilinearTrapezoid, 0, 1, 1.5), InputError);
  EXPECT_THROW(Distribution(DistributionKind::kCurvilinearTrapezoid, 0, 1, -0.1), InputError);
  EXPECT_THROW(Distribution(DistributionKind::kNormal, 0, -1), InputError);
  EXPECT_THROW(Distribution(DistributionKind::kNormal, NAN, 1), InputError);
  EXPECT_NO_THROW(Distribution(DistributionKind::kStudentT, 0, 1, 2.5));
}

TEST(DistributionCdf, ArcsineAnalytic) {
  // JCGM 101 6.4.6: a = sqrt(2) u; F(mu + a sin(theta)) = 1/2 + theta/pi.
  const Distribution d(DistributionKind::kArcsine, 5.0, 0.2);
  const double a = std::sqrt(2.0) * 0.2;
  EXPECT_NEAR(d.Cdf(5.0 + a * 0.5), 2.0 / 3.0, 1e-15);        // theta = pi/6
  EXPECT_NEAR(d.Cdf(5.0 - a / std::sqrt(2.0)), 0.25, 1e-15);  // theta = -pi/4
  EXPECT_EQ(d.Cdf(5.0 - a), 0.0);
  EXPECT_EQ(d.Cdf(5.0 + a * 1.0001), 1.0);
  // Variance from the CDF: Var = int 2 |t| (tail probability) dt, trapezoidal rule.
  double var = 0.0;
  const int n = 200000;
  for (int i = 0; i < n; ++i) {
    const double t = (i + 0.5) * a / n;
    var += 2.0 * t * (1.0 - d.Cdf(5.0 + t) + d.Cdf(5.0 - t)) * (a / n);
  }
  EXPECT_NEAR(std::sqrt(var), 0.2, 1e-5);
}

TEST(DistributionCdf, TriangularAndRectangularAnalytic) {
  const Distribution tri(DistributionKind::kTriangular, 1.0, 1.0 / std::sqrt(6.0));  // a = 1
  EXPECT_NEAR(tri.Cdf(0.5), 0.125, 1e-15);
  EXPECT_NEAR(tri.Cdf(1.5), 0.875, 1e-15);
  const Distribution rect(DistributionKind::kRectangular, 0.0, 1.0);  // a = sqrt(3)
  EXPECT_NEAR(rect.Cdf(std::sqrt(3.0) / 2.0), 0.75, 1e-15);
}

TEST(DistributionCdf, StudentTClosedForms) {
  for (double t : {-7.0, -2.0, -0.3, 0.0, 0.4, 1.0, 3.0, 12.0}) {
    // nu = 1 (Cauchy), 2 and 3: elementary closed forms.
    EXPECT_NEAR(StudentTCdf(t, 1.0), 0.5 + std::atan(t) / kPi, 1e-14) << t;
    EXPECT_NEAR(StudentTCdf(t, 2.0), 0.5 + t / (2.0 * std::sqrt(2.0 + t * t)), 1e-14) << t;
    const double s3 = std::sqrt(3.0);
    EXPECT_NEAR(StudentTCdf(t, 3.0), 0.5 + (t / (s3 * (1.0 + t * t / 3.0)) + std::atan(t / s3)) / kPi, 1e-14)
        << t;
  }
  // Published quantile: t_0.975(10) = 2.228138852 (JCGM 100 Table G.2: 2.23).
  EXPECT_NEAR(StudentTCdf(2.228138851986, 10.0), 0.975, 1e-12);
}

TEST(DistributionCdf, CurvilinearTrapezoidAgainstIntegratedPdf) {
  // JCGM 101 6.4.3.2 pdf g(t) = ln((w + d) / max(w - d, |t|)) / (4 d), integrated numerically.
  const double u = 0.7, r = 0.4;
  const Distribution d(DistributionKind::kCurvilinearTrapezoid, 2.0, u, r);
  const double w = u / std::sqrt(1.0 / 3.0 + r * r / 9.0), dd = r * w;
  EXPECT_NEAR(d.half_width(), w + dd, 1e-15);
  auto pdf = [&](double t) { return std::log((w + dd) / std::max(w - dd, std::abs(t))) / (4 * dd); };
  const int n = 400000;
  double cdf = 0.0, var = 0.0;
  const double lo = -(w + dd), h = 2 * (w + dd) / n;
  for (int i = 0; i < n; ++i) {
    const double t = lo + (i + 0.5) * h;
    cdf += pdf(t) * h;
    var += t * t * pdf(t) * h;
    if (i % 40000 == 39999) {
      EXPECT_NEAR(d.Cdf(2.0 + lo + (i + 1) * h), cdf, 2e-6) << i;
    }
  }
  EXPECT_NEAR(cdf, 1.0, 1e-6);
  EXPECT_NEAR(std::sqrt(var), u, 1e-5);  // 6.4.3.3: Var = w^2/3 + d^2/9
}

TEST(DistributionQuantile, NormalPublishedValues) {
  EXPECT_NEAR(StandardNormalQuantile(0.975), 1.959963984540054, 1e-14);
  EXPECT_NEAR(StandardNormalQuantile(0.995), 2.575829303548901, 1e-14);
  EXPECT_NEAR(StandardNormalQuantile(0.5), 0.0, 1e-16);
  EXPECT_NEAR(StandardNormalQuantile(1e-10), -6.361340902404056, 1e-12);
  EXPECT_NEAR(StandardNormalQuantile(0.0227501319481792), -2.0, 1e-13);
}

TEST(DistributionQuantile, InvertsTheCdfForEveryKind) {
  const Distribution all[] = {
      Distribution(DistributionKind::kNormal, 1.0, 0.5),
      Distribution(DistributionKind::kRectangular, 1.0, 0.5),
      Distribution(DistributionKind::kTriangular, 1.0, 0.5),
      Distribution(DistributionKind::kArcsine, 1.0, 0.5),
      Distribution(DistributionKind::kStudentT, 1.0, 0.5, 3.5),
      Distribution(DistributionKind::kCurvilinearTrapezoid, 1.0, 0.5, 0.3),
      Distribution(DistributionKind::kCurvilinearTrapezoid, 1.0, 0.5, 1.0),
  };
  for (const Distribution& d : all) {
    for (double p : {1e-6, 0.01, 0.2, 0.5, 0.77, 0.975, 0.999999}) {
      // The arcsine CDF has an infinite slope at the ends of its support: one ulp of x there is
      // ~1e-11 of probability.
      const double tolerance = d.kind() == DistributionKind::kArcsine ? 1e-10 : 1e-12;
      EXPECT_NEAR(d.Cdf(d.Quantile(p)), p, tolerance) << DistributionName(d.kind()) << " p=" << p;
    }
  }
}

// Draws n values with the engine's sampler (input 0 of a keyed stream) and checks mean,
// standard deviation and the Kolmogorov-Smirnov distance to the distribution's own CDF.
void CheckSampling(const Distribution& d, double kurtosis) {
  const int n = 200000;
  const mcm_internal::InputSampler sampler({d}, {"x"}, Eigen::MatrixXd(), 7, "test");
  const mcm_internal::KeyedStream rng(12345);
  std::vector<double> x(n);
  // Odd offsets and lengths exercise the groups of 4 trials sharing one Philox call.
  for (int first = 0; first < n;) {
    const int len = std::min(n - first, 253);
    sampler.Draw(rng, 3 + first, len, x.data() + first, len, nullptr);
    first += len;
  }
  double mean = 0.0;
  for (double v : x) mean += v;
  mean /= n;
  double var = 0.0;
  for (double v : x) var += (v - mean) * (v - mean);
  const double sd = std::sqrt(var / (n - 1));
  const std::string name(DistributionName(d.kind()));
  // 5 standard errors: of the mean u / sqrt(n), of the standard deviation
  // u sqrt((kurtosis - 1) / (4 n)).
  EXPECT_NEAR(mean, d.estimate(), 5.0 * d.u() / std::sqrt(n)) << name;
  EXPECT_NEAR(sd, d.u(), 5.0 * d.u() * std::sqrt((kurtosis - 1.0) / (4.0 * n))) << name;
  std::sort(x.begin(), x.end());
  double ks = 0.0;
  for (int i = 0; i < n; ++i) {
    const double f = d.Cdf(x[i]);
    ks = std::max({ks, f - static_cast<double>(i) / n, static_cast<double>(i + 1) / n - f});
  }
  // Kolmogorov critical value at significance 0.001: 1.949 / sqrt(n).
  EXPECT_LT(ks, 1.949 / std::sqrt(n)) << name;
  // A wrong width by 2 % would be detected: the same sample against a wider distribution.
  const Distribution wider(d.kind(), d.estimate(), d.u() * 1.02, d.shape());
  double ks_wider = 0.0;
  for (int i = 0; i < n; ++i) {
    const double f = wider.Cdf(x[i]);
    ks_wider = std::max({ks_wider, f - static_cast<double>(i) / n, static_cast<double>(i + 1) / n - f});
  }
  EXPECT_GT(ks_wider, 1.949 / std::sqrt(n)) << name;
}

TEST(DistributionSampling, Normal) { CheckSampling(Distribution(DistributionKind::kNormal, 3.0, 2.0), 3.0); }
TEST(DistributionSampling, Rectangular) {
  CheckSampling(Distribution(DistributionKind::kRectangular, -1.0, 0.5), 1.8);
}
TEST(DistributionSampling, Triangular) {
  CheckSampling(Distribution(DistributionKind::kTriangular, 0.0, 1e-6), 2.4);
}
TEST(DistributionSampling, Arcsine) {
  CheckSampling(Distribution(DistributionKind::kArcsine, 10.0, 0.1), 1.5);
}
TEST(DistributionSampling, StudentT) {
  // nu = 8: kurtosis 3 + 6 / (nu - 4) = 4.5.
  CheckSampling(Distribution(DistributionKind::kStudentT, 0.0, 1.0, 8.0), 4.5);
}
TEST(DistributionSampling, CurvilinearTrapezoid) {
  // Kurtosis of the curvilinear trapezoid with r = 0.5 is below 2; 2.2 is a safe bound.
  CheckSampling(Distribution(DistributionKind::kCurvilinearTrapezoid, 1.0, 0.3, 0.5), 2.2);
}

TEST(RandomStreams, SinCosTwoPiMatchesLongDouble) {
  // The Box-Muller transform's own sin/cos of 2 pi u (random.h) against long double libm.
  const long double two_pi = 6.283185307179586476925286766559005768L;
  double worst = 0.0;
  std::vector<double> us = {0.0,       0.125, 0.25,  0.375, 0.5,
                            0.625,     0.75,  0.875, 1.0,   std::nextafter(1.0, 0.0),
                            0x1.0p-53, 0.1,   0.3,   0.7};
  for (std::uint64_t i = 0; i < 200000; ++i) {
    us.push_back(mcm_internal::KeyedStream::ToOpenUnit(i * 0x9E3779B97F4A7C15ull));
  }
  for (double u : us) {
    double s, c;
    mcm_internal::KeyedStream::SinCosTwoPi(u, &s, &c);
    worst = std::max(worst, static_cast<double>(std::fabs(s - std::sin(two_pi * u))));
    worst = std::max(worst, static_cast<double>(std::fabs(c - std::cos(two_pi * u))));
  }
  EXPECT_LT(worst, 3e-16);
}

TEST(RandomStreams, UniformsAreOpenAndDependOnlyOnTheirKey) {
  EXPECT_EQ(mcm_internal::KeyedStream::ToOpenUnit(0), 0x1.0p-53);
  EXPECT_EQ(mcm_internal::KeyedStream::ToOpenUnit(~0ull), 1.0 - 0x1.0p-53);
  EXPECT_LT(mcm_internal::KeyedStream::ToOpenUnit(~0ull), 1.0);
  const mcm_internal::KeyedStream a(5), b(5), c(6);
  double x[4], y[4], z[4];
  a.Uniforms(10, 3, 0, x);
  b.Uniforms(10, 3, 0, y);
  c.Uniforms(10, 3, 0, z);
  for (int j = 0; j < 4; ++j) {
    EXPECT_EQ(x[j], y[j]);
    EXPECT_NE(x[j], z[j]);
    EXPECT_GT(x[j], 0.0);
    EXPECT_LT(x[j], 1.0);
  }
  b.Uniforms(10, 4, 0, y);  // another input
  EXPECT_NE(x[0], y[0]);
}

TEST(DistributionSampling, ZeroUncertaintyIsTheEstimate) {
  const mcm_internal::InputSampler sampler({Distribution(DistributionKind::kStudentT, 4.0, 0.0, 5.0)}, {"x"},
                                           Eigen::MatrixXd(), 0, "test");
  const mcm_internal::KeyedStream rng(1);
  double x[10];
  sampler.Draw(rng, 0, 10, x, 10, nullptr);
  for (double v : x) EXPECT_EQ(v, 4.0);
}

TEST(DistributionSampling, GaussianCopulaGivesTheCorrelationAndKeepsMarginals) {
  // Two normals with correlation 0.8 and a rectangular correlated with the first (rank
  // correlation of a Gaussian copula; the Pearson correlation of normal with rectangular through
  // the copula is 0.6 * sqrt(3/pi) = 0.5863).
  Eigen::Matrix3d r;
  r << 1.0, 0.8, 0.6, 0.8, 1.0, 0.48, 0.6, 0.48, 1.0;
  const mcm_internal::InputSampler sampler(
      {Distribution(DistributionKind::kNormal, 0, 1), Distribution(DistributionKind::kNormal, 5, 2),
       Distribution(DistributionKind::kRectangular, 0, 1)},
      {"a", "b", "c"}, r, 0, "test");
  const int n = 100000;
  std::vector<double> x(3 * n), scratch(sampler.scratch_size(n));
  sampler.Draw(mcm_internal::KeyedStream(99), 0, n, x.data(), n, scratch.data());
  auto corr = [&](int a, int b) {
    double ma = 0, mb = 0;
    for (int i = 0; i < n; ++i) ma += x[a * n + i], mb += x[b * n + i];
    ma /= n, mb /= n;
    double sab = 0, saa = 0, sbb = 0;
    for (int i = 0; i < n; ++i) {
      const double da = x[a * n + i] - ma, db = x[b * n + i] - mb;
      sab += da * db, saa += da * da, sbb += db * db;
    }
    return sab / std::sqrt(saa * sbb);
  };
  EXPECT_NEAR(corr(0, 1), 0.8, 0.005);
  EXPECT_NEAR(corr(0, 2), 0.6 * std::sqrt(3.0 / kPi), 0.008);
  // Marginal of the rectangular input still rectangular with half-width sqrt(3).
  double lo = 1e9, hi = -1e9;
  for (int i = 0; i < n; ++i) lo = std::min(lo, x[2 * n + i]), hi = std::max(hi, x[2 * n + i]);
  EXPECT_GE(lo, -std::sqrt(3.0));
  EXPECT_LE(hi, std::sqrt(3.0));
  EXPECT_NEAR(hi - lo, 2 * std::sqrt(3.0), 0.01);
}

TEST(DistributionSampling, NotPositiveDefiniteCorrelationNamesTheInputs) {
  Eigen::Matrix3d r;
  r << 1.0, 0.9, -0.9, 0.9, 1.0, 0.9, -0.9, 0.9, 1.0;
  try {
    mcm_internal::InputSampler sampler(
        {Distribution(DistributionKind::kNormal, 0, 1), Distribution(DistributionKind::kNormal, 0, 1),
         Distribution(DistributionKind::kNormal, 0, 1)},
        {"tmv", "rmv", "tbw"}, r, 0, "job.toml: tracker.correlation");
    FAIL() << "no exception";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("job.toml: tracker.correlation"), std::string::npos) << what;
    EXPECT_NE(what.find("'tmv', 'rmv', 'tbw'"), std::string::npos) << what;
    EXPECT_NE(what.find("not positive semi-definite"), std::string::npos) << what;
  }
}

TEST(DistributionSampling, SingularCorrelationOfOneGivesIdenticalDrawsAndMinusOneOpposite) {
  // JCGM 101 6.4.8.1 allows a positive semi-definite correlation matrix: r = +1 makes two
  // standardised inputs equal in every trial, r = -1 opposite (closed form of the copula).
  Eigen::Matrix3d r;
  r << 1.0, 1.0, -1.0, 1.0, 1.0, -1.0, -1.0, -1.0, 1.0;
  const mcm_internal::InputSampler sampler(
      {Distribution(DistributionKind::kNormal, 1.0, 2.0), Distribution(DistributionKind::kNormal, 5.0, 2.0),
       Distribution(DistributionKind::kRectangular, 0.0, 1.0)},
      {"a", "b", "c"}, r, 0, "test");
  const mcm_internal::KeyedStream rng(99);
  constexpr int n = 64;
  std::vector<double> out(3 * n), scratch(sampler.scratch_size(n));
  sampler.Draw(rng, 0, n, out.data(), n, scratch.data());  // out[k * n + i]: input k, trial i
  double spread = 0.0;
  for (int i = 0; i < n; ++i) {
    const double a = out[i], b = out[n + i], c = out[2 * n + i];
    EXPECT_NEAR((a - 1.0) / 2.0, (b - 5.0) / 2.0, 1e-12) << i;
    spread = std::max(spread, std::abs(a - 1.0));
    // c is rectangular with u = 1 (half-width sqrt 3): its normal score is minus that of a.
    const double z_a = (a - 1.0) / 2.0;
    EXPECT_NEAR(c, -std::sqrt(3.0) * (std::erfc(-z_a / std::sqrt(2.0)) - 1.0), 1e-9) << i;
  }
  EXPECT_GT(spread, 1.0);  // the draws do vary
}

TEST(RandomStreams, BulkNormalsAreTheNormalsOfEachGroupBitForBit) {
  // KeyedStream::NormalsBulk and DrawNormals (the engine's paths) against the per-group
  // Normals, including sub-batch edges that start and end inside a group of 4 trials.
  const mcm_internal::KeyedStream rng(20260101);
  constexpr int kGroups = mcm_internal::KeyedStream::kBulkGroups;
  double bulk[4 * kGroups];
  for (std::uint64_t first_group : {0ull, 1ull, 12345ull, (1ull << 40) + 7}) {
    for (int groups : {1, 3, kGroups}) {
      rng.NormalsBulk(first_group, groups, 9, bulk);
      for (int g = 0; g < groups; ++g) {
        double z[4];
        rng.Normals(first_group + static_cast<std::uint64_t>(g), 9, z);
        for (int j = 0; j < 4; ++j) ASSERT_EQ(bulk[4 * g + j], z[j]) << first_group << " " << g;
      }
    }
  }
  for (const auto& [first, n] :
       std::vector<std::pair<std::int64_t, int>>{{0, 256}, {3, 1}, {5, 517}, {4093, 7}, {1'000'001, 300}}) {
    std::vector<double> out(static_cast<std::size_t>(n));
    mcm_internal::DrawNormals(rng, 4, first, n, out.data());
    for (int i = 0; i < n; ++i) {
      const std::int64_t trial = first + i;
      double z[4];
      rng.Normals(static_cast<std::uint64_t>(trial / 4), 4, z);
      ASSERT_EQ(out[i], z[trial % 4]) << "trial " << trial;
    }
  }
}

TEST(RandomStreams, EveryPhiloxImplementationIsRandom123) {
  // The words of Philox4x32-10 from the portable loop and the SIMD lanes (those this machine
  // runs) against Random123's r123::Philox4x32, including a pair index whose low word wraps
  // inside one register of lanes, and input indices above 2^32.
  using mcm_internal::PhiloxImplementation;
  const r123::Philox4x32::key_type key = {{0x89ABCDEFu, 0x01234567u}};
  int compared = 0;
  for (PhiloxImplementation which : {PhiloxImplementation::kPortable, PhiloxImplementation::kSse2,
                                     PhiloxImplementation::kAvx2, PhiloxImplementation::kAvx512}) {
    if (!mcm_internal::PhiloxImplementationRuns(which)) continue;
    for (std::uint64_t first_pair : {0ull, 77ull, 0xFFFFFFF9ull, (1ull << 45) + 3}) {
      for (int pairs : {1, 17, 128}) {
        for (std::uint64_t input : {0ull, 5ull, (1ull << 40) + 9}) {
          std::vector<std::uint32_t> words(4 * static_cast<std::size_t>(pairs));
          mcm_internal::PhiloxWordsForTest(which, key[0], key[1], first_pair, pairs, input, words.data());
          for (int p = 0; p < pairs; ++p) {
            const std::uint64_t pair = first_pair + static_cast<std::uint64_t>(p);
            const r123::Philox4x32::ctr_type ctr = {
                {static_cast<std::uint32_t>(pair), static_cast<std::uint32_t>(pair >> 32),
                 static_cast<std::uint32_t>(input), static_cast<std::uint32_t>(input >> 32)}};
            const r123::Philox4x32::ctr_type expected = r123::Philox4x32()(ctr, key);
            for (int j = 0; j < 4; ++j) {
              ASSERT_EQ(words[4 * static_cast<std::size_t>(p) + j], expected[j])
                  << static_cast<int>(which) << " pair " << pair << " input " << input;
            }
          }
        }
      }
    }
    ++compared;
  }
  EXPECT_GE(compared, 1);
}

TEST(RandomStreams, LogOpenUnitWithinOneUlpOfLongDouble) {
  // random.h's ln against long double libm on the uniforms the stream produces and on the
  // edges of its range reduction (powers of two, both sides of sqrt(2)).
  double worst = 0.0;
  auto check = [&worst](double u) {
    const long double exact = std::log(static_cast<long double>(u));
    const double got = mcm_internal::KeyedStream::LogOpenUnit(u);
    const double ulp =
        std::nextafter(std::fabs(static_cast<double>(exact)), 1e300) - std::fabs(static_cast<double>(exact));
    worst = std::max(worst, static_cast<double>(std::fabs(got - exact)) / ulp);
  };
  for (std::uint64_t i = 0; i < 2'000'000; ++i) {
    check(mcm_internal::KeyedStream::ToOpenUnit(i * 0x9E3779B97F4A7C15ull));
  }
  for (int e = -53; e < 0; ++e) {
    for (double m : {1.0, std::nextafter(1.0, 2.0), std::sqrt(2.0), std::nextafter(std::sqrt(2.0), 0.0),
                     std::nextafter(std::sqrt(2.0), 2.0), std::nextafter(2.0, 0.0)}) {
      check(std::ldexp(m, e));
    }
  }
  check(1.0 - 0x1.0p-53);
  EXPECT_LT(worst, 1.0);
  EXPECT_EQ(mcm_internal::KeyedStream::LogOpenUnit(0.5), -std::log(2.0));
}

TEST(RandomStreams, NormalsAreBoxMullerOfTheirPhiloxWords) {
  // An independent evaluation of the stream's definition (random.h) in long double from
  // Random123's words, then the first normals of one seed pinned bit for bit: a change of the
  // stream (and so of every Monte Carlo result for a given seed) must be deliberate.
  const std::uint64_t seed = 0x0123456789ABCDEFull;
  const mcm_internal::KeyedStream rng(seed);
  const r123::Philox4x32::key_type key = {
      {static_cast<std::uint32_t>(seed), static_cast<std::uint32_t>(seed >> 32)}};
  const long double two_pi = 6.283185307179586476925286766559005768L;
  for (std::uint64_t group : {0ull, 1ull, 999ull, (1ull << 33) + 5}) {
    double z[4];
    rng.Normals(group, 11, z);
    for (int half = 0; half < 2; ++half) {
      const std::uint64_t pair = 2 * group + static_cast<std::uint64_t>(half);
      const r123::Philox4x32::ctr_type w = r123::Philox4x32()(
          {{static_cast<std::uint32_t>(pair), static_cast<std::uint32_t>(pair >> 32), 11u, 0u}}, key);
      auto unit = [](std::uint32_t hi, std::uint32_t lo) {
        return (static_cast<long double>((((static_cast<std::uint64_t>(hi) << 32) | lo) >> 12)) + 0.5L) *
               0x1.0p-52L;
      };
      const long double r = std::sqrt(-2.0L * std::log(unit(w[0], w[1])));
      const long double angle = two_pi * unit(w[2], w[3]);
      EXPECT_NEAR(z[2 * half], static_cast<double>(r * std::cos(angle)),
                  4e-15 * (1.0 + std::fabs(z[2 * half])));
      EXPECT_NEAR(z[2 * half + 1], static_cast<double>(r * std::sin(angle)),
                  4e-15 * (1.0 + std::fabs(z[2 * half + 1])));
    }
  }
  double first[4];
  rng.Normals(0, 0, first);
  const double pinned[4] = {0x1.6ad54d12cffc1p-1, 0x1.9300836837bf5p-2, -0x1.64f47fe6bb003p-1,
                            0x1.130f09ec5860cp-1};
  for (int j = 0; j < 4; ++j) EXPECT_EQ(first[j], pinned[j]) << j << ": " << std::hexfloat << first[j];
}

TEST(RandomStreams, NormalTailsBeyondFourSigma) {
  // Frequency of |z| > 4 among 4e6 draws against 2 Phi(-4) = 6.3342e-5 (expected count 253.4),
  // within 5 binomial standard errors (sqrt(N p (1 - p)) = 15.9): an approximate normal
  // generator (sums of uniforms, clipped tails) fails this.
  const mcm_internal::KeyedStream rng(7);
  constexpr int kN = 4'000'000;
  constexpr int kBlock = 4096;
  std::vector<double> z(kBlock);
  std::int64_t beyond = 0;
  for (std::int64_t first = 0; first < kN; first += kBlock) {
    mcm_internal::DrawNormals(rng, 0, first, kBlock, z.data());
    for (double v : z) beyond += std::fabs(v) > 4.0 ? 1 : 0;
  }
  const double p = 2.0 * 0.5 * std::erfc(4.0 / std::sqrt(2.0));
  const double expected = kN * p;
  const double se = std::sqrt(kN * p * (1.0 - p));
  EXPECT_NEAR(static_cast<double>(beyond), expected, 5.0 * se);
}
}  // namespace
}  // namespace vlt
