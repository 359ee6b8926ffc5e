// base/lanes.h — the SIMD lane type of the generated Monte Carlo kernel: its arithmetic is the
// scalar arithmetic lane by lane, its sin/cos within a few ulp of the exact values (long double).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "base/lanes.h"

namespace vlt {
namespace {

using base_internal::lanes::Double4;

TEST(Lanes, ArithmeticIsTheScalarArithmeticLaneByLane) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> value(-100.0, 100.0);
  for (int i = 0; i < 10000; ++i) {
    double a[4], b[4];
    for (int l = 0; l < 4; ++l) a[l] = value(rng), b[l] = value(rng);
    const Double4 x = base_internal::lanes::Load(a), y = base_internal::lanes::Load(b);
    const Double4 sum = x + y, diff = x - y, prod = x * y, quot = x / y, neg = -x, root = base_internal::lanes::sqrt(x * x),
                  mixed = 0.5 * x + 1.0;
    for (int l = 0; l < 4; ++l) {
      ASSERT_EQ(sum[l], a[l] + b[l]);
      ASSERT_EQ(diff[l], a[l] - b[l]);
      ASSERT_EQ(prod[l], a[l] * b[l]);
      ASSERT_EQ(quot[l], a[l] / b[l]);
      ASSERT_EQ(neg[l], -a[l]);
      ASSERT_EQ(root[l], std::sqrt(a[l] * a[l]));
      ASSERT_EQ(mixed[l], 0.5 * a[l] + 1.0);
    }
    double back[4];
    base_internal::lanes::Store(back, x);
    for (int l = 0; l < 4; ++l) ASSERT_EQ(back[l], a[l]);
  }
}

// Error of got against the exact value in units in the last place of the exact value.
double Ulps(double got, long double exact) {
  const double e = std::fabs(static_cast<double>(exact));
  const double ulp = std::nextafter(e, std::numeric_limits<double>::infinity()) - e;
  return static_cast<double>(std::fabs(got - exact)) / ulp;
}

TEST(Lanes, SinCosWithinAFewUlpOfLongDouble) {
  // Arguments: angles of a tracker model (|x| <= 10), small parameter angles, the whole
  // reduced range (|x| <= 2^19), and the doubles next to multiples of pi/2 (where sin or cos
  // vanish: there the error is bounded absolutely). Measured 2026-11-25: 2.38 ulp and
  // 1.05e-22 absolute at worst; libm's sin on the same machine: 0.52 ulp.
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> angle(-10.0, 10.0), small(-1e-3, 1e-3), wide(-4e5, 4e5);
  double worst_ulps = 0.0, worst_near_zero = 0.0;
  auto check = [&](double x) {
    Double4 s, c;
    base_internal::lanes::SinCos(Double4(x), &s, &c);
    const long double exact[2] = {std::sin(static_cast<long double>(x)),
                                  std::cos(static_cast<long double>(x))};
    const double got[2] = {s[0], c[0]};
    for (int w = 0; w < 2; ++w) {
      if (std::fabs(static_cast<double>(exact[w])) > 1e-6) {
        worst_ulps = std::max(worst_ulps, Ulps(got[w], exact[w]));
      } else {
        worst_near_zero = std::max(worst_near_zero, static_cast<double>(std::fabs(got[w] - exact[w])));
      }
    }
  };
  for (int i = 0; i < 300000; ++i) {
    check(angle(rng));
    check(small(rng));
    check(wide(rng));
  }
  for (int k = -2000; k <= 2000; ++k) {
    double x = k * 1.5707963267948966;
    for (int step = 0; step < 4; ++step) {
      check(x);
      x = std::nextafter(x, 1e300);
    }
  }
  EXPECT_LT(worst_ulps, 3.0);
  EXPECT_LT(worst_near_zero, 2e-22);
  EXPECT_GT(worst_ulps, 0.0);
}

// Up to kSmallAngle (2^-10 rad: a tracker's error angles) sin and cos are the short series of
// base/portable_math.h SinCosSmall: each within half an ulp of the exact value, i.e. the value
// rounded (but where that lies within about 2^-70 of a rounding boundary; 10^-4 ulp allowed for
// long double's own error), over uniform angles, every binade from 2^-1074 up, and the
// boundary's neighbours. Measured 2026-11-28: 0.5 ulp + < 10^-6 at worst over 8.9 10^5 values.
// (Rounding the long double to double is no reference here: it rounds twice, wrongly where the
// long double lies on a double's tie — a few hundred of these values.)
TEST(Lanes, SmallAnglesAreTheRoundedValue) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> small(-base_internal::portable::kSmallAngle, base_internal::portable::kSmallAngle),
      unit(1.0, 2.0);
  std::vector<double> xs;
  for (int i = 0; i < 400000; ++i) xs.push_back(small(rng));
  for (int e = -1074; e <= -11; ++e) {
    for (int i = 0; i < 40; ++i) xs.push_back((i % 2 != 0 ? -1.0 : 1.0) * std::ldexp(unit(rng), e));
  }
  double x = base_internal::portable::kSmallAngle;
  for (int step = 0; step < 8; ++step, x = std::nextafter(x, 0.0)) xs.push_back(x), xs.push_back(-x);
  double worst = 0.0;
  for (const double v : xs) {
    Double4 s, c;
    base_internal::lanes::SinCos(Double4(v), &s, &c);
    const long double exact[2] = {std::sin(static_cast<long double>(v)), std::cos(static_cast<long double>(v))};
    const double got[2] = {s[0], c[0]};
    for (int w = 0; w < 2; ++w) {
      if (exact[w] == 0.0L) continue;
      worst = std::max(worst, Ulps(got[w], exact[w]));
    }
  }
  EXPECT_LE(worst, 0.5 + 1e-4);
  EXPECT_GT(worst, 0.25);
}

TEST(Lanes, SinCosBeyondTheReducedRangeIsLibm) {
  const double xs[4] = {0x1.0p19 * 1.5, -1e10, std::numeric_limits<double>::infinity(),
                        std::numeric_limits<double>::quiet_NaN()};
  Double4 s, c;
  base_internal::lanes::SinCos(base_internal::lanes::Load(xs), &s, &c);
  for (int l = 0; l < 2; ++l) {
    EXPECT_EQ(s[l], std::sin(xs[l]));
    EXPECT_EQ(c[l], std::cos(xs[l]));
  }
  for (int l = 2; l < 4; ++l) {
    EXPECT_TRUE(std::isnan(s[l]));
    EXPECT_TRUE(std::isnan(c[l]));
  }
  // A lane in range next to one outside is unaffected by it.
  const double mixed[4] = {0.5, 1e10, -2.0, 3.0};
  base_internal::lanes::SinCos(base_internal::lanes::Load(mixed), &s, &c);
  Double4 s1, c1;
  base_internal::lanes::SinCos(Double4(0.5), &s1, &c1);
  EXPECT_EQ(s[0], s1[0]);
  EXPECT_EQ(c[0], c1[0]);
  EXPECT_EQ(s[1], std::sin(1e10));
}

}  // namespace
}  // namespace vlt
