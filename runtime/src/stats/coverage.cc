// stats/coverage.cc — coverage factors (vlt/gum.h; computed, JCGM 100 G.1.3, JCGM 102 6.5.2.3), the
// chi-square cdf and the Welch-Satterthwaite formula (JCGM 100 G.4.1).
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <vector>

#include "vlt/distributions.h"
#include "vlt/gum.h"
#include "stats/log_gamma.h"

namespace vlt {
namespace {

// Bisection of a monotonically increasing cdf on [lo, hi] to full double precision.
template <typename Cdf>
double InvertIncreasing(Cdf cdf, double p, double lo, double hi) {
  for (int i = 0; i < 2000 && hi - lo > 4 * std::numeric_limits<double>::epsilon() * hi; ++i) {
    const double mid = 0.5 * (lo + hi);
    (cdf(mid) < p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace

// Chi-square cdf with m (integer) degrees of freedom: regularized lower incomplete gamma
// P(m/2, x/2) by the exact recurrence P(a + 1, z) = P(a, z) - z^a e^-z / Gamma(a + 1), from
// P(1/2, z) = erf(sqrt z) and P(1, z) = 1 - e^-z (Abramowitz & Stegun 6.5.13, 26.4.4-5).
double ChiSquareCdf(double x, int m) {
  if (x <= 0.0) return 0.0;
  const double z = 0.5 * x;
  double a = (m % 2 == 1) ? 0.5 : 1.0;
  double p = (m % 2 == 1) ? std::erf(std::sqrt(z)) : -std::expm1(-z);
  while (a < 0.5 * m - 0.25) {
    p -= std::exp(a * std::log(z) - z - stats_internal::LogGamma(a + 1.0));
    a += 1.0;
  }
  return p;
}

double NormalCoverageFactor(double p) {
  if (!(p > 0.0 && p < 1.0)) {
    throw std::invalid_argument("coverage probability must be in (0, 1)");
  }
  // P(|Z| <= k) = erf(k / sqrt 2) = p.
  return InvertIncreasing([](double k) { return std::erf(k / std::sqrt(2.0)); }, p, 0.0, 40.0);
}

double StudentTCoverageFactor(double p, double nu) {
  if (!(p > 0.0 && p < 1.0) || !(nu >= 1.0)) {
    throw std::invalid_argument("coverage probability must be in (0, 1), degrees of freedom >= 1");
  }
  // Above nu = 1e7 t_p(nu) equals the normal k to better than 1e-7 (k_t - k_n ~ (k^3 + k) / (4 nu)),
  // and the incomplete beta function loses its accuracy: use the normal one.
  if (nu > 1e7) return NormalCoverageFactor(p);
  // Closed forms where the tail is heavy: nu = 1 (Cauchy) k = tan(pi p / 2); nu = 2
  // k = p sqrt(2 / (1 - p^2)).
  if (nu == 1.0) return std::tan(0.5 * std::numbers::pi * p);
  if (nu == 2.0) return p * std::sqrt(2.0 / (1.0 - p * p));
  // P(|T| <= k) = 2 F(k) - 1 = p; k < 1e6 for nu >= 3 and p < 1 - 1e-15.
  const double k = InvertIncreasing([nu](double t) { return 2.0 * StudentTCdf(t, nu) - 1.0; }, p, 0.0, 1e6);
  if (!(k < 1e6)) throw std::invalid_argument("Student t coverage factor beyond 1e6");
  return k;
}

double WelchSatterthwaite(double u_c, const std::vector<double>& component_variances,
                          const std::vector<double>& component_dof) {
  double denominator = 0.0;
  for (std::size_t i = 0; i < component_variances.size(); ++i) {
    const double nu = component_dof[i];
    if (std::isfinite(nu) && nu > 0.0) {
      denominator += component_variances[i] * component_variances[i] / nu;
    }
  }
  const double u4 = u_c * u_c * u_c * u_c;
  if (!(denominator > 0.0) || !(u4 > 0.0)) return std::numeric_limits<double>::infinity();
  return u4 / denominator;
}

double ChiSquareCoverageFactor(double p, int m) {
  if (!(p > 0.0 && p < 1.0) || m < 1) {
    throw std::invalid_argument("coverage probability must be in (0, 1), dimension >= 1");
  }
  const double q = InvertIncreasing([m](double x) { return ChiSquareCdf(x, m); }, p, 0.0, 1000.0 + 100.0 * m);
  return std::sqrt(q);
}

}  // namespace vlt
