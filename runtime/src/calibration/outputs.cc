// calibration/outputs.cc — the files of `vlt test` and `vlt calibrate` (outputs.h). CSVs and
// results.json are SI with the unit in every column name; the reports show display units
// (um, arcsec, ppm) and say so. Schema: docs/calibration.md "Outputs".
#include "base/toml_text.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <filesystem>
#include <sstream>

#include <nlohmann/json.hpp>

#include "output/assets.h"
#include "output/page.h"
#include "calibration/internal.h"
#include "vlt/calibration.h"
#include "vlt/models.h"
#include "base/format.h"

namespace vlt::calibration_outputs {

using output_internal::ScriptJson;

using output_internal::Page;

namespace {

using base_internal::Fixed;
using base_internal::HtmlEscape;
using base_internal::HumanUnit;
using base_internal::Num;
std::string Csv(const std::string& s) { return base_internal::CsvField(s); }

constexpr double kArcsec = std::numbers::pi / (180.0 * 3600.0);

// Sensitivity unit of a test error (um) per display unit of the parameter.
std::string PerUnit(const std::string& quantity, const std::string& si_unit) {
  return "um/" + DisplayUnit(quantity, si_unit).first;
}

nlohmann::json JsonMatrix(const Eigen::MatrixXd& m) {
  nlohmann::json rows = nlohmann::json::array();
  for (Eigen::Index i = 0; i < m.rows(); ++i) {
    nlohmann::json row = nlohmann::json::array();
    for (Eigen::Index j = 0; j < m.cols(); ++j) row.push_back(m(i, j));
    rows.push_back(row);
  }
  return rows;
}

std::string TestsCsv(const std::vector<TestResult>& results) {
  std::ostringstream os;
  os << "test,kind,reference_m,range_max_m,error_m,u_m,U_m,k,u_parameters_m,mpe_m,verdict,"
        "two_face_x_m,two_face_y_m,two_face_z_m,two_face_radial_m,two_face_transverse_m\n";
  for (const TestResult& r : results) {
    os << Csv(r.name) << ',' << TestKindName(r.kind) << ',' << Num(r.reference) << ',' << Num(r.range_max)
       << ',' << Num(r.error) << ',' << Num(r.u) << ',' << Num(r.U) << ',' << Num(r.k) << ','
       << Num(r.u_parameters) << ',' << (r.verdict.empty() ? "" : Num(r.mpe)) << ',' << r.verdict;
    if (r.kind == TestKind::kTwoFace) {
      os << ',' << Num(r.two_face.x()) << ',' << Num(r.two_face.y()) << ',' << Num(r.two_face.z()) << ','
         << Num(r.two_face_radial) << ',' << Num(r.two_face_transverse) << '\n';
    } else {
      os << ",,,,,\n";
    }
  }
  return os.str();
}

// Sensitivity table: test error per unit of each parameter, in um per display unit.
std::string SensitivityCsv(const ModelInfo& model, const std::vector<TestResult>& results) {
  const int P = model.num_params;
  std::ostringstream os;
  os << "test,kind";
  for (int k = 0; k < P; ++k) {
    os << ',' << model.params[k].name << '_' << PerUnit(model.params[k].quantity, model.params[k].unit);
  }
  os << '\n';
  for (const TestResult& r : results) {
    os << Csv(r.name) << ',' << TestKindName(r.kind);
    for (int k = 0; k < P; ++k) {
      const double per = DisplayUnit(model.params[k].quantity, model.params[k].unit).second;
      os << ',' << Num(r.sensitivity(k) * 1e6 / per);
    }
    os << '\n';
  }
  return os.str();
}

// Parameters no test sees: the largest effect of one prior u on any test below 1 nm.
nlohmann::json ParametersNoTestSees(const TestJob& job, const std::vector<TestResult>& results) {
  const ModelInfo& model = *job.tracker.model;
  const int P = model.num_params;
  std::vector<double> never_seen(P, 0.0);
  for (const TestResult& r : results) {
    for (int k = 0; k < P; ++k)
      never_seen[k] = std::max(never_seen[k], std::abs(r.sensitivity(k)) * job.tracker.params[k].u);
  }
  nlohmann::json unseen = nlohmann::json::array();
  for (int k = 0; k < P; ++k) {
    if (never_seen[k] < 1e-9) unseen.push_back(model.params[k].name);
  }
  return unseen;
}

std::string TestResultsJson(const TestJob& job, const std::vector<TestResult>& results,
                            const nlohmann::json& unseen) {
  const ModelInfo& model = *job.tracker.model;
  const int P = model.num_params;
  nlohmann::json j;
  j["schema"] = "vlt-test/1";
  j["vlt_version"] = VLT_VERSION;
  j["job"] = {{"name", job.name},
              {"file", job.file},
              {"model", model.name},
              {"layout", job.layout.name},
              {"layout_file", job.layout.where},
              {"layout_source", job.layout.source}};
  nlohmann::json params = nlohmann::json::array();
  for (int k = 0; k < P; ++k) {
    params.push_back({{"name", model.params[k].name},
                      {"unit", model.params[k].unit},
                      {"quantity", model.params[k].quantity},
                      {"estimate", job.tracker.params[k].estimate},
                      {"u", job.tracker.params[k].u}});
  }
  j["parameters"] = params;
  nlohmann::json tests = nlohmann::json::array();
  for (const TestResult& r : results) {
    nlohmann::json t = {{"name", r.name},
                        {"kind", TestKindName(r.kind)},
                        {"reference", r.reference},
                        {"range_max", r.range_max},
                        {"error", r.error},
                        {"u", r.u},
                        {"U", r.U},
                        {"k", r.k},
                        {"u_parameters", r.u_parameters},
                        {"verdict", r.verdict}};
    if (!r.verdict.empty()) t["mpe"] = r.mpe;
    if (r.kind == TestKind::kTwoFace) {
      t["two_face"] = {r.two_face.x(), r.two_face.y(), r.two_face.z()};
      t["two_face_radial"] = r.two_face_radial;
      t["two_face_transverse"] = r.two_face_transverse;
    }
    t["sensitivity"] = std::vector<double>(r.sensitivity.data(), r.sensitivity.data() + P);
    tests.push_back(t);
  }
  j["tests"] = tests;
  j["parameters_no_test_sees"] = unseen;
  return j.dump(1) + "\n";
}

// The tracker's error state and u, the layout, and the count of passes and failures.
void TrackerAndLayoutSection(std::ostringstream& body, const TestJob& job,
                             const std::vector<TestResult>& results, const nlohmann::json& unseen) {
  const ModelInfo& model = *job.tracker.model;
  const int P = model.num_params;
  int pass = 0, fail = 0;
  for (const TestResult& r : results) {
    pass += r.verdict == "pass";
    fail += r.verdict == "fail";
  }
  body << "<section><h2>Tracker and layout</h2><p>Model <b>" << HtmlEscape(model.name) << "</b>; layout <b>"
       << HtmlEscape(job.layout.name) << "</b> (" << HtmlEscape(job.layout.source) << ").</p><p>"
       << results.size() << " tests";
  if (pass + fail)
    body << ": <span class=\"ok\">" << pass << " pass</span>, <span class=\"" << (fail ? "bad" : "ok")
         << "\">" << fail << " fail</span>";
  body << ". Error = reported minus reference (length, ranging) or the two-face separation |p<sub>back</sub> "
          "− p<sub>front</sub>|. "
          "U: expanded uncertainty of the test itself (reading noise and reference standard, k = "
       << Fixed(results.empty() ? 2.0 : results[0].k, 2)
       << "). u(params): the spread of the error that the parameters' standard "
          "uncertainties imply. MPE = a + b·R with R the largest range to the test's targets.</p>";
  if (!unseen.empty()) {
    body << "<p class=\"bad\">No test sees: ";
    for (std::size_t i = 0; i < unseen.size(); ++i)
      body << (i ? ", " : "") << HtmlEscape(unseen[i].get<std::string>());
    body << "</p>";
  }
  // Every parameter named in words beside its symbol (the model spec's description; issue 34).
  body << "<table><tr><th class=\"l\">parameter</th><th>error state</th><th>u</th><th "
          "class=\"l\">unit</th><th class=\"l\">meaning</th></tr>";
  for (int k = 0; k < P; ++k) {
    const auto [unit, per] = DisplayUnit(model.params[k].quantity, model.params[k].unit);
    body << "<tr><td class=\"l\">" << HtmlEscape(model.params[k].name) << "</td><td>"
         << Fixed(job.tracker.params[k].estimate * per, 3) << "</td><td>"
         << Fixed(job.tracker.params[k].u * per, 3) << "</td><td class=\"l\">" << HumanUnit(unit)
         << "</td><td class=\"l\">" << HtmlEscape(model.params[k].description) << "</td></tr>";
  }
  body << "</table></section>\n";
}

void TestsTable(std::ostringstream& body, const std::vector<TestResult>& results) {
  body << "<section><h2>Tests</h2><table><tr><th class=\"l\">test</th><th class=\"l\">kind</th><th>reference "
          "/ mm</th>"
          "<th>R max / m</th><th>error / µm</th><th>U / µm</th><th>u(params) / µm</th><th>MPE / µm</th><th "
          "class=\"l\">verdict</th>"
          "<th>two-face radial / µm</th><th>transverse / µm</th></tr>";
  for (const TestResult& r : results) {
    body << "<tr><td class=\"l\">" << HtmlEscape(r.name) << "</td><td class=\"l\">" << TestKindName(r.kind)
         << "</td><td>" << (r.kind == TestKind::kTwoFace ? "" : Fixed(r.reference * 1e3, 4)) << "</td><td>"
         << Fixed(r.range_max, 3) << "</td><td>" << Fixed(r.error * 1e6, 2) << "</td><td>"
         << Fixed(r.U * 1e6, 2) << "</td><td>" << Fixed(r.u_parameters * 1e6, 2) << "</td><td>"
         << (r.verdict.empty() ? "" : Fixed(r.mpe * 1e6, 1)) << "</td><td class=\"l "
         << (r.verdict == "fail" ? "bad" : "ok") << "\">" << r.verdict << "</td><td>"
         << (r.kind == TestKind::kTwoFace ? Fixed(r.two_face_radial * 1e6, 2) : "") << "</td><td>"
         << (r.kind == TestKind::kTwoFace ? Fixed(r.two_face_transverse * 1e6, 2) : "") << "</td></tr>";
  }
  body << "</table></section>\n";
}

// Which test sees which parameter: |d error / d parameter| as a heatmap.
void SensitivityHeatmap(std::ostringstream& body, std::ostringstream& script, const ModelInfo& model,
                        const std::vector<TestResult>& results) {
  const int P = model.num_params;
  body << "<section><h2>Sensitivity: which test sees which parameter</h2><p class=\"note\">|d error / d "
          "parameter| "
          "in µm per µm, µm per arcsec, µm per ppm (sensitivity.csv has the signs of length and ranging "
          "tests; two-face rows are magnitudes). A column without colour is a parameter "
          "that no test of this layout sees.</p><div id=\"sens\" class=\"plot\" style=\"height:"
       << 200 + 9 * results.size() << "px\"></div></section>\n";
  nlohmann::json z = nlohmann::json::array(), x = nlohmann::json::array(), y = nlohmann::json::array();
  for (int k = 0; k < P; ++k) {
    x.push_back(std::string(model.params[k].name) + " (" +
                HumanUnit(PerUnit(model.params[k].quantity, model.params[k].unit)) + ")");
  }
  for (const TestResult& r : results) {
    y.push_back(r.name);
    nlohmann::json row = nlohmann::json::array();
    for (int k = 0; k < P; ++k)
      row.push_back(std::abs(r.sensitivity(k)) * 1e6 /
                    DisplayUnit(model.params[k].quantity, model.params[k].unit).second);
    z.push_back(row);
  }
  script << "Plotly.newPlot('sens',[{type:'heatmap',colorscale:'Viridis',x:" << ScriptJson(x) << ",y:" << ScriptJson(y)
         << ",z:" << ScriptJson(z)
         << ",hovertemplate:'%{y}<br>%{x}: "
            "%{z:.4g}<extra></extra>'}],{margin:{l:140,b:140},yaxis:{autorange:'reversed',dtick:1,tickfont:{size:8}}},"
            "{responsive:true}).then(done);";
}

std::string SimulatedReadingsCsv(const CalibrationData& simulated) {
  std::ostringstream csv;
  csv << "target,range,azimuth,elevation,face\n";
  for (const TargetReading& r : simulated.readings) {
    csv << Csv(r.target) << ',' << Num(r.readings(0)) << ',' << Num(r.readings(1)) << ','
        << Num(r.readings(2)) << ',' << FaceName(r.face) << '\n';
  }
  return csv.str();
}

// simulated_calibration.toml: the simulated tracker's test data, ready for `vlt calibrate`.
std::string SimulatedCalibrationToml(const TestJob& job, const CalibrationData& simulated) {
  const ModelInfo& model = *job.tracker.model;
  const int P = model.num_params;
  std::ostringstream t;
  t << "# Simulated calibration data written by `vlt test` from "
    << std::filesystem::path(job.file).filename().string() << " (seed " << job.seed << ").\n"
    << "# Run it with:  vlt calibrate simulated_calibration.toml\n"
    << "# The true error state of the simulated tracker (SI), to compare with the calibration:\n";
  for (int k = 0; k < P; ++k)
    t << "#   " << model.params[k].name << " = " << Num(job.tracker.params[k].estimate) << " "
      << model.params[k].unit << "\n";
  using base_internal::TomlQuoted;
  t << "# Values without a unit are SI (m, rad). Every key: docs/calibration.md.\n\n[job]\nname = "
    << TomlQuoted(job.name + "-calibration") << "\n\n[calibration]\ninstrument = "
    << TomlQuoted("simulated " + std::string(model.name) + " tracker (vlt test, seed " +
                  std::to_string(job.seed) + ")")
    << "\n\n[tracker]\nmodel = " << TomlQuoted(model.name)
    << "   # priors: the model's defaults\n\n[tracker.noise]\n"
    << "range_a = " << Num(simulated.noise.range_a) << "\nrange_b = " << Num(simulated.noise.range_b)
    << "\nazimuth = " << Num(simulated.noise.azimuth) << "\nelevation = " << Num(simulated.noise.elevation)
    << "\n\n[readings]\ncsv = \"simulated_readings.csv\"\ncolumns = { name = \"target\" }\n";
  for (const ReferenceBar& bar : simulated.bars) {
    t << "\n[[bar]]\nname = " << TomlQuoted(bar.name) << "\nlength = " << Num(bar.length)
      << "   # calibrated value, m\nu = " << Num(bar.u) << "\nu_position = " << Num(bar.u_position)
      << "\npositions = [\n";
    for (const auto& [a, b] : bar.positions) t << "  [" << TomlQuoted(a) << ", " << TomlQuoted(b) << "],\n";
    t << "]\n";
  }
  for (const ReferenceDistance& d : simulated.distances) {
    t << "\n[[reference]]\nfrom = " << TomlQuoted(d.from) << "\nto = " << TomlQuoted(d.to)
      << "\nlength = " << Num(d.length) << "\nu = " << Num(d.u) << "\n";
  }
  return t.str();
}

std::string ParametersCsv(const CalibrationResult& result) {
  std::ostringstream os;
  os << "parameter,unit,status,estimate,u,U,k,u_data,prior_estimate,prior_u,display_unit,estimate_display,U_"
        "display\n";
  for (const CalibratedParameter& p : result.parameters) {
    const auto [unit, per] = DisplayUnit(p.quantity, p.unit);
    os << p.name << ',' << p.unit << ',' << ParameterStatusName(p.status) << ',' << Num(p.estimate) << ','
       << Num(p.u) << ',' << Num(result.k * p.u) << ',' << Num(result.k) << ',' << Num(p.u_data) << ','
       << Num(p.prior_estimate) << ',' << Num(p.prior_u) << ',' << unit << ',' << Num(p.estimate * per) << ','
       << Num(result.k * p.u * per) << '\n';
  }
  return os.str();
}

std::string CorrelationCsv(const CalibrationResult& result) {
  const int P = static_cast<int>(result.parameters.size());
  std::ostringstream os;
  os << "parameter";
  for (const CalibratedParameter& p : result.parameters) os << ',' << p.name;
  os << '\n';
  for (int i = 0; i < P; ++i) {
    os << result.parameters[i].name;
    for (int k = 0; k < P; ++k) os << ',' << Num(result.correlation(i, k));
    os << '\n';
  }
  return os.str();
}

std::string IdentifiabilityCsv(const CalibrationResult& result) {
  std::ostringstream os;
  os << "index,singular_value,data_u_over_prior_u";
  for (const std::string& name : result.free_parameters) os << ',' << name;
  os << '\n';
  for (Eigen::Index i = 0; i < result.singular_values.size(); ++i) {
    const double s = result.singular_values(i);
    os << i + 1 << ',' << Num(s) << ',' << (s > 0 ? Num(1.0 / s) : "inf");
    for (Eigen::Index f = 0; f < result.singular_vectors.rows(); ++f)
      os << ',' << Num(result.singular_vectors(f, i));
    os << '\n';
  }
  return os.str();
}

std::string TargetsCsv(const CalibrationResult& result) {
  std::ostringstream os;
  os << "target,readings,x_m,y_m,z_m,u_x_m,u_y_m,u_z_m\n";
  for (const CalibratedTarget& t : result.targets) {
    os << Csv(t.name) << ',' << t.readings << ',' << Num(t.position.x()) << ',' << Num(t.position.y()) << ','
       << Num(t.position.z());
    for (int a = 0; a < 3; ++a) os << ',' << Num(std::sqrt(std::max(0.0, t.covariance(a, a))));
    os << '\n';
  }
  return os.str();
}

std::string ResidualsCsv(const CalibrationResult& result) {
  std::ostringstream os;
  os << "observation,where,unit,residual,u,normalised,redundancy,w,outlier\n";
  for (const CalibrationResidual& r : result.residuals) {
    os << Csv(r.observation) << ',' << Csv(r.where) << ',' << r.unit << ',' << Num(r.residual) << ','
       << Num(r.u) << ',' << Num(r.normalised) << ',' << Num(r.redundancy) << ',' << Num(r.w) << ','
       << (r.outlier ? "yes" : "no") << '\n';
  }
  return os.str();
}

std::string CalibrationResultsJson(const CalibrationJob& job, const CalibrationResult& result,
                                   const CalibrationProvenance& provenance) {
  nlohmann::json j;
  j["schema"] = "vlt-calibration/1";
  j["vlt_version"] = VLT_VERSION;
  j["job"] = {{"name", job.name},
              {"file", job.file},
              {"model", result.model},
              {"instrument", provenance.instrument},
              {"created", provenance.created}};
  nlohmann::json data_files = nlohmann::json::array();
  for (const auto& [file, sha] : provenance.data_files)
    data_files.push_back({{"file", file}, {"sha256", sha}});
  j["data_files"] = data_files;
  nlohmann::json params = nlohmann::json::array();
  for (const CalibratedParameter& p : result.parameters) {
    params.push_back({{"name", p.name},
                      {"unit", p.unit},
                      {"quantity", p.quantity},
                      {"status", ParameterStatusName(p.status)},
                      {"estimate", p.estimate},
                      {"u", p.u},
                      {"u_data", p.u_data},
                      {"prior_estimate", p.prior_estimate},
                      {"prior_u", p.prior_u}});
  }
  j["parameters"] = params;
  j["covariance"] = JsonMatrix(result.covariance);
  j["correlation"] = JsonMatrix(result.correlation);
  nlohmann::json held = nlohmann::json::array();
  for (const HeldCombination& h : result.held) {
    nlohmann::json terms = nlohmann::json::object();
    for (const auto& [name, c] : h.terms) terms[name] = c;
    held.push_back({{"terms", terms},
                    // null: the data do not determine it (as the network's results.json says it).
                    {"ratio", std::isfinite(h.ratio) ? nlohmann::json(h.ratio) : nlohmann::json(nullptr)},
                    {"description", h.description}});
  }
  j["identifiability"] = {
      {"free_parameters", result.free_parameters},
      {"singular_values", std::vector<double>(result.singular_values.data(),
                                              result.singular_values.data() + result.singular_values.size())},
      {"condition_number",
       std::isfinite(result.condition_number) ? nlohmann::json(result.condition_number) : nlohmann::json(nullptr)},
      {"held", held}};
  j["fit"] = {{"observations", result.observations},
              {"unknowns", result.unknowns},
              {"dof", result.dof},
              {"chi2", result.chi2},
              {"birge_ratio", result.birge_ratio},
              {"p_value", result.p_value},
              {"outliers", result.outliers},
              {"iterations", result.iterations},
              {"k", result.k},
              {"fits", CalibrationFitProblem(result).empty()},
              {"fit_problem", CalibrationFitProblem(result)}};
  return j.dump(1) + "\n";
}

// What was calibrated from which data (with their SHA-256), and how well the fit closes.
void ProvenanceSection(std::ostringstream& body, const CalibrationResult& result,
                       const CalibrationProvenance& provenance) {
  body << "<section><h2>Calibration</h2><p>Model <b>" << HtmlEscape(result.model) << "</b>, instrument <b>"
       << HtmlEscape(provenance.instrument.empty() ? "(not named)" : provenance.instrument)
       << "</b>, computed " << HtmlEscape(provenance.created)
       << ".</p><table><tr><th class=\"l\">data file</th><th class=\"l\">SHA-256</th></tr>";
  for (const auto& [file, sha] : provenance.data_files)
    body << "<tr><td class=\"l\">" << HtmlEscape(file) << "</td><td class=\"l\">" << sha << "</td></tr>";
  body << "</table><p>" << result.observations << " observations, " << result.unknowns << " unknowns, "
       << result.dof << " degrees of freedom; χ² = " << Fixed(result.chi2, 1) << ", Birge ratio "
       << Fixed(result.birge_ratio, 3) << " (p = " << Fixed(result.p_value, 3) << "); <span class=\""
       << (result.outliers ? "bad" : "ok") << "\">" << result.outliers
       << " outliers</span> (|w| above the limit).</p></section>\n";
}

// The error parameters: table and plot of estimate and prior with their U.
void ParametersSection(std::ostringstream& body, std::ostringstream& script,
                       const CalibrationResult& result) {
  const int P = static_cast<int>(result.parameters.size());
  body << "<section><h2>Error parameters</h2><p class=\"note\">U = k·u with k = " << Fixed(result.k, 2)
       << ". identified: determined by the data; held: not determined by the data, prior kept; partly: mixes "
          "both; fixed: prior kept "
          "on purpose. u(data): the part the data determine.</p><table><tr><th class=\"l\">parameter</th><th "
          "class=\"l\">status</th>"
          "<th>estimate</th><th>U</th><th>u(data)</th><th>prior</th><th>prior u</th><th "
          "class=\"l\">unit</th><th class=\"l\">meaning</th></tr>";
  // Every parameter named in words beside its symbol (the model spec's description; issue 34).
  const ModelInfo* model = FindModel(result.model);
  nlohmann::json names = nlohmann::json::array(), est = nlohmann::json::array(),
                 err = nlohmann::json::array(), prior = nlohmann::json::array();
  for (const CalibratedParameter& p : result.parameters) {
    const auto [unit, per] = DisplayUnit(p.quantity, p.unit);
    const bool id = p.status == ParameterStatus::kIdentified;
    body << "<tr><td class=\"l\">" << HtmlEscape(p.name) << "</td><td class=\"l " << (id ? "ok" : "na")
         << "\">" << ParameterStatusName(p.status) << "</td><td>" << Fixed(p.estimate * per, 3) << "</td><td>"
         << Fixed(result.k * p.u * per, 3) << "</td><td>" << Fixed(p.u_data * per, 3) << "</td><td>"
         << Fixed(p.prior_estimate * per, 3) << "</td><td>" << Fixed(p.prior_u * per, 3)
         << "</td><td class=\"l\">" << HumanUnit(unit) << "</td><td class=\"l\">"
         << HtmlEscape(calibration_internal::ParameterMeaning(model, p.name)) << "</td></tr>";
    names.push_back(p.name + " (" + HumanUnit(unit) + ")");
    est.push_back(p.estimate * per);
    err.push_back(result.k * p.u * per);
    prior.push_back(result.k * p.prior_u * per);
  }
  body << "</table><div id=\"params\" class=\"plot\"></div></section>\n";
  script << "Plotly.newPlot('params',[{type:'bar',name:'prior ±U',x:" << ScriptJson(names)
         << ",y:" << ScriptJson(nlohmann::json(std::vector<double>(P, 0.0)))
         << ",error_y:{type:'data',array:" << ScriptJson(prior)
         << ",color:'#aaa'},marker:{color:'rgba(0,0,0,0)'}},{type:'scatter',mode:'markers',"
            "name:'estimate ±U',x:"
         << ScriptJson(names) << ",y:" << ScriptJson(est) << ",error_y:{type:'data',array:" << ScriptJson(err)
         << "}}],{margin:{b:140},yaxis:{title:'µm, arcsec, ppm'}},{responsive:true}).then(done);";
}

void IdentifiabilitySection(std::ostringstream& body, const CalibrationResult& result) {
  body << "<section><h2>Identifiability</h2><p>Condition number of the "
          "prior-scaled, reduced Jacobian: "
       << (std::isinf(result.condition_number) ? std::string("infinite") : Fixed(result.condition_number, 1))
       << ". Combinations the data do not determine (held at their prior; coefficients of "
          "p/u<sub>prior</sub>):</p><ul>";
  if (result.held.empty()) body << "<li>none: the data determine every fitted parameter</li>";
  for (const HeldCombination& h : result.held) body << "<li>" << HtmlEscape(h.description) << "</li>";
  body << "</ul></section>\n";
}

// The 25 largest residuals by |w|.
void LargestResiduals(std::ostringstream& body, const CalibrationResult& result) {
  body << "<section><h2>Largest residuals</h2><table><tr><th class=\"l\">observation</th><th "
          "class=\"l\">where</th>"
          "<th>residual</th><th class=\"l\">unit</th><th>w</th><th>redundancy</th><th "
          "class=\"l\">outlier</th></tr>";
  std::vector<const CalibrationResidual*> sorted;
  for (const CalibrationResidual& r : result.residuals) sorted.push_back(&r);
  std::sort(sorted.begin(), sorted.end(), [](auto* a, auto* b) { return std::abs(a->w) > std::abs(b->w); });
  for (std::size_t i = 0; i < std::min<std::size_t>(sorted.size(), 25); ++i) {
    const CalibrationResidual& r = *sorted[i];
    const bool angle = r.unit == "rad";
    body << "<tr><td class=\"l\">" << HtmlEscape(r.observation) << "</td><td class=\"l\">"
         << HtmlEscape(r.where) << "</td><td>" << Fixed(r.residual * (angle ? 1.0 / kArcsec : 1e6), 3)
         << "</td><td class=\"l\">" << (angle ? "arcsec" : "µm") << "</td><td>" << Fixed(r.w, 2)
         << "</td><td>" << Fixed(r.redundancy, 3) << "</td><td class=\"l " << (r.outlier ? "bad" : "")
         << "\">" << (r.outlier ? "yes" : "") << "</td></tr>";
  }
  body << "</table><p class=\"note\">All residuals: residuals.csv.</p></section>\n";
}

}  // namespace

std::pair<std::string, double> DisplayUnit(const std::string& quantity, const std::string& si_unit) {
  if (quantity == "length") return {"um", 1e6};
  if (quantity == "angle") return {"arcsec", 1.0 / kArcsec};
  if (quantity == "ratio") return {"ppm", 1e6};
  return {si_unit, 1.0};
}

// ------------------------------------------------------------------------------------------------
// vlt test

Files TestFiles(const TestJob& job, const std::vector<TestResult>& results,
                const CalibrationData* simulated) {
  const ModelInfo& model = *job.tracker.model;
  Files files;
  files.emplace_back("tests.csv", TestsCsv(results));
  files.emplace_back("sensitivity.csv", SensitivityCsv(model, results));
  const nlohmann::json unseen = ParametersNoTestSees(job, results);
  files.emplace_back("results.json", TestResultsJson(job, results, unseen));

  // report.html
  std::ostringstream body, script;
  TrackerAndLayoutSection(body, job, results, unseen);
  TestsTable(body, results);
  SensitivityHeatmap(body, script, model, results);
  files.emplace_back("report.html", Page("vlt test — " + job.name, "Standard tests on a virtual tracker",
                                         body.str(), script.str()));

  if (simulated) {
    files.emplace_back("simulated_readings.csv", SimulatedReadingsCsv(*simulated));
    files.emplace_back("simulated_calibration.toml", SimulatedCalibrationToml(job, *simulated));
  }
  return files;
}

std::string TestSummary(const TestJob& job, const std::vector<TestResult>& results) {
  std::ostringstream os;
  int pass = 0, fail = 0;
  double worst = 0.0;
  std::string worst_name;
  for (const TestResult& r : results) {
    if (r.verdict == "pass") ++pass;
    if (r.verdict == "fail") ++fail;
    if (std::abs(r.error) > worst) {
      worst = std::abs(r.error);
      worst_name = r.name;
    }
  }
  os << job.name << ": " << results.size() << " tests of layout '" << job.layout.name << "' on a "
     << job.tracker.model->name << " tracker; largest |error| " << Fixed(worst * 1e6, 2) << " µm ("
     << worst_name << ")";
  if (pass + fail) os << "; " << pass << " pass, " << fail << " fail against the MPE";
  os << "\n";
  return os.str();
}

// ------------------------------------------------------------------------------------------------
// vlt calibrate

Files CalibrationFiles(const CalibrationJob& job, const CalibrationResult& result,
                       const CalibrationProvenance& provenance) {
  Files files;
  files.emplace_back("calibration.toml", CalibrationFileToml(result, provenance));
  files.emplace_back("parameters.csv", ParametersCsv(result));
  files.emplace_back("correlation.csv", CorrelationCsv(result));
  files.emplace_back("identifiability.csv", IdentifiabilityCsv(result));
  files.emplace_back("targets.csv", TargetsCsv(result));
  files.emplace_back("residuals.csv", ResidualsCsv(result));
  files.emplace_back("results.json", CalibrationResultsJson(job, result, provenance));

  std::ostringstream body, script;
  ProvenanceSection(body, result, provenance);
  ParametersSection(body, script, result);
  IdentifiabilitySection(body, result);
  LargestResiduals(body, result);
  files.emplace_back("report.html",
                     Page("vlt calibrate — " + job.name, "Error parameters identified from test data",
                          body.str(), script.str()));
  return files;
}

std::string CalibrationSummary(const CalibrationJob& job, const CalibrationResult& result) {
  std::ostringstream os;
  int identified = 0;
  for (const CalibratedParameter& p : result.parameters)
    identified += p.status == ParameterStatus::kIdentified;
  os << job.name << ": " << result.model << " tracker, " << result.observations << " observations; "
     << identified << " of " << result.parameters.size() << " parameters identified, " << result.held.size()
     << " combinations held at their prior; Birge ratio " << Fixed(result.birge_ratio, 3) << ", "
     << result.outliers << " outliers\n";
  for (const CalibratedParameter& p : result.parameters) {
    const auto [unit, per] = DisplayUnit(p.quantity, p.unit);
    char line[512];
    // The unit padded by columns ("µm" is two bytes, one column), and beside U too (none for "1").
    const std::string shown_unit = unit == "1" ? std::string() : HumanUnit(unit);
    std::snprintf(line, sizeof line, "  %-8s %-10s %10s %s  U = %s%s%s\n", p.name.c_str(),
                  ParameterStatusName(p.status), Fixed(p.estimate * per, 3).c_str(),
                  base_internal::PadColumns(shown_unit, 6, true).c_str(), Fixed(result.k * p.u * per, 3).c_str(),
                  shown_unit.empty() ? "" : " ", shown_unit.c_str());
    os << line;
  }
  for (const HeldCombination& h : result.held) os << "  held: " << h.description << "\n";
  return os.str();
}

}  // namespace vlt::calibration_outputs
