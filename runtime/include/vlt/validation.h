// vlt/validation.h — validation of the GUM uncertainty framework by the Monte Carlo method
// (JCGM 101 §8), and its extension to the coverage region of a measured point (docs/monte-carlo.md
// "Validation").
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "vlt/mcm.h"

namespace vlt {

// JCGM 101 8.2 for one scalar output. GUM interval y +- U_p (U_p = k u(y)) against the MCM
// probabilistically symmetric interval [y_low, y_high]:
//   d_low = |y - U_p - y_low|, d_high = |y + U_p - y_high|,
// delta = numerical tolerance of the GUM u(y) with n_dig significant digits (7.9.2).
// validated <=> d_low <= delta and d_high <= delta.
//
// A comparison with a Monte Carlo run of fixed M can fail from Monte Carlo noise alone. vlt states
// the Monte Carlo numerical tolerance of the interval ends, mcm_tolerance = 2 s_end with
// s_end = u sqrt(a (1 - a) / M) / phi(z_a), a = (1 - p)/2, the large-sample standard deviation of
// a quantile of a (near-)normal output (the 2 s of JCGM 101 7.9.4). Outcomes:
//   "validated"       d_low, d_high <= delta;
//   "inconclusive"    not within delta, but within delta + 2 mcm_tolerance (4 s_end): Monte Carlo
//                     noise can explain it; more trials (or --adaptive) are needed;
//   "not validated"   beyond delta + 2 mcm_tolerance: the GUM interval is not the Monte Carlo one;
//   "not applicable"  the GUM quantity has no first-order sensitivity (a form quantity at exact
//                     nominal points, vlt/fits.h): GUM gives no value to compare.
struct ScalarValidation {
  std::string name;
  std::string unit;
  double gum_y = 0.0;
  double gum_u = 0.0;
  double gum_expanded = 0.0;  // U_p
  double mcm_low = 0.0;
  double mcm_high = 0.0;
  double d_low = 0.0;
  double d_high = 0.0;
  double delta = 0.0;
  double mcm_tolerance = 0.0;  // 2 s_end (above); 0 when unknown (trials = 0)
  bool validated = false;
  std::string outcome;  // "validated", "inconclusive", "not validated", "not applicable"
  std::string verdict;  // outcome with the numbers
  // Inconclusive: about how many trials would decide, M (2 mcm_tolerance / (worst - delta))^2 (the
  // tolerance shrinks as 1 / sqrt(M)); 0 otherwise or when not estimated (trials unknown).
  double trials_to_decide = 0.0;
  // Validated as exact: the GUM's u and the Monte Carlo interval both within the output's
  // numerical resolution (ValidateScalar's `resolution`). What a statement may call "exact".
  bool exact = false;
};

// trials: M of the Monte Carlo run; mcm_u: its standard uncertainty of the output; p: coverage
// probability. differentiable = false: "not applicable". resolution: the numerical resolution of
// the output (what rounding leaves in a value computed from inputs of that size, e.g. 64 ulps of
// the coordinates a task is computed from); delta is never below it, so an output whose GUM u
// and Monte Carlo spread are both rounding noise (a component an RPS holds exactly) is not
// judged on its noise (docs/monte-carlo.md §9). 0: no floor.
ScalarValidation ValidateScalar(const std::string& name, const std::string& unit, double gum_y, double gum_u,
                                double gum_expanded, const CoverageInterval& mcm_symmetric,
                                int significant_digits, std::int64_t trials = 0, double mcm_u = 0.0,
                                double p = 0.95, bool differentiable = true, double resolution = 0.0);

// JCGM 101 8 for an output whose Monte Carlo values have no finite variance
// (McmOutputResult::infinite_variance; a ratio whose divisor's interval holds zero): the GUM
// propagates variances, and there is none to propagate, so `v` becomes "not validated" with the
// tail index in its verdict, whatever its interval comparison said (with no variance the Monte
// Carlo tolerance 2 s_end, which assumes one, made it "inconclusive"). Nothing for other outputs.
void CheckFiniteVariance(const McmOutputResult& mcm, ScalarValidation& v);

// Outcome of several comparisons together: "not validated" if any is, else "inconclusive" if any
// is, else "validated" ("not applicable" ones do not count; all of them: "not applicable").
std::string CombinedOutcome(const std::vector<std::string>& outcomes);

// Multivariate comparison for one point (JCGM 102 coverage regions, criterion defined by vlt):
// GUM region  E_g = {eta : (eta - y_g)^T U_g^-1 (eta - y_g) <= k_g^2}, k_g = sqrt(chi2_3(p));
// MCM region  E_m = {eta : (eta - y_m)^T U_m^-1 (eta - y_m) <= k_m^2}, k_m from McmPointResult.
// In every unit direction v the two regions project onto intervals; their endpoint differences
//   d(v) = max(|v.(y_g - y_m) - (k_g s_g(v) - k_m s_m(v))|, |v.(y_g - y_m) + (k_g s_g(v) - k_m s_m(v))|)
// with s(v) = sqrt(v^T U v) are JCGM 101's d_low, d_high for the scalar v.Y (max over v = the
// Hausdorff distance of the two ellipsoids). The point is validated when d(v) <= delta(s_g(v))
// for every direction (delta of 7.9.2 with n_dig digits), checked on a dense set of directions
// (1000 spread on the sphere + the coordinate axes + the eigenvectors of U_g). Also reported:
// the relative Frobenius difference |U_m - U_g|_F / |U_g|_F and the ratio k_m / k_g.
struct PointValidation {
  std::string name;
  double gum_coverage_factor = 0.0;    // sqrt(chi2_3(p))
  double mcm_coverage_factor = 0.0;    // 0 when the MCM region does not exist
  double coverage_factor_ratio = 0.0;  // k_m / k_g
  double covariance_difference = 0.0;  // relative Frobenius difference
  double worst_ratio = 0.0;            // max over v of d(v) / delta(s_g(v))
  Eigen::Vector3d worst_direction = Eigen::Vector3d::UnitX();
  double worst_distance = 0.0;  // d(v) in the worst direction, m
  double worst_delta = 0.0;     // delta(s_g(v)) there, m
  // Monte Carlo tolerance of the region's end in the worst direction: 2 s(v) with
  // s(v) = s_m(v) sqrt(s_k^2 + k_m^2 / (2M)), s_k = sqrt(p (1 - p) / M) / f(k_m), f the chi density
  // with 3 degrees of freedom (the quantile k_m and the spread s_m(v) both estimated from M trials).
  double mcm_tolerance = 0.0;
  bool validated = false;
  std::string outcome;  // as ScalarValidation::outcome
  std::string verdict;
  double trials_to_decide = 0.0;  // as ScalarValidation::trials_to_decide
};

// gum_coverage_factor: k_g = sqrt(chi2_3(p)) of the GUM region (vlt/gum.h
// ChiSquareCoverageFactor(p, 3), PointUncertainty::ellipsoid.k). Throws NumericalError when the
// GUM covariance is not positive definite (no region to compare).
PointValidation ValidatePoint(const std::string& name, const Eigen::Vector3d& gum_y,
                              const Eigen::Matrix3d& gum_covariance, double gum_coverage_factor,
                              const McmPointResult& mcm, int significant_digits, std::int64_t trials = 0,
                              double p = 0.95);

}  // namespace vlt
