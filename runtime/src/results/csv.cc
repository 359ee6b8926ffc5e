// points.csv, budget.csv, tasks.csv, map.csv (docs/results.md). Units are in the column names:
// coordinates in mm, uncertainties in um, angles in deg; budget estimates/u in each input's SI unit
// (column `unit`). Numbers are printed with the shortest representation that reads back exactly.
#include <cstdio>
#include <cmath>
#include <sstream>

#include "results/internal.h"

namespace vlt {
namespace {

using base_internal::Num;

constexpr double kMm = 1e3;  // m -> mm
constexpr double kUm = 1e6;  // m -> um
constexpr double kDeg = 180.0 / 3.14159265358979323846;

std::string Csv(const std::string& field) { return base_internal::CsvField(field); }

class Row {
 public:
  Row& operator<<(const std::string& s) { return Add(Csv(s)); }
  Row& operator<<(const char* s) { return Add(Csv(s)); }
  Row& operator<<(double v) {
    Separate();
    base_internal::AppendNum(line_, v);
    return *this;
  }
  Row& operator<<(int v) { return Add(std::to_string(v)); }
  Row& Empty() { return Add(""); }
  std::string str() const { return line_ + "\n"; }
  const std::string& line() const { return line_; }

 private:
  void Separate() {
    if (!first_) line_ += ',';
    first_ = false;
  }
  Row& Add(const std::string& s) {
    Separate();
    line_ += s;
    return *this;
  }
  std::string line_;
  bool first_ = true;
};

std::string Verdict(const PointResult& p) {
  if (!p.has_mcm) return "not run";
  return p.outcome;
}

bool IsLength(const std::string& unit) { return unit == "m"; }

// One row of the full points.csv: the point p, g its full GUM result (PointDetails).
std::string PointRow(const Results& r, const PointResult& p, const PointUncertainty& g) {
  Row row;
  row << p.input.name << std::string(FaceName(p.input.face)) << g.readings[0] << g.readings[1] * kDeg
      << g.readings[2] * kDeg;
  if (r.mode == JobMode::kPlan) {
    row << p.input.nominal.x() * kMm << p.input.nominal.y() * kMm << p.input.nominal.z() * kMm;
  } else {
    row.Empty().Empty().Empty();
  }
  row << g.part.x() * kMm << g.part.y() * kMm << g.part.z() * kMm;
  for (int a = 0; a < 3; ++a) row << g.u_part[a] * kUm;
  row << g.k;
  for (int a = 0; a < 3; ++a) row << g.U_part[a] * kUm;
  row << g.U_part.norm() * kUm << g.ellipsoid.k;
  for (int a = 0; a < 3; ++a) row << g.ellipsoid.semi_axes[a] * kUm;
  row << g.los_part.u_radial * kUm << g.los_part.u_horizontal * kUm << g.los_part.u_vertical * kUm;
  // No ratio where the first-order u is 0 (infinite): an empty field, never a number.
  if (const double ratio = g.second_order_ratio.maxCoeff(); std::isfinite(ratio)) {
    row << ratio;
  } else {
    row.Empty();
  }
  row << std::string(g.gum_reliable ? "yes" : "no");
  if (p.has_mcm) {
    const PointMcm& m = *p.monte_carlo;
    for (int a = 0; a < 3; ++a) row << m.axes[a].mean * kMm;
    for (int a = 0; a < 3; ++a) row << m.axes[a].u * kUm;
    for (int a = 0; a < 3; ++a) row << m.axes[a].symmetric.low * kMm << m.axes[a].symmetric.high * kMm;
    double d_max = 0.0, delta = 0.0;
    for (int a = 0; a < 3; ++a) {
      d_max = std::max({d_max, m.axis_validation[a].d_low, m.axis_validation[a].d_high});
      delta = a == 0 ? m.axis_validation[a].delta : std::min(delta, m.axis_validation[a].delta);
    }
    row << m.mcm.coverage_factor << d_max * kUm << delta * kUm << m.region_validation.worst_ratio;
  } else {
    for (int k = 0; k < 16; ++k) row.Empty();
  }
  row << Verdict(p);
  return row.line() + '\n';
}

}  // namespace

void WritePointsCsv(const Results& r, OutputText& out) {
  out.Write("name,face,range_m,azimuth_deg,elevation_deg,nominal_x_mm,nominal_y_mm,nominal_z_mm,"
         "x_mm,y_mm,z_mm,u_x_um,u_y_um,u_z_um,k,U_x_um,U_y_um,U_z_um,U_norm_um,"
         "ellipsoid_k,ellipsoid_a1_um,ellipsoid_a2_um,ellipsoid_a3_um,"
         "u_radial_um,u_horizontal_um,u_vertical_um,second_order_ratio_max,gum_reliable,"
         "mcm_x_mm,mcm_y_mm,mcm_z_mm,mcm_u_x_um,mcm_u_y_um,mcm_u_z_um,"
         "mcm_low_x_mm,mcm_high_x_mm,mcm_low_y_mm,mcm_high_y_mm,mcm_low_z_mm,mcm_high_z_mm,"
         "mcm_ellipsoid_k,d_max_um,delta_um,region_worst_ratio,gum_vs_mcm\n");
  results_internal::WritePointDetails(
      r, out, false, [&](std::size_t first, std::span<const PointUncertainty> points, std::string& text) {
        for (std::size_t i = 0; i < points.size(); ++i) text += PointRow(r, r.points[first + i], points[i]);
      });
}

// One row per point (docs/results.md "points.csv, compact"): the estimate rounded to 0.1 um, U
// rounded up to 3 significant digits, the rank-1 row of the point's budget and its share of trace(U_y). The
// budgets are recomputed block by block (results_internal::WritePointDetails), never held.
void WriteCompactPointsCsv(const Results& r, OutputText& out) {
  out.Write("name,x_mm,y_mm,z_mm,U_x_um,U_y_um,U_z_um,U_norm_um,dominant_input,dominant_share,gum_reliable");
  out.Write(r.has_mcm ? ",gum_vs_mcm\n" : "\n");
  constexpr int kCoordinateDecimals = 4;  // mm: 0.1 um
  constexpr int kUncertaintyDigits = 3;
  constexpr int kShareDecimals = 3;
  results_internal::WritePointDetails(
      r, out, true, [&](std::size_t first, std::span<const PointUncertainty> points, std::string& text) {
        for (std::size_t i = 0; i < points.size(); ++i) {
          const PointResult& p = r.points[first + i];
          const PointUncertainty& g = points[i];
          text += Csv(p.input.name);
          for (int a = 0; a < 3; ++a) {
            text += ',';
            base_internal::AppendDecimals(text, g.part[a] * kMm, kCoordinateDecimals);
          }
          for (int a = 0; a < 3; ++a) {
            text += ',';
            base_internal::AppendRoundedUp(text, g.U_part[a] * kUm, kUncertaintyDigits);
          }
          text += ',';
          base_internal::AppendRoundedUp(text, g.U_part.norm() * kUm, kUncertaintyDigits);
          // Rows are sorted by share_total: the first is the dominant input (budget.csv rank 1).
          const std::vector<BudgetRow>& budget = points[i].budget;
          text += ',';
          if (!budget.empty()) {
            text += Csv(budget.front().input);
            text += ',';
            base_internal::AppendDecimals(text, budget.front().share_total, kShareDecimals);
          } else {
            text += ',';
          }
          text += g.gum_reliable ? ",yes" : ",no";
          if (r.has_mcm) {
            text += ',';
            text += Csv(Verdict(p));
          }
          text += '\n';
        }
      });
}

namespace results_internal {

std::pair<std::string, double> PracticalSensitivity(const std::string& input_unit) {
  constexpr double kArcsec = 3.14159265358979323846 / (180.0 * 3600.0);
  if (input_unit == "m") return {"um/um", 1e6 * 1e-6};
  if (input_unit == "rad") return {"um/arcsec", 1e6 * kArcsec};
  if (input_unit == "1") return {"um/ppm", 1e6 * 1e-6};
  if (input_unit == "degC" || input_unit == "K") return {"um/K", 1e6};
  if (input_unit == "Pa") return {"um/hPa", 1e6 * 100.0};
  if (input_unit == "%") return {"um/%", 1e6};
  if (input_unit == "1/K") return {"um/(ppm/K)", 1e6 * 1e-6};
  return {"um/" + input_unit, 1e6};
}

}  // namespace results_internal

void WriteBudgetCsv(const Results& r, OutputText& out) {
  out.Write(
      "point,rank,input,group,unit,estimate,u,sensitivity_x,sensitivity_y,sensitivity_z,"
      "sensitivity_unit,sensitivity_practical_x,sensitivity_practical_y,sensitivity_practical_z,"
      "sensitivity_practical_unit,contribution_x_um,contribution_y_um,contribution_z_um,"
      "share_x,share_y,share_z,share_total\n");
  results_internal::WritePointDetails(
      r, out, true, [&](std::size_t first, std::span<const PointUncertainty> points, std::string& text) {
        for (std::size_t i = 0; i < points.size(); ++i) {
          int rank = 0;
          for (const BudgetRow& b : points[i].budget) {
            Row row;
            row << r.points[first + i].input.name << ++rank << b.input << b.group << b.input_unit
                << b.estimate << b.u;
            for (int a = 0; a < 3; ++a) row << b.sensitivity[a];
            row << b.sensitivity_unit;
            if (b.group == "correlation") {
              row.Empty().Empty().Empty().Empty();
            } else {
              const auto [unit, factor] = results_internal::PracticalSensitivity(b.input_unit);
              for (int a = 0; a < 3; ++a) row << b.sensitivity[a] * factor;
              row << unit;
            }
            for (int a = 0; a < 3; ++a) row << b.contribution[a] * kUm;
            for (int a = 0; a < 3; ++a) row << b.share[a];
            row << b.share_total;
            text += row.line();
            text += '\n';
          }
        }
      });
}

std::string PointsCsv(const Results& r) {
  StringText text;
  WritePointsCsv(r, text);
  return std::move(text.text());
}

std::string BudgetCsv(const Results& r) {
  StringText text;
  WriteBudgetCsv(r, text);
  return std::move(text.text());
}

std::string TasksCsv(const Results& r) {
  std::ostringstream out;
  out << "task,kind,quantity,value_unit,value,u_unit,u,k,U,mcm_mean,mcm_u,mcm_low,mcm_high,"
         "d_low,d_high,delta,gum_vs_mcm,tolerance_lower,tolerance_upper,conformity,"
         "probability_of_conformity_gum,probability_of_conformity_mcm\n";
  for (const TaskResult& t : r.tasks) {
    for (std::size_t q = 0; q < t.gum.quantities.size(); ++q) {
      const bool length = IsLength(t.gum.units[q]);
      const double vs = length ? kMm : 1.0;  // value scale
      const double us = length ? kUm : 1.0;  // uncertainty scale
      const Eigen::Index i = static_cast<Eigen::Index>(q);
      Row row;
      row << t.spec.name << std::string(TaskKindName(t.spec.kind)) << t.gum.quantities[q]
          << (length ? "mm" : t.gum.units[q]) << t.gum.value[i] * vs << (length ? "um" : t.gum.units[q])
          << t.gum.u[i] * us << t.gum.k << t.gum.U[i] * us;
      if (t.has_mcm && q < t.mcm.size()) {
        const McmOutputResult& m = t.mcm[q];
        const ScalarValidation& v = t.validation[q];
        row << m.mean * vs << m.u * us << m.symmetric.low * vs << m.symmetric.high * vs << v.d_low * us
            << v.d_high * us << v.delta * us << v.verdict;
      } else {
        row.Empty().Empty().Empty().Empty().Empty().Empty().Empty() << "not run";
      }
      // Conformity (vlt/conformity.h): limits in the value's unit (mm for lengths).
      const std::optional<ConformityDecision>* c = q < t.conformity.size() ? &t.conformity[q] : nullptr;
      const Tolerance* tol = t.spec.ToleranceOf(t.gum.quantities[q]);
      if (c != nullptr && c->has_value() && tol != nullptr) {
        if (std::isinf(tol->lower))
          row.Empty();
        else
          row << tol->lower * vs;
        if (std::isinf(tol->upper))
          row.Empty();
        else
          row << tol->upper * vs;
        row << (*c)->verdict;
        if ((*c)->probability_gum)
          row << *(*c)->probability_gum;
        else
          row.Empty();
        if ((*c)->probability_mcm)
          row << *(*c)->probability_mcm;
        else
          row.Empty();
      } else {
        row.Empty().Empty().Empty().Empty().Empty();
      }
      out << row.str();
    }
  }
  return out.str();
}

std::string MapCsv(const MapResult& map) {
  std::ostringstream out;
  // Per-source columns follow the totals (docs/results.md "map.csv"): groups, then sources.
  out << "x_m,y_m,z_m,U_x_um,U_y_um,U_z_um,U_norm_um,status";
  if (map.has_mcm) out << ",U_norm_mcm_um,gum_vs_mcm";
  if (!map.sources.empty()) out << ",dominant_source";
  for (const MapResult::Layer& g : map.groups) out << "," << Csv("U_group_" + g.name + "_um");
  for (const MapResult::Layer& l : map.sources) out << "," << Csv("U_" + l.name + "_um");
  out << "\n";
  std::size_t skipped = 0;
  for (std::size_t i = 0; i < map.nodes.size(); ++i) {
    Row row;
    row << map.nodes[i].x() << map.nodes[i].y() << map.nodes[i].z();
    const std::size_t extra =
        (map.has_mcm ? 2 : 0) + (map.sources.empty() ? 0 : 1) + map.groups.size() + map.sources.size();
    if (map.computed[i]) {
      row << map.U[i].x() * kUm << map.U[i].y() * kUm << map.U[i].z() * kUm << map.U_norm[i] * kUm << "ok";
      if (map.has_mcm) row << map.U_norm_mcm[i] * kUm << map.verdict[i];
      if (!map.sources.empty()) row << map.sources[static_cast<std::size_t>(map.dominant[i])].name;
      for (const MapResult::Layer& g : map.groups) row << g.U[i] * kUm;
      for (const MapResult::Layer& l : map.sources) row << l.U[i] * kUm;
    } else {
      std::string reason = skipped < map.skipped.size() ? map.skipped[skipped] : "skipped";
      ++skipped;
      std::size_t colon = reason.find("m: ");
      if (colon != std::string::npos) reason = reason.substr(colon + 3);
      row.Empty().Empty().Empty().Empty() << "skipped: " + reason;
      for (std::size_t e = 0; e < extra; ++e) row.Empty();
    }
    out << row.str();
  }
  return out.str();
}

}  // namespace vlt
