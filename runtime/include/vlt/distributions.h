// vlt/distributions.h — the probability distributions the Monte Carlo engine samples (JCGM 101
// 6.4), each parameterised by the estimate (its expectation) and the standard uncertainty (its
// standard deviation), plus one shape parameter where the family has one. This is the ONE place
// a distribution is added: name, parser, sampling, CDF and quantile live in
// runtime/src/stats/distributions.cc. docs/monte-carlo.md lists the parametrisations.
//
//   kind                    names accepted                     shape                  clause
//   normal                  "normal", "gaussian"               none (0)               6.4.7
//   rectangular             "rectangular", "uniform"           none (0)               6.4.2
//   triangular (symmetric)  "triangular"                       none (0)               6.4.5
//   arcsine (U-shaped)      "arcsine", "u-shaped", "u_shaped"  none (0)               6.4.6
//   scaled-shifted t        "student_t", "student-t", "t"      nu > 2 (degrees of     6.4.9
//                                                              freedom)
//   curvilinear trapezoid   "curvilinear_trapezoid",           r = d / w in [0, 1]    6.4.3
//                           "curvilinear-trapezoid"
//
// Curvilinear trapezoid (JCGM 101 6.4.3): a rectangular distribution centred on the estimate
// whose half-width is itself inexact, uniformly distributed on [w - d, w + d]. The shape is
// r = d / w (0 = rectangular); the variance is w^2/3 + d^2/9 (6.4.3.3), so
// w = u / sqrt(1/3 + r^2/9).
// Student t (JCGM 101 6.4.9): t_nu(mu, s^2) with s = u * sqrt((nu - 2) / nu) so that its standard
// deviation is u; nu > 2 is required for the standard deviation to exist.
#pragma once

#include <string>
#include <string_view>

namespace vlt {

struct UncertainInput;

enum class DistributionKind {
  kNormal,
  kRectangular,
  kTriangular,
  kArcsine,
  kStudentT,
  kCurvilinearTrapezoid,
};

// "normal", "rectangular", ... (lower case, the canonical spelling above).
std::string_view DistributionName(DistributionKind kind);

// Parse a distribution name (case-insensitive, the spellings in the table above). Unknown names
// throw InputError "<where>: unknown distribution '<name>' (expected normal, rectangular, ...)".
DistributionKind ParseDistribution(std::string_view name, std::string_view where);

// True where the family has a shape parameter (student_t, curvilinear_trapezoid).
bool HasShape(DistributionKind kind);

class Distribution {
 public:
  // Throws InputError naming `where` when u < 0, u or estimate not finite, or the shape is out of
  // range (student_t: nu > 2; curvilinear_trapezoid: 0 <= r <= 1; others: shape ignored).
  Distribution(DistributionKind kind, double estimate, double u, double shape = 0.0,
               std::string_view where = "distribution");
  // From an UncertainInput (distribution name parsed with `where` = "<where>: <input.name>").
  static Distribution FromInput(const UncertainInput& input, std::string_view where);

  DistributionKind kind() const { return kind_; }
  double estimate() const { return estimate_; }
  double u() const { return u_; }
  double shape() const { return shape_; }

  // Half-width of the support (rectangular a = sqrt(3) u, triangular sqrt(6) u, arcsine sqrt(2) u,
  // curvilinear trapezoid w + d); infinite for normal and Student t.
  double half_width() const;

  // Cumulative distribution function P(X <= x). Exact closed forms; Student t through the
  // regularised incomplete beta function (continued fraction, ~1e-14).
  double Cdf(double x) const;
  // Inverse CDF at probability `p` in (0, 1). Closed form for normal (Acklam's rational start +
  // one Halley step on erfc: ~1e-15 relative), rectangular, triangular, arcsine; numerical
  // inversion of the CDF (bracketed Newton, to ~1e-14 u) for Student t and curvilinear trapezoid.
  double Quantile(double p) const;

  // Exact transforms of uniforms on (0, 1) to one draw, as the Monte Carlo engine uses them where
  // the input is independent of the others (normal draws come from Box-Muller pairs in the
  // engine, runtime/src/mcm/random.h):
  //  - rectangular, triangular, arcsine, normal: Quantile(u1) (inverse CDF; u2 unused);
  //  - curvilinear trapezoid: JCGM 101 6.4.3.4, u1 -> lower limit a_s = mu - w - d + 2 d u1,
  //    upper limit b_s = 2 mu - a_s, draw a_s + (b_s - a_s) u2;
  //  - Student t: Quantile(u1) (the engine uses SampleBailey instead, which is much faster).
  double SampleTwoUniforms(double u1, double u2) const;

  // Student t by Bailey's polar method (Bailey 1994, Math. Comp. 62, 779-781; exact):
  // v1 = 2 u1 - 1, v2 = 2 u2 - 1, w = v1^2 + v2^2; if 0 < w <= 1 the draw is
  // mu + s v1 sqrt(nu (w^(-2/nu) - 1) / w) and the function returns true; otherwise the pair is
  // rejected (probability 1 - pi/4) and the caller retries with fresh uniforms.
  bool SampleBailey(double u1, double u2, double* draw) const;

 private:
  DistributionKind kind_;
  double estimate_;
  double u_;
  double shape_;
  double scale_;  // a, sqrt(6)u, sqrt(2)u, w, t scale s; u for normal
};

// Standard normal CDF Phi(z) = erfc(-z / sqrt 2) / 2 and its inverse (|relative error| ~1e-15).
double StandardNormalCdf(double z);
double StandardNormalQuantile(double p);

// Student t with nu degrees of freedom (standard, not scaled): CDF for any real nu > 0.
double StudentTCdf(double t, double nu);

// Regularised incomplete beta function I_x(a, b), x in [0, 1], a, b > 0.
double RegularizedIncompleteBeta(double x, double a, double b);

}  // namespace vlt
