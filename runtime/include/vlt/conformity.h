// vlt/conformity.h — is a measured quantity within its tolerance? The decision rule of
// ISO 14253-1:2017 (guard band = the expanded uncertainty U) and the probability of conformity of
// JCGM 106:2012 (docs/conformity.md).
#pragma once

#include <limits>
#include <optional>
#include <string>

namespace vlt {

// A tolerance interval [lower, upper] of a quantity, SI units; a one-sided tolerance has the
// other limit infinite (e.g. flatness: lower = -inf, upper = 50 um).
struct Tolerance {
  double lower = -std::numeric_limits<double>::infinity();
  double upper = std::numeric_limits<double>::infinity();
};

struct ConformityDecision {
  // ISO 14253-1:2017, 8.2 / 8.3 (simple acceptance with the guard band w = U on each side):
  //   "conforms"          lower + U <= y <= upper - U   (conformity proved)
  //   "does not conform"  y < lower - U or y > upper + U (non-conformity proved)
  //   "undetermined"      otherwise: the uncertainty range straddles a tolerance limit.
  std::string verdict;
  double guard_band = 0.0;        // U, same unit as y
  double acceptance_lower = 0.0;  // lower + U (-inf when one-sided)
  double acceptance_upper = 0.0;  // upper - U (+inf when one-sided)
  // JCGM 106 7.3.2: probability of conformity p_c = P(lower <= Y <= upper) for the normal PDF
  // N(y, u^2) of the GUM (u = 0: 1 or 0), or, with finite effective degrees of freedom, the
  // scaled and shifted t_nu_eff(y, u^2) (JCGM 106 7.3.3; consistent with U = t_p(nu_eff) u);
  // absent where the GUM gives no value (a form quantity at exact nominal points).
  std::optional<double> probability_gum;
  // The same from the Monte Carlo values (the fraction of the M trials inside the tolerance,
  // JCGM 106 7.2 with the MCM distribution function); absent without Monte Carlo.
  std::optional<double> probability_mcm;
};

// y, u: the GUM estimate and standard uncertainty; U: the expanded uncertainty (the guard band);
// dof: the effective degrees of freedom of u (infinity: normal).
ConformityDecision DecideConformity(const Tolerance& tolerance, double y, double u, double U,
                                    std::optional<double> probability_mcm = std::nullopt,
                                    double dof = std::numeric_limits<double>::infinity());

// "[a, b] m", "<= b m", ">= a m" for files (SI; base_internal::ShortestAt: the shortest digits that
// read back, at most 15 significant digits; below 10^-6 or from 10^16 with an exponent, 5e-12).
std::string DescribeTolerance(const Tolerance& tolerance, const std::string& unit);
// The same in the unit the value beside it is shown in: the limits (SI) times `scale` (1e3 for mm,
// 1e6 for µm), written as they were specified (the decimal point moved, not multiplied: 0.05 mm,
// never 0.05000000000000001 mm), then `shown_unit`.
std::string DescribeTolerance(const Tolerance& tolerance, double scale, const std::string& shown_unit);

}  // namespace vlt
