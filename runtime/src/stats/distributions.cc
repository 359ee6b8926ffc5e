// stats/distributions.cc — the probability distributions of vlt/distributions.h (JCGM 101 6.4).
// Adding a distribution: a DistributionKind, its names in kNames, and a case in every switch.
#include "vlt/distributions.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <string>

#include "stats/log_gamma.h"
#include "vlt/error.h"
#include "vlt/measurement_model.h"

namespace vlt {
namespace {

constexpr double kPi = 3.141592653589793238462643383279502884;

struct NameEntry {
  std::string_view name;
  DistributionKind kind;
};

constexpr NameEntry kNames[] = {
    {"normal", DistributionKind::kNormal},
    {"gaussian", DistributionKind::kNormal},
    {"rectangular", DistributionKind::kRectangular},
    {"uniform", DistributionKind::kRectangular},
    {"triangular", DistributionKind::kTriangular},
    {"arcsine", DistributionKind::kArcsine},
    {"u-shaped", DistributionKind::kArcsine},
    {"u_shaped", DistributionKind::kArcsine},
    {"student_t", DistributionKind::kStudentT},
    {"student-t", DistributionKind::kStudentT},
    {"t", DistributionKind::kStudentT},
    {"curvilinear_trapezoid", DistributionKind::kCurvilinearTrapezoid},
    {"curvilinear-trapezoid", DistributionKind::kCurvilinearTrapezoid},
};

std::string Lower(std::string_view text) {
  std::string out(text);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  // Blanks around the name are not significant.
  const auto first = out.find_first_not_of(" \t");
  const auto last = out.find_last_not_of(" \t");
  return first == std::string::npos ? std::string() : out.substr(first, last - first + 1);
}

// Curvilinear trapezoid CDF of the deviation t from the estimate, half-width w, its
// uncertainty d > 0 (JCGM 101 6.4.3.2: pdf g(t) = ln((w + d) / max(w - d, |t|)) / (4 d) for
// |t| <= w + d). Integral of the pdf from 0 to |t|, derived in docs/monte-carlo.md:
//   |t| <= w - d:        |t| ln((w + d)/(w - d)) / (4 d)
//   w - d < |t| <= w + d: [(w - d) ln((w + d)/(w - d)) + (|t| - (w - d)) ln(w + d)
//                          - (|t| ln|t| - |t|) + ((w - d) ln(w - d) - (w - d))] / (4 d)
double TrapezoidHalfCdf(double t, double w, double d) {
  const double a = std::abs(t);
  const double lo = w - d, hi = w + d;
  if (a >= hi) return 0.5;
  if (a == 0.0) return 0.0;
  auto x_log_x = [](double x) { return x > 0.0 ? x * std::log(x) : 0.0; };
  double integral;
  if (a <= lo) {
    integral = a * std::log(hi / lo);
  } else {
    const double lo_part = lo > 0.0 ? lo * std::log(hi / lo) : 0.0;
    integral = lo_part + (a - lo) * std::log(hi) - (x_log_x(a) - a) + (x_log_x(lo) - lo);
  }
  return std::min(0.5, integral / (4.0 * d));
}

// Inverse of a continuous increasing CDF by bisection on [lo, hi] (bracketing the answer) until
// the bracket no longer shrinks: the result is within a few ulp of the exact quantile.
template <typename Cdf>
double Bisect(const Cdf& cdf, double p, double lo, double hi) {
  for (int i = 0; i < 2000; ++i) {
    const double mid = 0.5 * (lo + hi);
    if (mid <= lo || mid >= hi) break;
    if (cdf(mid) < p) {
      lo = mid;
    } else {
      hi = mid;
    }
  }
  return 0.5 * (lo + hi);
}

}  // namespace

std::string_view DistributionName(DistributionKind kind) {
  switch (kind) {
    case DistributionKind::kNormal: return "normal";
    case DistributionKind::kRectangular: return "rectangular";
    case DistributionKind::kTriangular: return "triangular";
    case DistributionKind::kArcsine: return "arcsine";
    case DistributionKind::kStudentT: return "student_t";
    case DistributionKind::kCurvilinearTrapezoid: return "curvilinear_trapezoid";
  }
  return "unknown";
}

DistributionKind ParseDistribution(std::string_view name, std::string_view where) {
  const std::string key = Lower(name);
  for (const NameEntry& entry : kNames) {
    if (key == entry.name) return entry.kind;
  }
  throw InputError(std::string(where) + ": unknown distribution '" + std::string(name) +
                   "' (expected normal, rectangular/uniform, triangular, arcsine/u-shaped, "
                   "student_t, curvilinear_trapezoid)");
}

bool HasShape(DistributionKind kind) {
  return kind == DistributionKind::kStudentT || kind == DistributionKind::kCurvilinearTrapezoid;
}

Distribution::Distribution(DistributionKind kind, double estimate, double u, double shape,
                           std::string_view where)
    : kind_(kind), estimate_(estimate), u_(u), shape_(HasShape(kind) ? shape : 0.0) {
  const std::string at(where);
  if (!std::isfinite(estimate)) throw InputError(at + ": estimate is not a finite number");
  if (!std::isfinite(u) || u < 0.0) {
    throw InputError(at + ": standard uncertainty must be a finite number >= 0");
  }
  switch (kind) {
    case DistributionKind::kNormal: scale_ = u; break;
    case DistributionKind::kRectangular: scale_ = std::sqrt(3.0) * u; break;  // 6.4.2.3
    case DistributionKind::kTriangular: scale_ = std::sqrt(6.0) * u; break;   // 6.4.5.3
    case DistributionKind::kArcsine: scale_ = std::sqrt(2.0) * u; break;      // 6.4.6.3
    case DistributionKind::kStudentT:
      // 6.4.9.3: Var = s^2 nu / (nu - 2) for nu > 2.
      if (!(shape > 2.0) || !std::isfinite(shape)) {
        throw InputError(at + ": student_t needs degrees of freedom (shape) > 2, got " +
                         std::to_string(shape));
      }
      scale_ = u * std::sqrt((shape - 2.0) / shape);
      break;
    case DistributionKind::kCurvilinearTrapezoid:
      // 6.4.3.3: Var = w^2 / 3 + d^2 / 9 with d = r w.
      if (!(shape >= 0.0 && shape <= 1.0)) {
        throw InputError(at + ": curvilinear_trapezoid needs shape r = d/w in [0, 1], got " +
                         std::to_string(shape));
      }
      scale_ = u / std::sqrt(1.0 / 3.0 + shape * shape / 9.0);
      break;
  }
}

Distribution Distribution::FromInput(const UncertainInput& input, std::string_view where) {
  const std::string at = std::string(where) + ": " + input.name;
  return Distribution(ParseDistribution(input.distribution, at), input.estimate, input.u, input.shape, at);
}

double Distribution::half_width() const {
  switch (kind_) {
    case DistributionKind::kNormal:
    case DistributionKind::kStudentT: return u_ > 0.0 ? std::numeric_limits<double>::infinity() : 0.0;
    case DistributionKind::kCurvilinearTrapezoid: return scale_ * (1.0 + shape_);
    default: return scale_;
  }
}

double Distribution::Cdf(double x) const {
  const double t = x - estimate_;
  if (u_ == 0.0) return t < 0.0 ? 0.0 : 1.0;
  const double a = scale_;
  switch (kind_) {
    case DistributionKind::kNormal: return StandardNormalCdf(t / a);
    case DistributionKind::kRectangular: return std::clamp((t + a) / (2.0 * a), 0.0, 1.0);
    case DistributionKind::kTriangular:
      if (t <= -a) return 0.0;
      if (t >= a) return 1.0;
      if (t < 0.0) return (a + t) * (a + t) / (2.0 * a * a);
      return 1.0 - (a - t) * (a - t) / (2.0 * a * a);
    case DistributionKind::kArcsine:
      if (t <= -a) return 0.0;
      if (t >= a) return 1.0;
      return 0.5 + std::asin(t / a) / kPi;  // 6.4.6.2
    case DistributionKind::kStudentT: return StudentTCdf(t / a, shape_);
    case DistributionKind::kCurvilinearTrapezoid: {
      if (shape_ == 0.0) return std::clamp((t + a) / (2.0 * a), 0.0, 1.0);
      const double half = TrapezoidHalfCdf(t, a, shape_ * a);
      return t < 0.0 ? 0.5 - half : 0.5 + half;
    }
  }
  return 0.0;
}

double Distribution::Quantile(double p) const {
  if (u_ == 0.0) return estimate_;
  const double a = scale_;
  switch (kind_) {
    case DistributionKind::kNormal: return estimate_ + a * StandardNormalQuantile(p);
    case DistributionKind::kRectangular: return estimate_ + a * (2.0 * p - 1.0);
    case DistributionKind::kTriangular:
      if (p < 0.5) return estimate_ - a + a * std::sqrt(2.0 * p);
      return estimate_ + a - a * std::sqrt(2.0 * (1.0 - p));
    case DistributionKind::kArcsine: return estimate_ + a * std::sin(kPi * (p - 0.5));
    case DistributionKind::kStudentT: {
      // Bracket from the normal quantile widened until it contains the answer, then Newton steps
      // on the CDF (pdf known in closed form) kept inside the bracket, bisecting when a step
      // leaves it: ~5 CDF evaluations instead of ~60 for bisection alone.
      const double nu = shape_;
      const double z = StandardNormalQuantile(p);
      double lo = std::min(z, 0.0) * 2.0 - 1.0, hi = std::max(z, 0.0) * 2.0 + 1.0;
      while (StudentTCdf(lo, nu) > p) lo *= 2.0;
      while (StudentTCdf(hi, nu) < p) hi *= 2.0;
      const double log_norm =
          stats_internal::LogGamma(0.5 * (nu + 1.0)) - stats_internal::LogGamma(0.5 * nu) - 0.5 * std::log(nu * kPi);
      double t = std::clamp(z, lo, hi);
      for (int i = 0; i < 200; ++i) {
        const double f = StudentTCdf(t, nu) - p;
        if (f == 0.0) break;
        (f < 0.0 ? lo : hi) = t;
        const double pdf = std::exp(log_norm - 0.5 * (nu + 1.0) * std::log1p(t * t / nu));
        double next = t - f / pdf;
        if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
        if (std::abs(next - t) <= 4.0 * std::numeric_limits<double>::epsilon() * std::abs(t) || next == t) {
          t = next;
          break;
        }
        t = next;
      }
      return estimate_ + a * t;
    }
    case DistributionKind::kCurvilinearTrapezoid: {
      if (shape_ == 0.0) return estimate_ + a * (2.0 * p - 1.0);
      const double limit = a * (1.0 + shape_);
      return estimate_ + Bisect([this](double t) { return Cdf(estimate_ + t); }, p, -limit, limit);
    }
  }
  return estimate_;
}

double Distribution::SampleTwoUniforms(double u1, double u2) const {
  if (kind_ == DistributionKind::kCurvilinearTrapezoid && u_ > 0.0) {
    // JCGM 101 6.4.3.4 with limits mu -+ w, each known to +- d.
    const double d = shape_ * scale_;
    const double lower = estimate_ - scale_ - d + 2.0 * d * u1;
    const double upper = 2.0 * estimate_ - lower;
    return lower + (upper - lower) * u2;
  }
  return Quantile(u1);
}

bool Distribution::SampleBailey(double u1, double u2, double* draw) const {
  const double v1 = 2.0 * u1 - 1.0, v2 = 2.0 * u2 - 1.0;
  const double w = v1 * v1 + v2 * v2;
  if (!(w > 0.0 && w <= 1.0)) return false;
  const double nu = shape_;
  *draw = estimate_ + scale_ * v1 * std::sqrt(nu * (std::pow(w, -2.0 / nu) - 1.0) / w);
  return true;
}

double StandardNormalCdf(double z) { return 0.5 * std::erfc(-z / std::sqrt(2.0)); }

double StandardNormalQuantile(double p) {
  if (!(p > 0.0 && p < 1.0)) {
    if (p == 0.0) return -std::numeric_limits<double>::infinity();
    if (p == 1.0) return std::numeric_limits<double>::infinity();
    return std::numeric_limits<double>::quiet_NaN();
  }
  // Symmetry: work in the lower half, where Phi(x) = erfc(-x / sqrt 2) / 2 is accurate
  // (1 - p is exact for p >= 1/2).
  if (p > 0.5) return -StandardNormalQuantile(1.0 - p);
  // Acklam's rational approximation (relative error < 1.2e-9) as the start ...
  static constexpr double a[] = {-3.969683028665376e+01, 2.209460984245205e+02,  -2.759285104469687e+02,
                                 1.383577518672690e+02,  -3.066479806614716e+01, 2.506628277459239e+00};
  static constexpr double b[] = {-5.447609879822406e+01, 1.615858368580409e+02, -1.556989798598866e+02,
                                 6.680131188771972e+01, -1.328068155288572e+01};
  static constexpr double c[] = {-7.784894002430293e-03, -3.223964580411365e-01, -2.400758277161838e+00,
                                 -2.549732539343734e+00, 4.374664141464968e+00,  2.938163982698783e+00};
  static constexpr double d[] = {7.784695709041462e-03, 3.224671290700398e-01, 2.445134137142996e+00,
                                 3.754408661907416e+00};
  double x;
  if (p < 0.02425) {
    const double q = std::sqrt(-2.0 * std::log(p));
    x = (((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) /
        ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1.0);
  } else {
    const double q = p - 0.5, r = q * q;
    x = (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * q /
        (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1.0);
  }
  // ... refined by Halley steps on Phi(x) - p (cubic convergence: one step reaches ~1e-15).
  for (int i = 0; i < 2; ++i) {
    const double e = StandardNormalCdf(x) - p;
    const double u = e * std::sqrt(2.0 * kPi) * std::exp(0.5 * x * x);
    x -= u / (1.0 + 0.5 * x * u);
  }
  return x;
}

double RegularizedIncompleteBeta(double x, double a, double b) {
  if (x <= 0.0) return 0.0;
  if (x >= 1.0) return 1.0;
  // Continued fraction for I_x(a, b) (Abramowitz & Stegun 26.5.8), convergent for
  // x < (a + 1)/(a + b + 2); otherwise the symmetry I_x(a, b) = 1 - I_{1-x}(b, a).
  if (x > (a + 1.0) / (a + b + 2.0)) return 1.0 - RegularizedIncompleteBeta(1.0 - x, b, a);
  const double log_front = a * std::log(x) + b * std::log1p(-x) + stats_internal::LogGamma(a + b) -
                           stats_internal::LogGamma(a) - stats_internal::LogGamma(b);
  constexpr double kTiny = 1e-300;
  // Modified Lentz evaluation of 1 / (1 + d1 / (1 + d2 / (1 + ...))).
  double c = 1.0;
  double d = 1.0 - (a + b) * x / (a + 1.0);
  if (std::abs(d) < kTiny) d = kTiny;
  d = 1.0 / d;
  double h = d;
  for (int m = 1; m <= 1000; ++m) {
    const double m2 = 2.0 * m;
    double coefficient = m * (b - m) * x / ((a + m2 - 1.0) * (a + m2));  // d_{2m}
    d = 1.0 + coefficient * d;
    if (std::abs(d) < kTiny) d = kTiny;
    c = 1.0 + coefficient / c;
    if (std::abs(c) < kTiny) c = kTiny;
    d = 1.0 / d;
    h *= d * c;
    coefficient = -(a + m) * (a + b + m) * x / ((a + m2) * (a + m2 + 1.0));  // d_{2m+1}
    d = 1.0 + coefficient * d;
    if (std::abs(d) < kTiny) d = kTiny;
    c = 1.0 + coefficient / c;
    if (std::abs(c) < kTiny) c = kTiny;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::abs(delta - 1.0) < 1e-16) break;
  }
  return std::exp(log_front) * h / a;
}

double StudentTCdf(double t, double nu) {
  // P(|T| > |t|) = I_{nu/(nu+t^2)}(nu/2, 1/2).
  const double tail = 0.5 * RegularizedIncompleteBeta(nu / (nu + t * t), 0.5 * nu, 0.5);
  return t > 0.0 ? 1.0 - tail : tail;
}

}  // namespace vlt
