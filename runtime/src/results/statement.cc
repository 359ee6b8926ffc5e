// results/statement.cc — each task's result as one signs it (JCGM 100 7.2): the value and its
// expanded uncertainty rounded as 7.2.6 asks (U up to two significant digits, the value to the same
// decimal place), the coverage factor and probability, the Monte Carlo coverage interval where it
// was run, and the decision against a tolerance (ISO 14253-1). Printed at the top of the summary
// and of report.html, and in results.json `statements` (docs/results.md "Result statements").
#include <cmath>
#include <string>
#include <vector>

#include "results/internal.h"
#include "vlt/conformity.h"

namespace vlt::results_internal {
namespace {

// The units a statement shows a task quantity in: lengths as mm with U in µm, angles as degrees
// with U in arcseconds, dimensionless quantities (direction components) as they are.
struct ShownUnits {
  double value_scale = 1.0, expanded_scale = 1.0;
  std::string value_unit, expanded_unit;
};

// Decimals of a value shown without an uncertainty to round it by: 0.1 um, 10^-6 degree, 10^-6.
int PlainDecimals(const ShownUnits& units) { return units.value_unit == " mm" ? 4 : 6; }

ShownUnits UnitsOf(const std::string& si_unit) {
  constexpr double kDegree = 180.0 / 3.14159265358979323846;
  if (si_unit == "m") return {1e3, 1e6, " mm", " µm"};
  if (si_unit == "rad") return {kDegree, 3600.0 * kDegree, "°", "″"};
  return {1.0, 1.0, "", ""};
}

// "; conforms to [a, b] mm (ISO 14253-1, guard band U; probability of conformity 99.9 %)".
std::string ConformityText(const TaskResult& t, std::size_t q, const ShownUnits& units, int decimals) {
  if (q >= t.conformity.size() || !t.conformity[q]) return "";
  const std::string& quantity = t.gum.quantities[q];
  const Tolerance* tolerance = nullptr;
  for (const auto& [name, limits] : t.spec.tolerances) tolerance = name == quantity ? &limits : tolerance;
  if (tolerance == nullptr) return "";
  auto limit = [&](double v) { return ShownAt(v, units.value_scale, decimals); };
  std::string interval;
  if (std::isfinite(tolerance->lower) && std::isfinite(tolerance->upper)) {
    interval.append("[")
        .append(limit(tolerance->lower))
        .append(", ")
        .append(limit(tolerance->upper))
        .append("]");
  } else if (std::isfinite(tolerance->upper)) {
    interval.append("≤ ").append(limit(tolerance->upper));
  } else {
    interval.append("≥ ").append(limit(tolerance->lower));
  }
  interval.append(units.value_unit);
  const ConformityDecision& decision = *t.conformity[q];
  std::string text = "; " + decision.verdict + (decision.verdict == "undetermined" ? " against " : " to ") +
                     interval + " (ISO 14253-1, guard band U";
  const std::optional<double> p =
      decision.probability_mcm ? decision.probability_mcm : decision.probability_gum;
  // Three significant digits; beyond 99.9 % or below 0.1 % a bound (a Monte Carlo fraction of 1
  // out of M trials says "more than 1 - 1/M", not "certain").
  if (p) {
    text += "; probability of conformity " + (*p > 0.999   ? std::string("> 99.9 %")
                                              : *p < 0.001 ? std::string("< 0.1 %")
                                                           : Sig(100.0 * *p, 3) + " %");
  }
  return text + ")";
}

// One statement: "<value> <unit>, U = <U> <unit> (k = 1.96, p = 95 %)" and what Monte Carlo says.
std::string StatementText(const Results& r, const TaskResult& t, std::size_t q) {
  const Eigen::Index i = static_cast<Eigen::Index>(q);
  const ShownUnits units = UnitsOf(t.gum.units[q]);
  const double value = t.gum.value[i], expanded = t.gum.U[i];
  const bool differentiable = q >= t.gum.differentiable.size() || t.gum.differentiable[q];
  // No first-order value: not differentiable, or a first-order u of 0 to rounding (ValidateScalar).
  const bool no_first_order = !differentiable || (t.has_mcm && q < t.validation.size() &&
                                                  t.validation[q].outcome == "not applicable");
  // U below 10^-9 of the unit it is shown in (1 fm, 1 nrad): what rounding leaves of an exactly
  // determined quantity (a component a reference point system holds), not an uncertainty.
  const bool exact = !no_first_order && std::isfinite(expanded) && expanded * units.expanded_scale < 1e-9;
  const bool has_gum = !no_first_order && !exact && std::isfinite(expanded);
  const std::string p = Sig(100.0 * r.coverage_probability, 3) + " %";
  const McmOutputResult* mc = t.has_mcm && q < t.mcm.size() ? &t.mcm[q] : nullptr;
  std::string text;
  int decimals = 0;
  if (exact) {
    return ShownAt(value, units.value_scale, PlainDecimals(units)) + units.value_unit +
           ", exact (U below the numerical resolution)";
  }
  if (has_gum) {
    const GumRounded rounded = RoundLikeGum(value, units.value_scale, expanded, units.expanded_scale);
    decimals = rounded.value_decimals;
    text = rounded.value + units.value_unit + ", U = " + rounded.expanded + units.expanded_unit +
           " (k = " + Sig(t.gum.k, 3) + ", p = " + p + ")";
  } else if (mc != nullptr) {
    // No first-order GUM value: the Monte Carlo interval, rounded like a U of its half-width.
    const double half = 0.5 * (mc->symmetric.high - mc->symmetric.low);
    decimals = half > 0.0 ? RoundLikeGum(value, units.value_scale, half, units.value_scale).value_decimals
                          : PlainDecimals(units);
    text = ShownAt(value, units.value_scale, decimals) + units.value_unit +
           " (the GUM gives no first-order uncertainty)";
  } else {
    return ShownAt(value, units.value_scale, PlainDecimals(units)) + units.value_unit +
           " (no uncertainty: the GUM gives no first-order value and Monte Carlo was not run)";
  }
  if (mc != nullptr) {
    const std::string outcome = q < t.validation.size() ? t.validation[q].outcome : "";
    text += "; Monte Carlo " + p + " coverage interval [" +
            ShownAt(mc->symmetric.low, units.value_scale, decimals) + ", " +
            ShownAt(mc->symmetric.high, units.value_scale, decimals) + "]" + units.value_unit;
    if (has_gum) text += outcome == "validated" ? ", GUM validated (JCGM 101 8)" : ", GUM " + outcome;
  }
  return text + ConformityText(t, q, units, decimals);
}

}  // namespace

bool IsHeadline(const TaskResult& t, const std::string& quantity) {
  if (t.spec.kind == TaskKind::kDeviation) return quantity == "deviation";
  if (t.spec.kind == TaskKind::kPosition) return quantity == "deviation" || quantity == "position";
  if (t.spec.kind == TaskKind::kProfile || t.spec.kind == TaskKind::kFlatness ||
      t.spec.kind == TaskKind::kStraightness || t.spec.kind == TaskKind::kRoundness ||
      t.spec.kind == TaskKind::kCylindricity)
    return true;
  return quantity == "distance" || quantity == "radius" || quantity == "flatness" ||
         quantity == "straightness" || quantity == "cylindricity" || quantity == "half_angle" ||
         (t.spec.kind == TaskKind::kCone && quantity == "form") || quantity == "normal_x" ||
         quantity == "normal_y" || quantity.rfind("centre_", 0) == 0 || t.spec.kind == TaskKind::kTwoFace ||
         t.spec.kind == TaskKind::kBestFit || t.spec.kind == TaskKind::kBestFitScale ||
         t.spec.kind == TaskKind::kRps || t.spec.kind == TaskKind::kFeatures;
}

std::vector<ResultStatement> ResultStatements(const Results& r) {
  std::vector<ResultStatement> statements;
  for (const TaskResult& t : r.tasks) {
    for (std::size_t q = 0; q < t.gum.quantities.size(); ++q) {
      if (!IsHeadline(t, t.gum.quantities[q])) continue;
      statements.push_back({t.spec.name, t.gum.quantities[q], StatementText(r, t, q)});
    }
  }
  return statements;
}

}  // namespace vlt::results_internal
