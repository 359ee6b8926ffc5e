// tasks/conformity.cc — ISO 14253-1:2017 decision with guard band U and the JCGM 106:2012
// probability of conformity (vlt/conformity.h, docs/conformity.md).
#include "vlt/conformity.h"

#include <cmath>
#include <cstdio>

#include "base/format.h"
#include "vlt/distributions.h"

namespace vlt {

ConformityDecision DecideConformity(const Tolerance& tolerance, double y, double u, double U,
                                    std::optional<double> probability_mcm, double dof) {
  ConformityDecision d;
  d.guard_band = U;
  d.acceptance_lower = tolerance.lower + U;  // -inf + U = -inf
  d.acceptance_upper = tolerance.upper - U;
  if (y >= d.acceptance_lower && y <= d.acceptance_upper) {
    d.verdict = "conforms";
  } else if (y < tolerance.lower - U || y > tolerance.upper + U) {
    d.verdict = "does not conform";
  } else {
    d.verdict = "undetermined";
  }
  // JCGM 106 (7.3.2): p_c = Phi((T_U - y) / u) - Phi((T_L - y) / u); Phi(+-inf) = 1, 0; with
  // finite nu_eff the t distribution function in place of Phi (7.3.3).
  const bool t = std::isfinite(dof) && dof <= 1e7;
  auto cdf = [&](double z) { return t ? StudentTCdf(z, dof) : StandardNormalCdf(z); };
  if (u > 0.0) {
    const double hi = std::isinf(tolerance.upper) ? 1.0 : cdf((tolerance.upper - y) / u);
    const double lo = std::isinf(tolerance.lower) ? 0.0 : cdf((tolerance.lower - y) / u);
    d.probability_gum = std::max(0.0, hi - lo);
  } else {
    d.probability_gum = (y >= tolerance.lower && y <= tolerance.upper) ? 1.0 : 0.0;
  }
  d.probability_mcm = probability_mcm;
  return d;
}

std::string DescribeTolerance(const Tolerance& tolerance, const std::string& unit) {
  return DescribeTolerance(tolerance, 1.0, unit);
}

std::string DescribeTolerance(const Tolerance& tolerance, double scale, const std::string& shown_unit) {
  // Appended piece by piece (g++ 12 warns falsely on "literal" + std::string here).
  std::string text;
  if (std::isinf(tolerance.lower)) {
    text.append("<= ").append(base_internal::ShortestAt(tolerance.upper, scale));
  } else if (std::isinf(tolerance.upper)) {
    text.append(">= ").append(base_internal::ShortestAt(tolerance.lower, scale));
  } else {
    text.append("[").append(base_internal::ShortestAt(tolerance.lower, scale)).append(", ");
    text.append(base_internal::ShortestAt(tolerance.upper, scale)).append("]");
  }
  if (!shown_unit.empty()) text.append(" ").append(shown_unit);
  return text;
}

}  // namespace vlt
