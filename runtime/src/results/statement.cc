// results/statement.cc — each task's result as one signs it (JCGM 100 7.2): the value and its
// expanded uncertainty rounded as 7.2.6 asks (U up to two significant digits, the value to the same
// decimal place), the coverage factor and probability, the Monte Carlo coverage interval where it
// was run, and the decision against a tolerance (ISO 14253-1). Printed at the top of the summary
// and of report.html, and in results.json `statements` (docs/results.md "Result statements").
#include <cmath>
#include <cstdio>
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

// A tolerance limit as it was specified (not rounded to the value's decimals): ten significant
// digits in the shown unit, trailing zeros dropped.
std::string Limit(double v, const ShownUnits& units) {
  return ShortestAt(v, units.value_scale) + units.value_unit;
}

// "; conforms to [a, b] mm (ISO 14253-1, guard band U; probability of conformity 99.9 %)", with
// the rule that decided (DecidedByMonteCarlo: the Monte Carlo shortest interval in place of y +- U).
std::string ConformityText(const TaskResult& t, std::size_t q, const ShownUnits& units) {
  if (q >= t.conformity.size() || !t.conformity[q]) return "";
  const std::string& quantity = t.gum.quantities[q];
  const Tolerance* tolerance = nullptr;
  for (const auto& [name, limits] : t.spec.tolerances) tolerance = name == quantity ? &limits : tolerance;
  if (tolerance == nullptr) return "";
  std::string interval;
  if (std::isfinite(tolerance->lower) && std::isfinite(tolerance->upper)) {
    const ShownUnits bare{units.value_scale, units.expanded_scale, "", ""};
    interval.append("[")
        .append(Limit(tolerance->lower, bare))
        .append(", ")
        .append(Limit(tolerance->upper, bare));
    interval.append("]").append(units.value_unit);
  } else if (std::isfinite(tolerance->upper)) {
    interval.append("≤ ").append(Limit(tolerance->upper, units));
  } else {
    interval.append("≥ ").append(Limit(tolerance->lower, units));
  }
  const ConformityDecision& decision = *t.conformity[q];
  std::string text =
      "; " + decision.verdict + (decision.verdict == "undetermined" ? " against " : " to ") + interval +
      (DecidedByMonteCarlo(t, q) ? " (ISO 14253-1 with the Monte Carlo shortest coverage interval"
                                 : " (ISO 14253-1, guard band U");
  // Three significant digits; beyond 99.9 % or below 0.1 % a bound (a Monte Carlo fraction of 1
  // out of M trials says "more than 1 - 1/M", not "certain").
  const std::optional<double> p =
      decision.probability_mcm ? decision.probability_mcm : decision.probability_gum;
  if (p) {
    text += "; probability of conformity " + (*p > 0.999   ? std::string("> 99.9 %")
                                              : *p < 0.001 ? std::string("< 0.1 %")
                                                           : Sig(100.0 * *p, 3) + " %");
  }
  return text + ")";
}

// The statement led by the Monte Carlo distribution (DecidedByMonteCarlo): its shortest coverage
// interval (the one the decision uses), rounded like a U of its half-width, and why.
std::string MonteCarloStatement(const TaskResult& t, std::size_t q, const ShownUnits& units,
                                const std::string& p) {
  const Eigen::Index i = static_cast<Eigen::Index>(q);
  const CoverageInterval& ci = t.mcm[q].shortest;
  const double half = 0.5 * (ci.high - ci.low);
  // Decimals that show the interval's width (rounded like a U of its half-width), unless that is
  // rounding noise (below 10^-12 of the shown unit): then the value's plain decimals.
  int decimals = PlainDecimals(units);
  if (std::isfinite(half) && half * units.value_scale > 1e-12) {
    decimals = RoundLikeGum(t.gum.value[i], units.value_scale, half, units.value_scale).value_decimals;
  }
  std::string text = "Monte Carlo " + p + " shortest coverage interval [" +
                     ShownAt(ci.low, units.value_scale, decimals) + ", " +
                     ShownAt(ci.high, units.value_scale, decimals) + "]" + units.value_unit;
  const bool differentiable = q >= t.gum.differentiable.size() || t.gum.differentiable[q];
  const std::string outcome = q < t.validation.size() ? t.validation[q].outcome : "";
  if (!differentiable || outcome == "not applicable") {
    text += " (the GUM gives no first-order uncertainty; value at the estimates " +
            ShownAt(t.gum.value[i], units.value_scale, decimals) + units.value_unit + ")";
  } else {
    const GumRounded gum = RoundLikeGum(t.gum.value[i], units.value_scale, t.gum.U[i], units.expanded_scale);
    text += " (the GUM's " + gum.value + units.value_unit + ", U = " + gum.expanded + units.expanded_unit +
            " is " + outcome + " by Monte Carlo, JCGM 101 8)";
  }
  return text;
}

// One statement: "<value> <unit>, U = <U> <unit> (k = 1.96, p = 95 %)" and what Monte Carlo says;
// led by Monte Carlo where the GUM has no first-order value or is not validated.
std::string StatementText(const Results& r, const TaskResult& t, std::size_t q) {
  const Eigen::Index i = static_cast<Eigen::Index>(q);
  const ShownUnits units = UnitsOf(t.gum.units[q]);
  const double value = t.gum.value[i], expanded = t.gum.U[i];
  const std::string p = Sig(100.0 * r.coverage_probability, 3) + " %";
  if (DecidedByMonteCarlo(t, q)) return MonteCarloStatement(t, q, units, p) + ConformityText(t, q, units);
  const bool differentiable = q >= t.gum.differentiable.size() || t.gum.differentiable[q];
  const McmOutputResult* mc = t.has_mcm && q < t.mcm.size() ? &t.mcm[q] : nullptr;
  if (!differentiable) {
    return ShownAt(value, units.value_scale, PlainDecimals(units)) + units.value_unit +
           " (no uncertainty: the GUM gives no first-order value and Monte Carlo was not run)" +
           ConformityText(t, q, units);
  }
  // Exact where the validation says so (ScalarValidation::exact: the GUM's u and the Monte Carlo
  // interval within the output's numerical resolution; one rule, not a second threshold here).
  // Without Monte Carlo a U below 10^-9 of its shown unit (1 fm, 1 nrad) only says the first order
  // is 0 (a normal's component along itself varies at second order).
  if (mc != nullptr && q < t.validation.size() && t.validation[q].exact) {
    return ShownAt(value, units.value_scale, PlainDecimals(units)) + units.value_unit +
           ", exact (the GUM's U and the Monte Carlo interval are below the numerical resolution)" +
           ConformityText(t, q, units);
  }
  if (mc == nullptr && !(std::isfinite(expanded) && expanded * units.expanded_scale >= 1e-9)) {
    return ShownAt(value, units.value_scale, PlainDecimals(units)) + units.value_unit +
           ", U 0 to first order (a second-order spread, if any, needs Monte Carlo)" +
           ConformityText(t, q, units);
  }
  const GumRounded rounded = RoundLikeGum(value, units.value_scale, expanded, units.expanded_scale);
  std::string text = rounded.value + units.value_unit + ", U = " + rounded.expanded + units.expanded_unit +
                     " (k = " + Sig(t.gum.k, 3) + ", p = " + p + ")";
  if (mc != nullptr) {
    const std::string outcome = q < t.validation.size() ? t.validation[q].outcome : "";
    text += "; Monte Carlo " + p + " coverage interval [" +
            ShownAt(mc->symmetric.low, units.value_scale, rounded.value_decimals) + ", " +
            ShownAt(mc->symmetric.high, units.value_scale, rounded.value_decimals) + "]" + units.value_unit +
            (outcome == "validated" ? ", GUM validated (JCGM 101 8)" : ", GUM " + outcome);
  }
  return text + ConformityText(t, q, units);
}

}  // namespace

bool DecidedByMonteCarlo(const TaskResult& task, std::size_t q) {
  if (!task.has_mcm || q >= task.mcm.size()) return false;
  const bool differentiable = q >= task.gum.differentiable.size() || task.gum.differentiable[q];
  const std::string outcome = q < task.validation.size() ? task.validation[q].outcome : "";
  return !differentiable || outcome == "not applicable" || outcome == "not validated";
}

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
