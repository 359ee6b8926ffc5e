// Writing the result files all-or-nothing, and the terminal summary.
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <system_error>

#include "output/page.h"
#include "results/internal.h"
#include "vlt/error.h"

namespace vlt {
namespace {

// printf into a std::string of any length (names of any length).
template <typename... Args>
std::string FormatLine(const char* format, Args... args) {
  const int n = std::snprintf(nullptr, 0, format, args...);
  std::string text(static_cast<std::size_t>(std::max(n, 0)), '\0');
  std::snprintf(text.data(), text.size() + 1, format, args...);
  return text;
}

}  // namespace

std::vector<OutputFile> ResultFiles(const Results& results) {
  // Written when the output directory commits, into its staging directory: a failure leaves the
  // old set untouched; the per-point files are streamed, never held whole.
  const Results* r = &results;
  std::vector<OutputFile> files;
  if (results.detail == PointDetail::kCompact) {
    files.emplace_back("points.csv", [r](OutputText& out) { WriteCompactPointsCsv(*r, out); });
  } else {
    files.emplace_back("points.csv", [r](OutputText& out) { WritePointsCsv(*r, out); });
    files.emplace_back("points.jsonl", [r](OutputText& out) { WritePointsJsonl(*r, out); });
    files.emplace_back("budget.csv", [r](OutputText& out) { WriteBudgetCsv(*r, out); });
  }
  if (results.arrays) files.emplace_back("points.npy", [r](OutputText& out) { WritePointsNpy(*r, out); });
  files.emplace_back("tasks.csv", [r](OutputText& out) { out.Write(TasksCsv(*r)); });
  files.emplace_back("results.json", [r](OutputText& out) { out.Write(ResultsJson(*r)); });
  files.emplace_back("report.html", [r](OutputText& out) { out.Write(ReportHtml(*r)); });
  if (results.map) {
    files.emplace_back("map.csv", [r](OutputText& out) { out.Write(MapCsv(*r->map)); });
    files.emplace_back("map.html", [r](OutputText& out) {
      out.Write(MapHtml(*r->map, r->job_name + ": " + r->map->settings.description));
    });
  }
  return files;
}

namespace {

void RunHeaderLines(const Results& r, std::ostringstream& out) {
  char line[512];
  out << "vlt " << r.vlt_version << " — job '" << r.job_name << "' (" << r.job_file << "), model "
      << r.model_name << ", " << (r.mode == JobMode::kPlan ? "offline plan" : "online readings") << ", "
      << r.points.size() << (r.points.size() == 1 ? " point, " : " points, ") << r.tasks.size()
      << (r.tasks.size() == 1 ? " task\n" : " tasks\n");
  out << output_internal::RecordLine(r.record);
  if (r.calibration) {
    if (r.calibration->kind == "identified") {
      out << "Tracker parameters from the calibration file " << r.calibration->file << " (instrument '"
          << r.calibration->instrument << "', calibrated " << r.calibration->created << ")\n";
    } else {
      // A prior from a datasheet (vlt prior) is no calibration of this instrument: say which it is.
      out << "Tracker parameters: a prior from the datasheet's MPE (" << r.calibration->file << ", '"
          << r.calibration->instrument << "', derived " << r.calibration->created
          << "; not a calibration of this instrument)\n";
    }
  }
  std::snprintf(line, sizeof line,
                "Coverage probability %.4g: U = k u per axis with k = %.3f; |U| = sqrt(Ux^2+Uy^2+Uz^2); "
                "coverage ellipsoid k = %.3f\n\n",
                r.coverage_probability, r.k_axis, r.k_region);
  out << line;
}

// Each task's result as JCGM 100 7.2 states it (ResultStatements), at the top.
void StatementLines(const Results& r, std::ostringstream& out) {
  const std::vector<results_internal::ResultStatement> statements = results_internal::ResultStatements(r);
  if (statements.empty()) return;
  out << "Results (JCGM 100 7.2; U rounded up to two significant digits, the value to the same decimal "
         "place, 7.2.6):\n";
  for (const results_internal::ResultStatement& s : statements) out << "  " << s.task << "." << s.quantity << " = " << s.text << "\n";
  out << "\n";
}

// A number of trials as people write it: two significant digits, whole, in groups of three
// ("640 000", not "6.4e+05").
std::string TrialCount(double m) {
  const double scale = std::pow(10.0, std::max(0.0, std::floor(std::log10(m)) - 1.0));
  const std::string digits = std::to_string(static_cast<long long>(std::llround(m / scale) * scale));
  std::string out;
  for (std::size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) out += ' ';
    out += digits[i];
  }
  return out;
}

// The verdict column of a point: its validation by Monte Carlo, and whether the GUM is reliable.
std::string PointVerdict(const PointResult& p) {
  const PointGum& g = p.gum;
  std::string verdict = !p.has_mcm ? "not run" : p.outcome == "not validated" ? "NOT validated" : p.outcome;
  if (!g.gum_reliable) {
    // JCGM 100 5.1.2 note, computed without Monte Carlo: said with --no-mcm too.
    char flag[128];
    const double ratio = g.second_order_ratio.maxCoeff();
    if (!g.second_order_decided) {
      // The curvature changes within one u: no ratio says by how much (docs/gum.md).
      std::snprintf(flag, sizeof flag,
                    "GUM NOT RELIABLE (2nd order cannot decide: curvature changes within 1 u; "
                    "Monte Carlo); ");
    } else if (std::isfinite(ratio)) {
      std::snprintf(flag, sizeof flag, "GUM NOT RELIABLE (2nd order %.3g x u^2); ", ratio);
    } else {
      std::snprintf(flag, sizeof flag, "GUM NOT RELIABLE (first-order u is 0, 2nd order is not); ");
    }
    verdict = flag + verdict;
  }
  return verdict;
}

void PointTable(const Results& r, std::ostringstream& out) {
  const std::size_t max_rows = 40;
  // Point names are shown whole (SpatialAnalyzer-style "Group::Collection::Point" included): the
  // column is as wide as the longest name shown.
  int name_width = 14;
  for (std::size_t i = 0; i < r.points.size() && i < max_rows; ++i) {
    name_width = std::max(name_width, static_cast<int>(r.points[i].input.name.size()));
  }
  std::string u_headers;  // padded by columns: "µm" is one column and two bytes
  for (const char* header : {"Ux[µm]", "Uy[µm]", "Uz[µm]", "|U|[µm]", "a1[µm]"}) {
    u_headers.append(" ").append(base_internal::PadColumns(header, 8));
  }
  out << FormatLine("%-*s %9s %10s %10s %10s%s  %s\n", name_width, "point", "range[m]", "x[mm]", "y[mm]",
                    "z[mm]", u_headers.c_str(), "GUM vs MCM");
  // The rows' full results (the ellipsoid's largest semi-axis) recomputed: Results keep PointGum.
  std::vector<std::size_t> shown(std::min(r.points.size(), max_rows));
  for (std::size_t i = 0; i < shown.size(); ++i) shown[i] = i;
  const std::vector<PointUncertainty> details = PointDetails(r, shown, false, r.threads);
  for (std::size_t i = 0; i < r.points.size(); ++i) {
    if (i == max_rows) {
      out << "... " << (r.points.size() - max_rows) << " more points in points.csv\n";
      break;
    }
    const PointResult& p = r.points[i];
    const PointUncertainty& g = details[i];
    const std::string verdict = PointVerdict(p);
    out << FormatLine("%-*s %9.3f %10.3f %10.3f %10.3f %8.1f %8.1f %8.1f %8.1f %8.1f  %s\n", name_width,
                      p.input.name.c_str(), g.readings[0], g.part.x() * 1e3, g.part.y() * 1e3,
                      g.part.z() * 1e3, g.U_part.x() * 1e6, g.U_part.y() * 1e6, g.U_part.z() * 1e6,
                      g.U_part.norm() * 1e6, g.ellipsoid.semi_axes[0] * 1e6, verdict.c_str());
  }
}

// The headline quantities only; every component is in tasks.csv.
// The widths of the task table's first three columns: the longest name, kind and quantity shown
// (at least the headers' usual widths), so that a long one shifts no column.
struct TaskColumns {
  int name = 18, kind = 9, quantity = 13;
};

// Decimals that show x (> 0) with three significant digits (13.2: 1; 0.00000724: 8), at most 12.
int DecimalsForThreeDigits(double x) {
  if (!(x > 0.0) || !std::isfinite(x)) return 1;
  return std::clamp(2 - static_cast<int>(std::floor(std::log10(x))), 0, 12);
}

// One row of the task table: quantity q of task t, its GUM value and U and the Monte Carlo interval.
std::string TaskRow(const TaskResult& t, std::size_t q, const TaskColumns& columns) {
  const std::string& quantity = t.gum.quantities[q];
  const Eigen::Index i = static_cast<Eigen::Index>(q);
  const bool length = t.gum.units[q] == "m", angle = t.gum.units[q] == "rad";
  constexpr double kDegree = 180.0 / 3.14159265358979323846;
  const double vs = length ? 1e3 : angle ? kDegree : 1.0, us = length ? 1e6 : angle ? 3600.0 * kDegree : 1.0;
  const char* u_unit = length ? " µm" : angle ? " arcsec" : "";
  char value_text[64] = "";
  // A value that rounds to zero is printed as 0, not -0.0000 (two_face of nominal points).
  if (length) {
    const double shown = std::abs(t.gum.value[i] * vs) < 5e-5 ? 0.0 : t.gum.value[i] * vs;
    std::snprintf(value_text, sizeof value_text, "%.4f mm", shown);
  } else if (angle) {
    const double shown = std::abs(t.gum.value[i] * vs) < 5e-7 ? 0.0 : t.gum.value[i] * vs;
    std::snprintf(value_text, sizeof value_text, "%.6f deg", shown);
  }
  std::string value = value_text;
  // A quantity without a first-order derivative (the form of nominal points) has no GUM U: "n/a",
  // never "0 um" (docs/tasks.md "Jacobians").
  const bool has_gum = q >= t.gum.differentiable.size() || t.gum.differentiable[q];
  // A first-order u of 0 to rounding (ValidateScalar: "not applicable" although differentiable)
  // is printed as 0, not as the rounding noise it is (7.24e-22).
  const bool first_order_zero =
      has_gum && t.has_mcm && q < t.validation.size() && t.validation[q].outcome == "not applicable";
  const bool has_interval = t.has_mcm && q < t.validation.size();
  const double low = has_interval ? (t.mcm[q].symmetric.low - t.gum.value[i]) * us : 0.0;
  const double high = has_interval ? (t.mcm[q].symmetric.high - t.gum.value[i]) * us : 0.0;
  // U to three significant digits; the interval's ends, and a dimensionless value, to the same
  // decimal place (0.00000724, not 7.24e-06; [-39.1, 38.0], not [-39.1, 38]); the ends keep two
  // significant digits of their own where they are much narrower than U (a GUM NOT validated:
  // [-0.41, 0.39] beside U = 385, not [0, 0]). Beyond eight decimals (a U of rounding noise
  // without Monte Carlo to say so) three significant digits with an exponent, never 0.000000000000.
  const bool shown_u = has_gum && !first_order_zero;
  const double ends = std::max(std::abs(low), std::abs(high));
  const int decimals = DecimalsForThreeDigits(shown_u ? t.gum.U[i] * us : ends);
  const int end_decimals = std::max(decimals, DecimalsForThreeDigits(ends) - 1);
  auto shown = [](double x, int d) { return d > 8 ? base_internal::Sig(x, 3) : base_internal::Fixed(x, d); };
  if (!length && !angle) {
    const double v = std::abs(t.gum.value[i]) < 1e-12 ? 0.0 : t.gum.value[i];
    value = std::abs(v) < 1e6 ? base_internal::Fixed(v, std::clamp(decimals, 6, 8)) : base_internal::Sig(v, 6);
  }
  std::string big_u = !has_gum           ? std::string("n/a")
                      : first_order_zero ? std::string("0") + u_unit
                                         : shown(t.gum.U[i] * us, decimals) + u_unit;
  std::string interval = "-", verdict = "not run";
  if (has_interval) {
    interval.assign("[").append(shown(low, end_decimals)).append(", ");
    interval.append(shown(high, end_decimals)).append("]").append(u_unit);
    const std::string& outcome = t.validation[q].outcome;
    verdict = outcome == "not validated"    ? "NOT validated"
              : outcome != "not applicable" ? outcome
              : first_order_zero            ? "GUM u 0 to rounding (2nd order only): MCM interval"
                                            : "GUM n/a (not differentiable): MCM interval";
  }
  // U and the interval are padded by columns, not bytes: "µm" is two bytes wide in printf's count.
  return FormatLine("%-*s %-*s %-*s %16s %s %s  %s\n", columns.name, t.spec.name.c_str(), columns.kind,
                    std::string(TaskKindName(t.spec.kind)).c_str(), columns.quantity, quantity.c_str(),
                    value.c_str(), base_internal::PadColumns(big_u, 11).c_str(),
                    base_internal::PadColumns(interval, 26).c_str(), verdict.c_str());
}

void TaskTable(const Results& r, std::ostringstream& out) {
  if (r.tasks.empty()) return;
  TaskColumns columns;
  for (const TaskResult& t : r.tasks) {
    for (const std::string& quantity : t.gum.quantities) {
      if (!results_internal::IsHeadline(t, quantity)) continue;
      columns.name = std::max(columns.name, static_cast<int>(t.spec.name.size()));
      columns.kind = std::max(columns.kind, static_cast<int>(TaskKindName(t.spec.kind).size()));
      columns.quantity = std::max(columns.quantity, static_cast<int>(quantity.size()));
    }
  }
  out << "\n"
      << FormatLine("%-*s %-*s %-*s %16s %11s %26s  %s\n", columns.name, "task", columns.kind, "kind",
                    columns.quantity, "quantity", "value", "U (GUM)", "MCM interval - value", "GUM vs MCM");
  for (const TaskResult& t : r.tasks) {
    for (std::size_t q = 0; q < t.gum.quantities.size(); ++q) {
      if (!results_internal::IsHeadline(t, t.gum.quantities[q])) continue;
      out << TaskRow(t, q, columns);
    }
  }
}

// Conformity of the task quantities with a tolerance (ISO 14253-1, JCGM 106).
void ConformityLines(const Results& r, std::ostringstream& out) {
  char line[512];
  bool first_conformity = true;
  for (const TaskResult& t : r.tasks) {
    for (std::size_t q = 0; q < t.conformity.size(); ++q) {
      if (!t.conformity[q]) continue;
      const ConformityDecision& d = *t.conformity[q];
      const Tolerance tol = *t.spec.ToleranceOf(t.gum.quantities[q]);
      // In the unit of the task table's value beside it: mm, degrees, or as it is.
      constexpr double kDegree = 180.0 / 3.14159265358979323846;
      const std::string& unit = t.gum.units[q];
      const std::string limits = unit == "m"     ? DescribeTolerance(tol, 1e3, "mm")
                                 : unit == "rad" ? DescribeTolerance(tol, kDegree, "deg")
                                                 : DescribeTolerance(tol, unit == "1" ? "" : unit);
      std::snprintf(line, sizeof line, "%s %s %s: %s", t.spec.name.c_str(), t.gum.quantities[q].c_str(),
                    limits.c_str(), d.verdict.c_str());
      out << (first_conformity ? "\n" : "") << line << " (probability of conformity";
      first_conformity = false;
      if (d.probability_gum) {
        std::snprintf(line, sizeof line, " %.4g GUM", *d.probability_gum);
        out << line;
      }
      if (d.probability_mcm) {
        std::snprintf(line, sizeof line, "%s %.4g Monte Carlo", d.probability_gum ? "," : "",
                      *d.probability_mcm);
        out << line;
      }
      out << ")\n";
    }
  }
}

// The Monte Carlo outputs without a finite variance (McmOutputResult::infinite_variance), if any:
// their u and the comparison with the GUM mean nothing.
void NoFiniteVarianceLine(const Results& r, std::ostringstream& out) {
  std::vector<const McmOutputResult*> outputs;
  for (const PointResult& p : r.points) {
    if (!p.has_mcm) continue;
    for (const McmOutputResult& a : p.monte_carlo->axes) {
      if (a.infinite_variance) outputs.push_back(&a);
    }
  }
  for (const TaskResult& t : r.tasks) {
    for (const McmOutputResult& q : t.mcm) {
      if (q.infinite_variance) outputs.push_back(&q);
    }
  }
  if (outputs.empty()) return;
  out << "No finite variance (tail index < 2, Hill's estimator; u is meaningless, the coverage intervals are "
         "the answer): ";
  for (std::size_t i = 0; i < outputs.size() && i < 6; ++i) {
    char item[160];
    std::snprintf(item, sizeof item, "%s%s (index %.2f)", i ? ", " : "", outputs[i]->name.c_str(),
                  outputs[i]->tail_index.value_or(0.0));
    out << item;
  }
  out << (outputs.size() > 6 ? ", ...\n" : "\n");
}

void MonteCarloLines(const Results& r, std::ostringstream& out) {
  char line[1024];
  if (!r.has_mcm) {
    out << "Monte Carlo: not run (GUM only).\n";
    return;
  }
  // Task results are counted per quantity: one output the GUM cannot linearise (e.g. the
  // flatness of nominal points) must not hide that the others are validated.
  std::size_t quantities = 0, validated = 0, inconclusive = 0, without_gum = 0;
  std::string failed;
  int listed = 0;
  for (const TaskResult& t : r.tasks) {
    for (const ScalarValidation& v : t.validation) {
      if (v.outcome == "not applicable") {  // no GUM value to validate
        ++without_gum;
        continue;
      }
      ++quantities;
      if (v.validated) {
        ++validated;
      } else if (v.outcome == "inconclusive") {
        ++inconclusive;
      } else if (listed++ < 6) {
        failed += (failed.empty() ? "" : ", ") + v.name;
      } else if (listed == 7) {
        failed += ", ...";
      }
    }
  }
  // "gpu: <device>" (docs/gpu.md): said as "and the GPU <device>".
  const bool on_gpu = r.mcm.device.rfind("gpu: ", 0) == 0;
  std::snprintf(
      line, sizeof line,
      "Monte Carlo: %lld trials%s, seed %llu, %d thread(s)%s%s, %.1f s. GUM validated by MCM (JCGM 101 8): "
      "%d/%zu points, %zu/%zu task %s",
      static_cast<long long>(r.mcm.trials),
      r.mcm.adaptive ? (r.mcm.converged ? " (adaptive, converged)" : " (adaptive, NOT converged)") : "",
      static_cast<unsigned long long>(r.mcm.seed), r.mcm.threads, on_gpu ? " and the GPU " : "",
      on_gpu ? r.mcm.device.c_str() + 5 : "", r.mcm.seconds, r.validated_points,
      r.points.size(), validated, quantities, quantities == 1 ? "quantity" : "quantities");
  out << line;
  // Those with no first-order GUM value (not differentiable, or a first-order u of 0 to rounding):
  // their Monte Carlo interval is the answer, nothing to validate.
  if (without_gum > 0) out << " (" << without_gum << " more with no first-order GUM value: Monte Carlo only)";
  out << ".\n";
  if (r.inconclusive_points > 0 || inconclusive > 0) {
    out << "Inconclusive (Monte Carlo tolerance larger than delta; more trials or --adaptive): "
        << r.inconclusive_points << (r.inconclusive_points == 1 ? " point, " : " points, ") << inconclusive
        << (inconclusive == 1 ? " task quantity" : " task quantities");
    // How many trials would decide most of them (ScalarValidation::trials_to_decide): 9 in 10, since
    // a difference that happens to sit at delta needs any number.
    std::vector<double> to_decide;
    auto add = [&](double m) {
      if (m > 0.0) to_decide.push_back(m);
    };
    for (const PointResult& p : r.points) {
      if (!p.has_mcm || !p.monte_carlo) continue;
      double point = 0.0;  // a point is decided when its axes and its region are
      for (const ScalarValidation& v : p.monte_carlo->axis_validation)
        point = std::max(point, v.trials_to_decide);
      add(std::max(point, p.monte_carlo->region_validation.trials_to_decide));
    }
    for (const TaskResult& t : r.tasks) {
      for (const ScalarValidation& v : t.validation) add(v.trials_to_decide);
    }
    if (!to_decide.empty()) {
      std::sort(to_decide.begin(), to_decide.end());
      const double m = to_decide[(to_decide.size() * 9 - 1) / 10];
      out << "; " << (m > 1e9 ? std::string("more than 10^9") : "about " + TrialCount(m))
          << " trials would decide " << (to_decide.size() >= 10 ? "9 in 10 of them" : "most of them");
    }
    out << ".\n";
  }
  if (!failed.empty()) out << "Not validated: " << failed << " (tasks.csv, report.html).\n";
  NoFiniteVarianceLine(r, out);
}

void MapLine(const MapResult& map, std::ostringstream& out) {
  char line[512];
  double max_u = 0, min_u = 1e300;
  for (std::size_t i = 0; i < map.nodes.size(); ++i) {
    if (!map.computed[i]) continue;
    max_u = std::max(max_u, map.U_norm[i]);
    min_u = std::min(min_u, map.U_norm[i]);
  }
  std::snprintf(line, sizeof line,
                "Map: %s: |U| %.1f .. %.1f µm over %zu nodes (%zu skipped: at the gimbal point, on the vertical axis or beyond 10 km).\n",
                map.settings.description.c_str(), min_u * 1e6, max_u * 1e6, map.nodes.size(),
                map.skipped.size());
  out << line;
}

}  // namespace

std::string SummaryText(const Results& r) {
  std::ostringstream out;
  RunHeaderLines(r, out);
  StatementLines(r, out);
  PointTable(r, out);
  TaskTable(r, out);
  ConformityLines(r, out);
  out << "\n";
  MonteCarloLines(r, out);
  if (r.map) MapLine(*r.map, out);
  if (r.detail == PointDetail::kCompact) {
    // The compact points.csv has other columns than the full one: said where it is written.
    out << "points.csv is compact (" << r.points.size()
        << " points: name, estimate, U, dominant input; no budget.csv, no points.jsonl); "
           "[output] detail = \"full\" writes every column (docs/results.md)\n";
  }
  return out.str();
}

}  // namespace vlt
