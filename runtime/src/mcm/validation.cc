// mcm/validation.cc — GUM validated by Monte Carlo (JCGM 101 §8; multivariate criterion of
// vlt/validation.h).
#include "vlt/validation.h"

#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "vlt/error.h"
#include "vlt/gum.h"

namespace vlt {
namespace {

// The outcome from the comparison and the Monte Carlo tolerance (vlt/validation.h): a difference
// beyond delta is put down to Monte Carlo noise only while it stays within delta plus two Monte
// Carlo tolerances (4 s_end: noise exceeds it with probability 6e-5).
std::string Outcome(double distance, double mcm_tolerance, double delta) {
  if (distance <= delta) return "validated";
  return distance <= delta + 2.0 * mcm_tolerance ? "inconclusive" : "not validated";
}

// With `trials` known, how many trials would tell an inconclusive comparison: the tolerance
// 2 s_end shrinks as 1 / sqrt(M), and the observed difference beyond delta becomes decisive ("not
// validated") once 2 s_end(M') < worst - delta, M' = M (2 s_end / (worst - delta))^2. An estimate
// from this run's difference: where the true difference lies within delta, the observed excess
// was noise and more trials than that may be needed (the next run's verdict says how many).
// 0: not estimated.
double TrialsToDecide(const std::string& outcome, double worst, double delta, double mcm_tolerance,
                      std::int64_t trials) {
  if (outcome != "inconclusive" || trials <= 0 || !(worst > delta)) return 0.0;
  return static_cast<double>(trials) * std::pow(2.0 * mcm_tolerance / (worst - delta), 2);
}

std::string Verdict(const std::string& outcome, double worst, double delta, double mcm_tolerance,
                    const std::string& unit, double trials_to_decide) {
  char text[400];
  if (outcome == "inconclusive") {
    char decide[160] = "use more trials or the adaptive procedure";
    if (trials_to_decide > 1e9) {
      std::snprintf(decide, sizeof decide,
                    "the difference is at delta itself: more than 1e9 trials would decide");
    } else if (trials_to_decide > 0.0) {
      std::snprintf(decide, sizeof decide, "about %.2g trials would decide, or the adaptive procedure",
                    trials_to_decide);
    }
    std::snprintf(text, sizeof text,
                  "inconclusive: Monte Carlo tolerance %.3g %s, delta %.3g %s, largest endpoint difference "
                  "%.3g %s within what Monte Carlo noise gives; %s",
                  mcm_tolerance, unit.c_str(), delta, unit.c_str(), worst, unit.c_str(), decide);
  } else {
    std::snprintf(text, sizeof text, "%s (largest endpoint difference %.3g %s, tolerance %.3g %s)",
                  outcome.c_str(), worst, unit.c_str(), delta, unit.c_str());
  }
  return text;
}

// Standard normal density.
double Phi(double z) { return std::exp(-0.5 * z * z) / std::sqrt(2.0 * std::numbers::pi); }

// Directions spread evenly on the unit sphere (Fibonacci lattice).
std::vector<Eigen::Vector3d> SphereDirections(int n) {
  std::vector<Eigen::Vector3d> out;
  const double golden = std::numbers::pi * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < n; ++i) {
    const double z = 1.0 - (2.0 * i + 1.0) / n;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    out.emplace_back(r * std::cos(golden * i), r * std::sin(golden * i), z);
  }
  return out;
}

}  // namespace

std::string CombinedOutcome(const std::vector<std::string>& outcomes) {
  bool any = false, inconclusive = false;
  for (const std::string& o : outcomes) {
    if (o == "not applicable") continue;
    any = true;
    if (o == "not validated") return o;
    inconclusive = inconclusive || o == "inconclusive";
  }
  if (!any) return "not applicable";
  return inconclusive ? "inconclusive" : "validated";
}

ScalarValidation ValidateScalar(const std::string& name, const std::string& unit, double gum_y, double gum_u,
                                double gum_expanded, const CoverageInterval& mcm_symmetric,
                                int significant_digits, std::int64_t trials, double mcm_u, double p,
                                bool differentiable, double resolution) {
  ScalarValidation v;
  v.name = name;
  v.unit = unit;
  v.gum_y = gum_y;
  v.gum_u = gum_u;
  v.gum_expanded = gum_expanded;
  v.mcm_low = mcm_symmetric.low;
  v.mcm_high = mcm_symmetric.high;
  // JCGM 101 8.2 b), c).
  v.d_low = std::abs(gum_y - gum_expanded - mcm_symmetric.low);
  v.d_high = std::abs(gum_y + gum_expanded - mcm_symmetric.high);
  if (!differentiable) {
    // GUM has no value here (no first-order sensitivity): nothing to validate (docs/tasks.md).
    v.outcome = "not applicable";
    v.verdict =
        "not applicable: GUM has no first-order value (not differentiable at zero form error); "
        "the Monte Carlo interval is the answer";
    return v;
  }
  // A first-order u of 0 to rounding: the GUM says the output is exact. Where the Monte Carlo
  // agrees (its interval within the resolution of the value: a component a reference point system
  // holds) that is validated; where it spreads further (a unit normal's component along itself,
  // which a tilt changes by 1 - cos: second order only) the GUM has no first-order value, as for
  // the form of nominal points, and the Monte Carlo interval is the answer. Its 7.9.2 delta, of a
  // u that is rounding noise, would otherwise judge that spread against the noise (issue 34:
  // "not validated" for u = 1e-21 against delta = 5e-22).
  if (resolution > 0.0 && gum_u <= resolution) {
    v.delta = resolution;
    const double spread = std::max(std::abs(mcm_symmetric.low - gum_y), std::abs(mcm_symmetric.high - gum_y));
    char text[360];
    if (spread <= resolution) {
      std::snprintf(
          text, sizeof text,
          "validated: exact (the GUM u, %.3g %s, and the Monte Carlo interval, within %.3g %s of the "
          "value, are below the output's numerical resolution, %.3g %s)",
          gum_u, unit.c_str(), spread, unit.c_str(), resolution, unit.c_str());
      v.validated = true;
      v.exact = true;
      v.outcome = "validated";
    } else {
      std::snprintf(
          text, sizeof text,
          "not applicable: the GUM's first-order u (%.3g %s) is 0 to rounding (at most the output's "
          "numerical resolution, %.3g %s) while the Monte Carlo interval reaches %.3g %s from the "
          "value: the output varies at second order only; the Monte Carlo interval is the answer",
          gum_u, unit.c_str(), resolution, unit.c_str(), spread, unit.c_str());
      v.outcome = "not applicable";
    }
    v.verdict = text;
    return v;
  }
  // JCGM 101 7.9.2's delta of u(y), but never finer than the output can be computed.
  v.delta = std::max(NumericalTolerance(gum_u, significant_digits), resolution);
  if (trials > 0 && mcm_u > 0.0) {
    const double a = 0.5 * (1.0 - p);
    const double z_a = NormalCoverageFactor(p);  // the (1 - a) quantile of N(0, 1)
    v.mcm_tolerance = 2.0 * mcm_u * std::sqrt(a * (1.0 - a) / static_cast<double>(trials)) / Phi(z_a);
  }
  v.validated = v.d_low <= v.delta && v.d_high <= v.delta;
  v.outcome = Outcome(std::max(v.d_low, v.d_high), v.mcm_tolerance, v.delta);
  v.trials_to_decide =
      TrialsToDecide(v.outcome, std::max(v.d_low, v.d_high), v.delta, v.mcm_tolerance, trials);
  v.verdict =
      Verdict(v.outcome, std::max(v.d_low, v.d_high), v.delta, v.mcm_tolerance, unit, v.trials_to_decide);
  return v;
}

void CheckFiniteVariance(const McmOutputResult& mcm, ScalarValidation& v) {
  if (!mcm.infinite_variance || v.outcome == "not applicable") return;
  char text[320];
  std::snprintf(
      text, sizeof text,
      "not validated: the Monte Carlo values have no finite variance (tail index %.2f < 2, "
      "Hill's estimator): a GUM u describes nothing; the Monte Carlo coverage interval is the answer",
      mcm.tail_index.value_or(0.0));
  v.validated = false;
  v.outcome = "not validated";
  v.verdict = text;
}

PointValidation ValidatePoint(const std::string& name, const Eigen::Vector3d& gum_y,
                              const Eigen::Matrix3d& gum_covariance, double gum_coverage_factor,
                              const McmPointResult& mcm, int significant_digits, std::int64_t trials,
                              double p) {
  PointValidation v;
  v.name = name;
  v.gum_coverage_factor = gum_coverage_factor;
  v.mcm_coverage_factor = mcm.has_region ? mcm.coverage_factor : 0.0;
  v.coverage_factor_ratio = v.mcm_coverage_factor / gum_coverage_factor;
  const double norm_g = gum_covariance.norm();
  if (Eigen::LLT<Eigen::Matrix3d>(gum_covariance).info() != Eigen::Success || !(norm_g > 0.0)) {
    throw NumericalError("validation of point '" + name +
                         "': the GUM covariance is not positive definite (no coverage region)");
  }
  v.covariance_difference = (mcm.covariance - gum_covariance).norm() / norm_g;
  if (!mcm.has_region) {
    v.validated = false;
    v.outcome = "not validated";
    v.verdict = "not validated (the Monte Carlo covariance is singular: no coverage region)";
    v.worst_ratio = 0.0;
    return v;
  }

  std::vector<Eigen::Vector3d> directions = SphereDirections(1000);
  for (int a = 0; a < 3; ++a) directions.push_back(Eigen::Vector3d::Unit(a));
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(gum_covariance);
  for (int a = 0; a < 3; ++a) directions.push_back(eigen.eigenvectors().col(a).normalized());

  const Eigen::Vector3d shift = gum_y - mcm.mean;
  v.worst_ratio = -1.0;
  for (const Eigen::Vector3d& d : directions) {
    const double s_g = std::sqrt(std::max(0.0, d.dot(gum_covariance * d)));
    const double s_m = std::sqrt(std::max(0.0, d.dot(mcm.covariance * d)));
    // Endpoints of the projections of both regions on d: JCGM 101 8.2 d_low, d_high for d.Y.
    const double c = d.dot(shift);
    const double h = gum_coverage_factor * s_g - mcm.coverage_factor * s_m;
    const double distance = std::max(std::abs(c - h), std::abs(c + h));
    const double delta = NumericalTolerance(s_g, significant_digits);
    const double ratio =
        delta > 0.0 ? distance / delta : (distance > 0.0 ? std::numeric_limits<double>::max() : 0.0);
    if (ratio > v.worst_ratio) {
      v.worst_ratio = ratio;
      v.worst_direction = d;
      v.worst_distance = distance;
      v.worst_delta = delta;
    }
  }
  v.validated = v.worst_ratio <= 1.0;
  if (trials > 0) {
    const double m = static_cast<double>(trials);
    const double k = mcm.coverage_factor;
    const double density = std::sqrt(2.0 / std::numbers::pi) * k * k * std::exp(-0.5 * k * k);  // chi, 3 dof
    const double s_k = std::sqrt(p * (1.0 - p) / m) / density;
    const double s_m = std::sqrt(std::max(0.0, v.worst_direction.dot(mcm.covariance * v.worst_direction)));
    v.mcm_tolerance = 2.0 * s_m * std::sqrt(s_k * s_k + k * k / (2.0 * m));
  }
  v.outcome =
      v.validated ? std::string("validated") : Outcome(v.worst_distance, v.mcm_tolerance, v.worst_delta);
  v.trials_to_decide = TrialsToDecide(v.outcome, v.worst_distance, v.worst_delta, v.mcm_tolerance, trials);
  v.verdict = Verdict(v.outcome, v.worst_distance, v.worst_delta, v.mcm_tolerance, "m", v.trials_to_decide);
  return v;
}

}  // namespace vlt
