// results.json: the run in one document, SI units throughout (schema in docs/results.md;
// "schema": "vlt-results/2"); the detail of every point in points.jsonl, one JSON object per line,
// written point by point (a scan of 10^6 points never exists as one document). The report embeds
// its own variant (the points it draws, with their budgets).
#include <algorithm>
#include <cmath>
#include <cstdio>

#include <nlohmann/json.hpp>

#include "output/page.h"
#include "parallel/pool.h"
#include "results/internal.h"
#include "vlt/refractive_index.h"
#include "vlt/units.h"

namespace vlt {
namespace {

using json = nlohmann::ordered_json;

json Vec(const Eigen::VectorXd& v) {
  json a = json::array();
  for (Eigen::Index i = 0; i < v.size(); ++i) a.push_back(v[i]);
  return a;
}

json Mat(const Eigen::MatrixXd& m) {
  json a = json::array();
  for (Eigen::Index i = 0; i < m.rows(); ++i) {
    json row = json::array();
    for (Eigen::Index j = 0; j < m.cols(); ++j) row.push_back(m(i, j));
    a.push_back(row);
  }
  return a;
}

// Columns of a 3x3 direction matrix as a list of unit vectors.
json Columns(const Eigen::Matrix3d& m) {
  json a = json::array();
  for (int j = 0; j < 3; ++j) a.push_back(Vec(m.col(j)));
  return a;
}

// An input's value as the report shows it: as typed, else in a readable unit of its SI unit,
// else "%.6g <unit>" (custom models' own units).
std::string Shown(const std::string& typed, double si, const std::string& unit, bool is_u) {
  if (!typed.empty()) return typed;
  static const std::pair<const char*, Dimension> kDimensions[] = {
      {"m", Dimension::kLength},    {"rad", Dimension::kAngle},  {"1", Dimension::kRatio},
      {"Pa", Dimension::kPressure}, {"%", Dimension::kHumidity}, {"1/K", Dimension::kPerKelvin}};
  if (unit == "degC")
    return FormatReadable(si, is_u ? Dimension::kTemperatureDifference : Dimension::kTemperature);
  for (const auto& [name, dimension] : kDimensions) {
    if (unit == name) return FormatReadable(si, dimension);
  }
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.6g", si);
  return unit.empty() ? std::string(buffer) : std::string(buffer) + " " + unit;
}

json Input(const UncertainInput& in) {
  return json{{"name", in.name},
              {"group", in.group},
              {"unit", in.unit},
              {"estimate", in.estimate},
              {"u", in.u},
              {"distribution", in.distribution},
              {"shape", in.shape},
              {"display_estimate", Shown(in.display_estimate, in.estimate, in.unit, false)},
              {"display_u", Shown(in.display_u, in.u, in.unit, true)}};
}

// What a shared input is, for hover texts: a model parameter's description from its spec, else the
// meaning of the environment, pose and part inputs (docs/job-file.md).
std::string InputDescription(const MeasurementSetup& setup, const UncertainInput& in) {
  if (in.group == "parameter" && setup.model) {
    // setup.params[k] is the model's parameter k (under its own name when the job renamed it).
    for (std::size_t k = 0; k < setup.params.size() && k < static_cast<std::size_t>(setup.model->num_params);
         ++k) {
      if (setup.params[k].name == in.name || in.name == setup.model->params[k].name)
        return setup.model->params[k].description;
    }
  }
  static const std::pair<const char*, const char*> kMeaning[] = {
      {"environment.temperature", "Air temperature along the beam (refractive index of air: the range)"},
      {"environment.pressure", "Air pressure (refractive index of air: the range)"},
      {"environment.humidity", "Relative humidity of the air (refractive index of air: the range)"},
      {"environment.co2", "CO2 mole fraction of the air (refractive index of air: the range)"},
      {"pose.rx", "Station rotation about the part x axis"},
      {"pose.ry", "Station rotation about the part y axis"},
      {"pose.rz", "Station rotation about the part z axis"},
      {"pose.tx", "Station origin, part x"},
      {"pose.ty", "Station origin, part y"},
      {"pose.tz", "Station origin, part z"},
      {"thermal.cte", "Expansion coefficient of the part (coordinates reduced to the reference temperature)"},
      {"thermal.temperature", "Temperature of the part"}};
  for (const auto& [name, meaning] : kMeaning) {
    if (in.name == name) return meaning;
  }
  return "";
}

json Los(const LineOfSightSplit& s) {
  return json{{"u_radial", s.u_radial},
              {"u_horizontal", s.u_horizontal},
              {"u_vertical", s.u_vertical},
              {"directions", Columns(s.directions)}};
}

json McmOut(const McmOutputResult& m) {
  return json{
      {"name", m.name},
      {"unit", m.unit},
      {"value_at_estimates", m.value_at_estimates},
      {"mean", m.mean},
      {"u", m.u},
      {"symmetric_interval", {m.symmetric.low, m.symmetric.high}},
      {"shortest_interval", {m.shortest.low, m.shortest.high}},
      // vlt/mcm.h: null when not estimated or the tail is bounded (no finite number).
      {"tail_index", m.tail_index && std::isfinite(*m.tail_index) ? json(*m.tail_index) : json(nullptr)},
      {"infinite_variance", m.infinite_variance},
      {"numerical_accuracy",
       {{"s_mean", m.accuracy.s_mean},
        {"s_u", m.accuracy.s_u},
        {"s_low", m.accuracy.s_low},
        {"s_high", m.accuracy.s_high},
        {"delta", m.accuracy.delta}}},
      {"histogram", m.histogram.counts.empty() ? json(nullptr)
                                               : json{{"low", m.histogram.low},
                                                      {"width", m.histogram.width},
                                                      {"counts", m.histogram.counts},
                                                      {"below", m.histogram.below},
                                                      {"above", m.histogram.above}}}};
}

// ScalarValidation::trials_to_decide: null when not inconclusive (0).
json TrialsToDecideJson(double trials) { return trials > 0.0 ? json(trials) : json(nullptr); }

json Scalar(const ScalarValidation& v) {
  return json{{"name", v.name},
              {"unit", v.unit},
              {"gum_y", v.gum_y},
              {"gum_u", v.gum_u},
              {"gum_U", v.gum_expanded},
              {"mcm_low", v.mcm_low},
              {"mcm_high", v.mcm_high},
              {"d_low", v.d_low},
              {"d_high", v.d_high},
              {"delta", v.delta},
              {"mcm_tolerance", v.mcm_tolerance},
              {"trials_to_decide", TrialsToDecideJson(v.trials_to_decide)},
              {"validated", v.validated},
              {"outcome", v.outcome},
              {"verdict", v.verdict}};
}

// The refractive index of the job's air (docs/results.md inputs.air): phase and group index at
// the estimates with their standard uncertainties. The range correction of the measurement model
// uses the phase index n (docs/gum.md).
// The correlation groups as given (name, inputs, matrix) and the parameters' block of the shared
// correlation (null when the parameters are independent of each other).
json CorrelationGroupsJson(const MeasurementSetup& s) {
  json groups = json::array();
  for (const CorrelationGroup& g : s.correlations) {
    groups.push_back({{"name", g.name}, {"inputs", g.inputs}, {"matrix", Mat(g.matrix)}});
  }
  return groups;
}

json ParameterCorrelationJson(const MeasurementSetup& s) {
  if (s.correlations.empty()) return nullptr;
  const int p = static_cast<int>(s.params.size());
  const Eigen::MatrixXd r = SharedCorrelation(SharedInputNames(s), s.correlations).topLeftCorner(p, p);
  return r.isIdentity(0.0) ? json(nullptr) : Mat(r);
}

json AirJson(const MeasurementSetup& s) {
  if (!s.environment) return nullptr;
  const Environment& e = *s.environment;
  const double u[4] = {e.temperature.u, e.pressure.u, e.humidity.u, e.co2.u};
  const AirEquation equation = EquationOf(e);
  const AirIndexReport r = AirIndexWithUncertainty(equation, AirAtEstimates(e), u);
  return json{{"equation", std::string(AirEquationName(equation))},
              {"n_phase", r.n_phase},
              {"u_n_phase", r.u_phase},
              {"n_group", r.n_group},
              {"u_n_group", r.u_group},
              {"ranging", std::string(RangingName(s.ranging))},
              {"range_correction_uses", IndexOf(s.ranging) == RangingIndex::kPhase ? "n_phase" : "n_group"}};
}

// The practical unit of an input (what its practical sensitivity is per: "um/arcsec" -> "arcsec")
// and the factor from its SI value to it.
std::string PracticalInputUnit(const std::string& input_unit) {
  const std::string per = results_internal::PracticalSensitivity(input_unit).first;
  // (std::find, not string::find: GCC 12 warns of a bogus memchr bound where this is inlined.)
  const auto slash = std::find(per.begin(), per.end(), '/');
  return slash == per.end() ? per : std::string(slash + 1, per.end());
}
double PracticalInputScale(const std::string& input_unit) {
  return 1e6 / results_internal::PracticalSensitivity(input_unit).second;
}

json Budget(const BudgetRow& b) {
  return json{
      {"input", b.input},
      {"group", b.group},
      {"unit", b.input_unit},
      {"estimate", b.estimate},
      {"u", b.u},
      {"sensitivity", Vec(b.sensitivity)},
      {"sensitivity_unit", b.sensitivity_unit},
      {"sensitivity_practical",
       b.group == "correlation"
           ? json(nullptr)
           : Vec(b.sensitivity * results_internal::PracticalSensitivity(b.input_unit).second)},
      {"sensitivity_practical_unit",
       b.group == "correlation" ? std::string() : results_internal::PracticalSensitivity(b.input_unit).first},
      // The estimate and u in the unit the practical sensitivity is per (arcsec, ppm, hPa, ...), so
      // that c u in um can be checked by hand from one row (issue 34).
      {"practical_unit", b.group == "correlation" ? std::string() : PracticalInputUnit(b.input_unit)},
      {"estimate_practical", b.group == "correlation" ? json(nullptr) : json(b.estimate * PracticalInputScale(b.input_unit))},
      {"u_practical", b.group == "correlation" ? json(nullptr) : json(b.u * PracticalInputScale(b.input_unit))},
      {"contribution", Vec(b.contribution)},
      {"variance", Vec(b.variance)},
      {"share", Vec(b.share)},
      {"share_total", b.share_total}};
}

// One point's detail (g: its full GUM result, PointDetails): a line of points.jsonl (without its
// budget: the rows are in budget.csv) or an element of the report's points (with its budget).
json Point(const Results& r, const PointResult& p, const PointUncertainty& g, bool with_budget) {
  json j;
  j["name"] = p.input.name;
  j["face"] = std::string(FaceName(p.input.face));
  j["readings"] = {{"range", g.readings[0]}, {"azimuth", g.readings[1]}, {"elevation", g.readings[2]}};
  j["nominal"] = r.mode == JobMode::kPlan ? Vec(p.input.nominal) : json(nullptr);
  json gum;
  gum["estimate"] = Vec(g.part);
  gum["covariance"] = Mat(g.cov_part);
  gum["u"] = Vec(g.u_part);
  gum["k"] = g.k;
  gum["U"] = Vec(g.U_part);
  gum["U_norm"] = g.U_part.norm();
  gum["ellipsoid"] = {{"k", g.ellipsoid.k},
                      {"semi_axes", Vec(g.ellipsoid.semi_axes)},
                      {"directions", Columns(g.ellipsoid.directions)}};
  gum["line_of_sight"] = Los(g.los_part);
  gum["tracker_frame"] = {{"estimate", Vec(g.tracker)},
                          {"covariance", Mat(g.cov_tracker)},
                          {"u", Vec(g.u_tracker)},
                          {"line_of_sight", Los(g.los_tracker)}};
  gum["correlation_handling"] = r.correlation_handling;
  // JCGM 100 5.1.2 note: second-order variance per coordinate, its ratio to u^2, and the flag.
  gum["second_order"] = {{"variance", Vec(g.second_order_variance)},
                         {"ratio", Vec(g.second_order_ratio)},
                         {"threshold", kSecondOrderThreshold},
                         {"reliable", g.gum_reliable},
                         {"decided", g.second_order_decided}};
  j["gum"] = gum;
  if (with_budget) {
    json rows = json::array();
    for (const BudgetRow& b : g.budget) rows.push_back(Budget(b));
    j["budget"] = rows;
  }
  if (p.has_mcm) {
    const PointMcm& m = *p.monte_carlo;
    json axes = json::array();
    for (int a = 0; a < 3; ++a) axes.push_back(McmOut(m.axes[a]));
    j["mcm"] = {{"mean", Vec(m.mcm.mean)},
                {"covariance", Mat(m.mcm.covariance)},
                {"correlation", Mat(m.mcm.correlation)},
                {"has_region", m.mcm.has_region},
                {"coverage_factor", m.mcm.coverage_factor},
                {"axes", axes}};
    json av = json::array();
    for (int a = 0; a < 3; ++a) av.push_back(Scalar(m.axis_validation[a]));
    const PointValidation& v = m.region_validation;
    j["validation"] = {{"axes", av},
                       {"region",
                        {{"gum_coverage_factor", v.gum_coverage_factor},
                         {"mcm_coverage_factor", v.mcm_coverage_factor},
                         {"coverage_factor_ratio", v.coverage_factor_ratio},
                         {"covariance_difference", v.covariance_difference},
                         {"worst_ratio", v.worst_ratio},
                         {"worst_direction", Vec(v.worst_direction)},
                         {"worst_distance", v.worst_distance},
                         {"worst_delta", v.worst_delta},
                         {"mcm_tolerance", v.mcm_tolerance},
                         {"trials_to_decide", TrialsToDecideJson(v.trials_to_decide)},
                         {"validated", v.validated},
                         {"outcome", v.outcome},
                         {"verdict", v.verdict}}},
                       {"validated", p.validated},
                       {"verdict", p.outcome}};
  } else {
    j["mcm"] = nullptr;
    j["validation"] = nullptr;
  }
  return j;
}

json Task(const TaskResult& t) {
  json j;
  j["name"] = t.spec.name;
  j["kind"] = std::string(TaskKindName(t.spec.kind));
  // A fit weighted by its points' covariance (docs/tasks.md): r^T W r at its solution and the
  // residual rows less the parameters.
  j["weighting"] = t.spec.weighted ? "covariance" : "none";
  if (t.spec.weighted) {
    j["weighted_fit"] = {{"chi2", t.gum.chi2}, {"degrees_of_freedom", t.gum.degrees_of_freedom}};
  }
  // `points = "all"` stays "all" (a scan's task would list every point name again).
  j["points"] = t.spec.all_points ? json("all") : json(t.spec.points);
  j["quantities"] = t.gum.quantities;
  j["units"] = t.gum.units;
  // Deviation / position: the point, its nominal position and normal and its alignment (the
  // report's deviation map; docs/results.md tasks[].nominal).
  if ((t.spec.kind == TaskKind::kDeviation || t.spec.kind == TaskKind::kPosition) && t.spec.nominal &&
      t.spec.nominal->point >= 0) {
    const NominalGeometry& g = *t.spec.nominal;
    j["nominal"] = {{"point", t.spec.points[static_cast<std::size_t>(g.point)]},
                    {"position", Vec(g.positions.col(g.point))},
                    {"normal", Vec(g.normal)},
                    {"alignment", g.alignment}};
  }
  j["gum"] = {{"value", Vec(t.gum.value)},
              {"covariance", Mat(t.gum.covariance)},
              {"u", Vec(t.gum.u)},
              {"k", t.gum.k},
              {"U", Vec(t.gum.U)}};
  json groups = json::array();
  for (const TaskGroupContribution& g : t.gum.budget) {
    groups.push_back({{"group", g.group}, {"variance", Vec(g.variance)}, {"share", Vec(g.share)}});
  }
  j["budget_by_group"] = groups;
  json inputs = json::array();
  for (std::size_t s = 0; s < t.gum.shared_input_names.size(); ++s) {
    if (static_cast<Eigen::Index>(s) >= t.gum.shared_input_variance.cols()) break;
    inputs.push_back({{"input", t.gum.shared_input_names[s]},
                      {"variance", Vec(t.gum.shared_input_variance.col(static_cast<Eigen::Index>(s)))}});
  }
  if (t.gum.shared_input_variance.cols() == static_cast<Eigen::Index>(t.gum.shared_input_names.size()) + 1) {
    inputs.push_back(
        {{"input", "correlations"},
         {"variance", Vec(t.gum.shared_input_variance.col(t.gum.shared_input_variance.cols() - 1))}});
  }
  j["budget_by_shared_input"] = inputs;
  if (t.has_mcm) {
    json m = json::array(), v = json::array();
    for (const McmOutputResult& o : t.mcm) m.push_back(McmOut(o));
    for (const ScalarValidation& s : t.validation) v.push_back(Scalar(s));
    j["mcm"] = m;
    j["validation"] = {{"quantities", v}, {"validated", t.validated}, {"verdict", t.outcome}};
  } else {
    j["mcm"] = nullptr;
    j["validation"] = nullptr;
  }
  // ISO 14253-1 / JCGM 106 per quantity with a tolerance (docs/conformity.md); SI units.
  json conformity = json::array();
  for (std::size_t q = 0; q < t.conformity.size(); ++q) {
    if (!t.conformity[q]) continue;
    const ConformityDecision& d = *t.conformity[q];
    const Tolerance tol = *t.spec.ToleranceOf(t.gum.quantities[q]);
    auto limit = [](double v) { return std::isinf(v) ? json(nullptr) : json(v); };
    conformity.push_back(
        {{"quantity", t.gum.quantities[q]},
         {"tolerance", {limit(tol.lower), limit(tol.upper)}},
         {"decision_rule", d.probability_gum ? "ISO 14253-1:2017 guard band w = U"
                           : d.probability_mcm
                               ? "Monte Carlo shortest coverage interval inside the tolerance (no GUM value)"
                               : "none: no GUM value and no Monte Carlo"},
         {"verdict", d.verdict},
         {"guard_band", d.guard_band},
         {"probability_gum", d.probability_gum ? json(*d.probability_gum) : json(nullptr)},
         {"probability_mcm", d.probability_mcm ? json(*d.probability_mcm) : json(nullptr)}});
  }
  j["conformity"] = conformity;
  return j;
}

json Map(const MapResult& m) {
  json j;
  j["kind"] = m.settings.kind == MapSettings::Kind::kPlane ? "plane" : "box";
  j["description"] = m.settings.description;
  j["quantity"] = m.quantity;
  j["fixed_axis"] = m.settings.kind == MapSettings::Kind::kPlane
                        ? json(std::string(1, "xyz"[m.settings.fixed_axis]))
                        : json(nullptr);
  j["min"] = Vec(m.settings.min);
  j["max"] = Vec(m.settings.max);
  j["step"] = m.settings.step;
  Eigen::Vector3i c = m.settings.counts();
  j["counts"] = {c[0], c[1], c[2]};
  j["coverage_probability"] = m.coverage_probability;
  j["k"] = m.k;
  // Row-major grid (x fastest): null where a node was skipped.
  json un = json::array(), ux = json::array(), uy = json::array(), uz = json::array();
  for (std::size_t i = 0; i < m.nodes.size(); ++i) {
    if (m.computed[i]) {
      un.push_back(m.U_norm[i]);
      ux.push_back(m.U[i].x());
      uy.push_back(m.U[i].y());
      uz.push_back(m.U[i].z());
    } else {
      un.push_back(nullptr);
      ux.push_back(nullptr);
      uy.push_back(nullptr);
      uz.push_back(nullptr);
    }
  }
  j["value_name"] = m.value_name;
  j["U_norm"] = un;
  j["U_x"] = ux;
  j["U_y"] = uy;
  j["U_z"] = uz;
  j["skipped"] = m.skipped;
  auto values = [&](const std::vector<double>& v) {
    json a = json::array();
    for (std::size_t i = 0; i < m.nodes.size(); ++i) a.push_back(m.computed[i] ? json(v[i]) : json(nullptr));
    return a;
  };
  // Per-source layers (docs/results.md): in results.json and the HTML only while the grid is
  // small enough to draw (kMaxMapLayerValues); map.csv has them always.
  const bool layers =
      (m.sources.size() + m.groups.size()) * m.nodes.size() <= results_internal::kMaxMapLayerValues;
  j["layers_included"] = layers;
  json groups = json::array(), sources = json::array();
  if (layers) {
    for (const MapResult::Layer& g : m.groups) groups.push_back({{"name", g.name}, {"U", values(g.U)}});
    for (const MapResult::Layer& l : m.sources)
      sources.push_back({{"name", l.name}, {"group", l.group}, {"U", values(l.U)}});
  }
  j["groups"] = groups;
  j["sources"] = sources;
  json dominant = json::array();
  if (layers && !m.sources.empty()) {
    for (std::size_t i = 0; i < m.nodes.size(); ++i)
      dominant.push_back(m.computed[i] ? json(m.dominant[i]) : json(nullptr));
  }
  j["dominant"] = dominant;
  if (m.has_mcm) {
    json mc;
    mc["trials"] = m.mcm_trials;
    mc["seed"] = m.mcm_seed;
    mc["U_norm"] = values(m.U_norm_mcm);
    json verdict = json::array();
    for (std::size_t i = 0; i < m.nodes.size(); ++i)
      verdict.push_back(m.computed[i] ? json(m.verdict[i]) : json(nullptr));
    mc["verdict"] = verdict;
    j["monte_carlo"] = mc;
  } else {
    j["monte_carlo"] = nullptr;
  }
  json markers = json::array();
  for (const MapResult::Marker& k : m.markers) {
    markers.push_back(
        {{"name", k.name}, {"position", Vec(k.position)}, {"kind", k.point ? "point" : "station"}});
  }
  j["markers"] = markers;
  return j;
}

json JobJson(const Results& r) {
  json job = {{"name", r.job_name},     {"description", r.job_description},
              {"file", r.job_file},     {"mode", r.mode == JobMode::kPlan ? "plan" : "readings"},
              {"model", r.model_name},  {"coverage_probability", r.coverage_probability},
              {"k_axis", r.k_axis},     {"k_region", r.k_region},
              {"n_dig", r.n_dig},       {"points", r.points.size()},
              {"tasks", r.tasks.size()}};
  json files = json::array();
  for (const InputFile& f : r.input_files)
    files.push_back({{"role", f.role}, {"path", f.path}, {"sha256", f.sha256}});
  job["input_files"] = files;
  job["record"] = output_internal::RecordJson(r.record);
  // Where the tracker's error parameters came from (docs/calibration.md): null = the model's
  // defaults and the job's [tracker.parameters].
  job["calibration"] = nullptr;
  if (r.calibration) {
    job["calibration"] = {{"file", r.calibration->file},
                          {"sha256", r.calibration->sha256},
                          {"instrument", r.calibration->instrument},
                          {"created", r.calibration->created},
                          {"kind", r.calibration->kind}};
  }
  return job;
}

json InputsJson(const Results& r) {
  const MeasurementSetup& s = r.setup;
  json shared = json::array();
  for (const UncertainInput& in : r.shared_inputs) {
    json j_in = Input(in);
    j_in["description"] = InputDescription(s, in);
    shared.push_back(std::move(j_in));
  }
  return {{"noise",
           {{"range_a", s.noise.range_a},
            {"range_b", s.noise.range_b},
            {"azimuth", s.noise.azimuth},
            {"elevation", s.noise.elevation}}},
          {"shared", shared},
          {"parameter_correlation", ParameterCorrelationJson(s)},
          {"correlations", CorrelationGroupsJson(s)},
          {"environment_equation",
           s.environment ? json(std::string(AirEquationName(EquationOf(*s.environment)))) : json(nullptr)},
          {"vacuum_wavelength", s.environment ? json(s.environment->vacuum_wavelength) : json(nullptr)},
          {"air", AirJson(s)},
          {"part_reference_temperature", s.thermal ? json(s.thermal->reference) : json(nullptr)}};
}

json MonteCarloJson(const Results& r) {
  if (!r.has_mcm) return {{"enabled", false}};
  return {{"enabled", true},
          {"seed", r.mcm.seed},
          {"trials", r.mcm.trials},
          {"adaptive", r.mcm.adaptive},
          {"converged", r.mcm.converged},
          {"batch_size", r.mcm.batch_size},
          {"batches", r.mcm.batches},
          {"threads", r.mcm.threads},
          {"ranks", r.mcm.ranks},
          {"device", r.mcm.device},
          {"device_note", r.mcm.device_note.empty() ? json(nullptr) : json(r.mcm.device_note)},
          {"seconds", r.mcm.seconds},
          {"interval_method", r.mcm.interval_method},
          {"n_dig", r.n_dig},
          {"convergence", r.mcm.convergence_trials.empty() ? json(nullptr)
                                                           : json{{"trials", r.mcm.convergence_trials},
                                                                  {"worst_ratio", r.mcm.convergence_ratio}}}};
}

// Chunks of the points for the summaries below: 128 of them whatever the count (8 for each of 16
// threads; a scan's 10^6 records are 384 MB to read).
std::size_t SummaryChunk(const Results& r) { return std::max<std::size_t>(1, (r.points.size() + 127) / 128); }

// The points of a scan that report.html shows in full: the kReportDetailedPoints with the largest
// |U| (equal |U|: the first in job order), in job order. The largest of each chunk side by side,
// then the largest of those: the same points whatever the thread count.
std::vector<std::size_t> LargestPoints(const Results& r) {
  constexpr std::size_t kShown = results_internal::kReportDetailedPoints;
  std::vector<double> norm(r.points.size());
  auto larger = [&](std::size_t a, std::size_t b) { return norm[a] != norm[b] ? norm[a] > norm[b] : a < b; };
  const std::size_t chunk = SummaryChunk(r);
  std::vector<std::vector<std::size_t>> largest((r.points.size() + chunk - 1) / chunk);
  parallel_internal::ForEachChunk(r.points.size(), chunk, r.threads, [&](std::size_t c, std::size_t b, std::size_t e) {
    std::vector<std::size_t>& order = largest[c];
    order.reserve(e - b);
    for (std::size_t i = b; i < e; ++i) {
      norm[i] = r.points[i].gum.U_part().norm();
      order.push_back(i);
    }
    const std::size_t keep = std::min(kShown, order.size());
    std::partial_sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(keep), order.end(), larger);
    order.resize(keep);
  });
  std::vector<std::size_t> order;
  for (const std::vector<std::size_t>& l : largest) order.insert(order.end(), l.begin(), l.end());
  const std::size_t keep = std::min(kShown, order.size());
  std::partial_sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(keep), order.end(), larger);
  order.resize(keep);
  std::sort(order.begin(), order.end());
  return order;
}

// The points serialised into the document, and for a scan in report.html its overview.
std::vector<std::size_t> PointsShown(const Results& r, bool for_html, json& j) {
  std::vector<std::size_t> point_indices;
  if (for_html && r.points.size() > results_internal::kReportDetailedPoints) {
    // A scan in report.html (docs/results.md "report.html"): the points with the largest |U| in
    // full (table, budgets, ellipsoids), an overview of at most kReportOverviewPoints points
    // (every s-th, in job order) for the 3-D plot; every point stays in points.csv / budget.csv.
    point_indices = LargestPoints(r);
    const std::size_t stride = (r.points.size() + results_internal::kReportOverviewPoints - 1) /
                               results_internal::kReportOverviewPoints;
    json ox = json::array(), oy = json::array(), oz = json::array(), ou = json::array();
    for (std::size_t i = 0; i < r.points.size(); i += stride) {
      const PointGum& g = r.points[i].gum;
      ox.push_back(g.part.x());
      oy.push_back(g.part.y());
      oz.push_back(g.part.z());
      ou.push_back(g.U_part().norm());
    }
    j["points_total"] = r.points.size();
    j["points_overview"] = {{"every", stride}, {"x", ox}, {"y", oy}, {"z", oz}, {"U_norm", ou}};
  } else {
    point_indices.resize(r.points.size());
    for (std::size_t i = 0; i < point_indices.size(); ++i) point_indices[i] = i;
  }
  return point_indices;
}

json SummaryJson(const Results& r) {
  // Largest u and U over the axes, largest |U| and the last point that has it, per chunk side by
  // side, then over the chunks in order: the same as one pass in job order.
  struct Largest {
    double u = 0.0, axis = 0.0, norm = 0.0;
    std::size_t worst = 0;
    bool any = false;
  };
  const std::size_t chunk = SummaryChunk(r);
  std::vector<Largest> largest((r.points.size() + chunk - 1) / chunk);
  parallel_internal::ForEachChunk(r.points.size(), chunk, r.threads, [&](std::size_t c, std::size_t b, std::size_t e) {
    Largest& l = largest[c];
    for (std::size_t i = b; i < e; ++i) {
      const PointGum& g = r.points[i].gum;
      const Eigen::Vector3d u = g.u_part(), U = g.U_part();
      l.u = std::max(l.u, u.maxCoeff());
      l.axis = std::max(l.axis, U.maxCoeff());
      if (U.norm() >= l.norm) {
        l.norm = U.norm();
        l.worst = i;
        l.any = true;
      }
    }
  });
  double max_u = 0.0, max_U_norm = 0.0, max_axis = 0.0;
  std::string worst;
  for (const Largest& l : largest) {
    max_u = std::max(max_u, l.u);
    max_axis = std::max(max_axis, l.axis);
    if (l.any && l.norm >= max_U_norm) {
      max_U_norm = l.norm;
      worst = r.points[l.worst].input.name;
    }
  }
  return {{"max_u_axis", max_u},
          {"max_U_axis", max_axis},
          {"max_U_norm", max_U_norm},
          {"worst_point", worst},
          {"validated_points", r.has_mcm ? json(r.validated_points) : json(nullptr)},
          {"validated_tasks", r.has_mcm ? json(r.validated_tasks) : json(nullptr)},
          {"gum_seconds", r.gum_seconds},
          {"mcm_seconds", r.mcm_seconds}};
}

constexpr const char* kPointsPlaceholder = "@@vlt-points@@";

// The document for report.html with the points shown (and their budgets) serialised one at a
// time in place of the placeholder.
std::string WithPoints(const Results& r, const json& j, int indent,
                       const std::vector<std::size_t>& point_indices) {
  // The points' full results and budgets are not held in Results: recomputed for the points drawn.
  const std::vector<PointUncertainty> details = PointDetails(r, point_indices, true, r.threads);
  const std::string outer = j.dump(indent, ' ', false, json::error_handler_t::replace);
  const std::string quoted = std::string("\"") + kPointsPlaceholder + "\"";
  const std::size_t at = outer.find(quoted);
  if (at == std::string::npos) throw std::logic_error("results.json: points placeholder missing");
  // "points" is a member of the top-level object: its elements sit two levels deep.
  const std::string pad = indent >= 0 ? std::string(static_cast<std::size_t>(2 * indent), ' ') : "";
  const std::string close_pad = indent >= 0 ? std::string(static_cast<std::size_t>(indent), ' ') : "";
  std::string text;
  text.reserve(outer.size() + point_indices.size() * 4096);
  text.append(outer, 0, at);
  if (point_indices.empty()) {
    text += "[]";
  } else {
    text += indent >= 0 ? "[\n" : "[";
    for (std::size_t n = 0; n < point_indices.size(); ++n) {
      std::string one = Point(r, r.points[point_indices[n]], details[n], true)
                            .dump(indent, ' ', false, json::error_handler_t::replace);
      if (indent >= 0) {
        text += pad;
        for (char c : one) {
          text += c;
          if (c == '\n') text += pad;
        }
        text += n + 1 < point_indices.size() ? ",\n" : "\n";
      } else {
        text += one;
        if (n + 1 < point_indices.size()) text += ',';
      }
    }
    text += indent >= 0 ? close_pad + "]" : "]";
  }
  text.append(outer, at + quoted.size(), std::string::npos);
  return text;
}

}  // namespace

std::string results_internal::ResultsJsonText(const Results& r, int indent, bool for_html) {
  json j;
  j["schema"] = "vlt-results/2";
  j["vlt_version"] = r.vlt_version;
  j["vlt_commit"] = r.vlt_commit;
  j["created"] = r.created;
  j["units"] = {{"length", "m"},   {"angle", "rad"}, {"temperature", "degC"},          {"pressure", "Pa"},
                {"humidity", "%"}, {"ratio", "1"},   {"expansion_coefficient", "1/K"}, {"time", "s"}};
  j["job"] = JobJson(r);
  j["inputs"] = InputsJson(r);
  j["monte_carlo"] = MonteCarloJson(r);
  // The points are serialised one at a time into the text below (never one document of every
  // point: its DOM was most of a scan's memory); here a placeholder holds their place.
  const std::vector<std::size_t> point_indices = PointsShown(r, for_html, j);
  if (for_html) {
    j["points"] = kPointsPlaceholder;
  } else {
    // vlt-results/2: one line per point, in job order; none in the compact detail, where
    // points.csv has one compact row per point and points.npy (when asked) the full detail.
    const bool full = r.detail != PointDetail::kCompact;
    j["points_file"] = full ? json("points.jsonl") : json(nullptr);
    j["point_detail"] = full ? "full" : "compact";
    j["points_array"] = r.arrays ? json("points.npy") : json(nullptr);
  }
  json tasks = json::array();
  for (const TaskResult& t : r.tasks) tasks.push_back(Task(t));
  j["tasks"] = tasks;
  // Each headline task quantity's result as JCGM 100 7.2 states it (results/statement.cc).
  json statements = json::array();
  for (const results_internal::ResultStatement& st : results_internal::ResultStatements(r)) {
    statements.push_back({{"task", st.task}, {"quantity", st.quantity}, {"text", st.text}});
  }
  j["statements"] = statements;
  j["map"] = r.map ? Map(*r.map) : json(nullptr);
  j["summary"] = SummaryJson(r);
  if (for_html) j["report"] = {{"ellipsoid_scale", r.ellipsoid_scale}};
  if (!for_html) return j.dump(indent, ' ', false, json::error_handler_t::replace) + "\n";
  return ScriptSafe(WithPoints(r, j, indent, point_indices));
}

std::string ResultsJson(const Results& r, int indent) {
  return results_internal::ResultsJsonText(r, indent, false);
}

void WritePointsJsonl(const Results& r, OutputText& out) {
  results_internal::WritePointDetails(
      r, out, false, [&](std::size_t first, std::span<const PointUncertainty> points, std::string& text) {
        for (std::size_t i = 0; i < points.size(); ++i) {
          text += Point(r, r.points[first + i], points[i], false).dump(-1, ' ', false, json::error_handler_t::replace);
          text += '\n';
        }
      });
}

std::string PointsJsonl(const Results& r) {
  StringText text;
  WritePointsJsonl(r, text);
  return std::move(text.text());
}

std::string MapJson(const MapResult& map, int indent) { return Map(map).dump(indent); }

}  // namespace vlt
