// calibration/prior_outputs.cc — the files of `vlt prior` (vlt/calibration.h PriorFiles;
// docs/profiles.md "Outputs"): the prior file a job loads, the parameters, the tests' budgets.
#include <cstdio>
#include <map>
#include <sstream>

#include <nlohmann/json.hpp>

#include "base/format.h"
#include "base/toml_text.h"
#include "calibration/internal.h"
#include "output/page.h"
#include "vlt/calibration.h"
#include "vlt/models.h"

namespace vlt::calibration_outputs {

namespace {

using base_internal::Fixed;
using base_internal::HtmlEscape;
using base_internal::HumanUnit;
using base_internal::Num;
using output_internal::Page;
using output_internal::ScriptJson;
using base_internal::TomlQuoted;
std::string Csv(const std::string& s) { return base_internal::CsvField(s); }

// The reading noise's share of a test's u^2 (0 for a test without any spread).
double NoiseShare(const PriorTest& t) { return t.u > 0.0 ? t.u_noise * t.u_noise / (t.u * t.u) : 0.0; }

// A TOML float that reads back as the same double (never a TOML integer).
std::string TomlFloat(double v) {
  std::string s = Num(v);
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
  return s;
}

std::string PriorFileToml(const PriorJob& job, const PriorResult& result, const CalibrationProvenance& provenance) {
  std::ostringstream os;
  os << "# vlt prior file: error-parameter uncertainties derived by `vlt prior` from a datasheet's MPE\n"
        "# statements (docs/profiles.md): NOT a calibration of any instrument. Load it in a job with\n"
        "#   [tracker]\n#   calibration = \"<this file>\"\n"
        "# Values are SI (m, rad, 1); u is the standard uncertainty. status: from_mpe (set by the\n"
        "# statements), at_bound (the statements allow more; the bound decides), not_constrained (the\n"
        "# statements say nothing about it: the generic u kept), fixed (u = 0).\n\n";
  os << "[calibration]\n";
  os << "kind = \"prior from MPE\"\n";
  os << "model = " << TomlQuoted(result.model) << "\n";
  os << "instrument = " << TomlQuoted(provenance.instrument) << "\n";
  os << "created = " << TomlQuoted(provenance.created) << "\n";
  os << "vlt_version = " << TomlQuoted(provenance.vlt_version) << "\n";
  os << "profile = " << TomlQuoted(job.name) << "\n";
  os << "conformance_probability = " << TomlFloat(job.settings.conformance_probability) << "\n";
  os << "bound = " << TomlFloat(job.settings.bound) << "\n";
  os << "layout = " << TomlQuoted(job.layout.name) << "\n";
  os << "fits = true\n\n";
  for (const auto& [file, sha] : provenance.data_files) {
    os << "[[calibration.data_file]]\nfile = " << TomlQuoted(file) << "\nsha256 = " << TomlQuoted(sha) << "\n\n";
  }
  for (const auto& [what, citation] : job.sources) {
    os << "[[calibration.source]]\nstatement = " << TomlQuoted(what) << "\ncitation = " << TomlQuoted(citation)
       << "\n\n";
  }
  for (const PriorParameter& p : result.parameters) {
    os << "[[parameter]]\n";
    os << "name = " << TomlQuoted(p.name) << "\n";
    os << "unit = " << TomlQuoted(p.unit) << "\n";
    os << "estimate = " << TomlFloat(p.estimate) << "\n";
    os << "u = " << TomlFloat(p.u) << "\n";
    os << "status = " << TomlQuoted(PriorStatusName(p.status)) << "\n";
    os << "prior_estimate = " << TomlFloat(p.estimate) << "\n";
    os << "prior_u = " << TomlFloat(p.u0) << "\n\n";
  }
  os << "[correlation]\n# independent: the datasheet states no correlation\nmatrix = [\n";
  for (std::size_t i = 0; i < result.parameters.size(); ++i) {
    os << "  [";
    for (std::size_t j = 0; j < result.parameters.size(); ++j) os << (j ? ", " : "") << (i == j ? "1.0" : "0.0");
    os << "],\n";
  }
  os << "]\n";
  return SealCalibrationText(os.str());
}

std::string PriorParametersCsv(const PriorResult& result) {
  std::ostringstream os;
  os << "parameter,unit,status,estimate,u,u_generic,bound,display_unit,u_display\n";
  for (const PriorParameter& p : result.parameters) {
    const auto [unit, per] = DisplayUnit(p.quantity, p.unit);
    os << Csv(p.name) << ',' << Csv(p.unit) << ',' << PriorStatusName(p.status) << ',' << Num(p.estimate) << ','
       << Num(p.u) << ',' << Num(p.u0) << ',' << Num(p.bound) << ',' << Csv(unit) << ',' << Num(p.u * per) << '\n';
  }
  return os.str();
}

std::string PriorTestsCsv(const PriorResult& result) {
  std::ostringstream os;
  os << "test,kind,range_max_m,mpe_m,u_noise_m,u_parameters_m,u_m,conformance_probability,binding\n";
  for (const PriorTest& t : result.tests) {
    os << Csv(t.name) << ',' << TestKindName(t.kind) << ',' << Num(t.range_max) << ',' << Num(t.mpe) << ','
       << Num(t.u_noise) << ',' << Num(t.u_parameters) << ',' << Num(t.u) << ',' << Num(t.conformance) << ','
       << (t.binding ? "true" : "false") << '\n';
  }
  return os.str();
}

// Each parameter's share of each test's u^2 (the reading noise's is the rest).
std::string PriorSharesCsv(const PriorResult& result) {
  std::ostringstream os;
  os << "test";
  for (const PriorParameter& p : result.parameters) os << ',' << Csv(p.name);
  os << ",noise\n";
  for (const PriorTest& t : result.tests) {
    os << Csv(t.name);
    for (Eigen::Index k = 0; k < t.share.size(); ++k) os << ',' << Num(t.share(k));
    os << ',' << Num(NoiseShare(t)) << '\n';
  }
  return os.str();
}

std::string PriorResultsJson(const PriorJob& job, const PriorResult& result, const CalibrationProvenance& provenance) {
  nlohmann::json j;
  j["schema"] = "vlt-prior/1";
  j["vlt_version"] = provenance.vlt_version;
  j["profile"] = {{"name", job.name},
                  {"file", job.file},
                  {"instrument", provenance.instrument},
                  {"created", provenance.created},
                  {"model", result.model},
                  {"layout", job.layout.name},
                  {"conformance_probability", job.settings.conformance_probability},
                  {"bound", job.settings.bound},
                  {"z", result.z}};
  nlohmann::json sources = nlohmann::json::array();
  for (const auto& [what, citation] : job.sources) sources.push_back({{"statement", what}, {"citation", citation}});
  j["sources"] = sources;
  nlohmann::json params = nlohmann::json::array();
  for (const PriorParameter& p : result.parameters) {
    params.push_back({{"name", p.name},
                      {"unit", p.unit},
                      {"status", PriorStatusName(p.status)},
                      {"estimate", p.estimate},
                      {"u", p.u},
                      {"u_generic", p.u0},
                      {"bound", p.bound}});
  }
  j["parameters"] = params;
  nlohmann::json tests = nlohmann::json::array();
  for (const PriorTest& t : result.tests) {
    nlohmann::json share = nlohmann::json::array();
    for (Eigen::Index k = 0; k < t.share.size(); ++k) share.push_back(t.share(k));
    tests.push_back({{"name", t.name},
                     {"kind", TestKindName(t.kind)},
                     {"range_max_m", t.range_max},
                     {"mpe_m", t.mpe},
                     {"u_noise_m", t.u_noise},
                     {"u_parameters_m", t.u_parameters},
                     {"u_m", t.u},
                     {"conformance_probability", t.conformance},
                     {"binding", t.binding},
                     {"share", share}});
  }
  j["tests"] = tests;
  return j.dump(1) + "\n";
}

// The report: what the statements were and where they come from, the derived uncertainties, each
// test's budget and conformance, and each parameter's share of each test's budget.
void PriorProvenanceSection(std::ostringstream& body, const PriorJob& job, const PriorResult& result,
                            const CalibrationProvenance& provenance) {
  body << "<section><h2>Prior from a datasheet</h2><p class=\"note\">Uncertainties of the error "
          "parameters under which the simulated standard tests meet every MPE statement below with "
          "probability p: a statement about every instrument that meets this datasheet, <b>not a "
          "calibration of any instrument</b> (docs/profiles.md).</p><p>Profile <b>"
       << HtmlEscape(job.name) << "</b>, instrument <b>"
       << HtmlEscape(provenance.instrument.empty() ? "(not named)" : provenance.instrument) << "</b>, model <b>"
       << HtmlEscape(result.model) << "</b>, layout <b>" << HtmlEscape(job.layout.name) << "</b>; p = "
       << Fixed(job.settings.conformance_probability, 4) << " (z = " << Fixed(result.z, 3) << "), bound "
       << Fixed(job.settings.bound, 1) << " × the generic u; computed " << HtmlEscape(provenance.created)
       << ".</p><table><tr><th class=\"l\">statement</th><th class=\"l\">MPE</th><th class=\"l\">source</th></tr>";
  auto mpe_text = [](const Mpe& m) {
    return m.set ? Fixed(m.a * 1e6, 3) + " µm + " + Fixed(m.b * 1e6, 3) + " µm/m" : std::string("—");
  };
  std::map<std::string, std::string> cited(job.sources.begin(), job.sources.end());
  const std::pair<const char*, const Mpe*> statements[] = {
      {"length", &job.mpe.length}, {"ranging", &job.mpe.ranging}, {"two_face", &job.mpe.two_face}};
  for (const auto& [kind, mpe] : statements) {
    if (!mpe->set && !cited.count(kind)) continue;
    body << "<tr><td class=\"l\">" << kind << "</td><td class=\"l\">" << mpe_text(*mpe) << "</td><td class=\"l\">"
         << HtmlEscape(cited.count(kind) ? cited[kind] : "(no source given)") << "</td></tr>";
    cited.erase(kind);
  }
  for (const auto& [what, citation] : cited)
    body << "<tr><td class=\"l\">" << HtmlEscape(what) << "</td><td class=\"l\"></td><td class=\"l\">"
         << HtmlEscape(citation) << "</td></tr>";
  body << "</table><table><tr><th class=\"l\">file</th><th class=\"l\">SHA-256</th></tr>";
  for (const auto& [file, sha] : provenance.data_files)
    body << "<tr><td class=\"l\">" << HtmlEscape(file) << "</td><td class=\"l\">" << sha << "</td></tr>";
  body << "</table></section>\n";
}

void PriorParametersSection(std::ostringstream& body, const PriorResult& result) {
  body << "<section><h2>Error parameters</h2><p class=\"note\">from_mpe: set by the statements; at_bound: "
          "the statements allow more, the bound decides; not_constrained: the statements say nothing about "
          "it, the generic u is kept; fixed: u = 0.</p><table><tr><th class=\"l\">parameter</th><th "
          "class=\"l\">status</th><th>u</th><th>generic u</th><th>bound</th><th class=\"l\">unit</th><th "
          "class=\"l\">meaning</th></tr>";
  const ModelInfo* model = FindModel(result.model);
  for (const PriorParameter& p : result.parameters) {
    const auto [unit, per] = DisplayUnit(p.quantity, p.unit);
    const std::string meaning = calibration_internal::ParameterMeaning(model, p.name);
    body << "<tr><td class=\"l\">" << HtmlEscape(p.name) << "</td><td class=\"l "
         << (p.status == PriorStatus::kFromMpe ? "ok" : "na") << "\">" << PriorStatusName(p.status) << "</td><td>"
         << Fixed(p.u * per, 3) << "</td><td>" << Fixed(p.u0 * per, 3) << "</td><td>" << Fixed(p.bound * per, 3)
         << "</td><td class=\"l\">" << HtmlEscape(HumanUnit(unit)) << "</td><td class=\"l\">" << HtmlEscape(meaning)
         << "</td></tr>";
  }
  body << "</table></section>\n";
}

void PriorTestsSection(std::ostringstream& body, const PriorResult& result) {
  body << "<section><h2>Tests</h2><p class=\"note\">u: the test's error under the derived prior, the reading "
          "noise and the parameters in quadrature (two-face: square roots of the traces of the covariance of "
          "back − front); conformance: P(|E| ≤ MPE), exact for the Gaussian; binding: the statement holds "
          "with probability p exactly.</p><table><tr><th class=\"l\">test</th><th class=\"l\">kind</th><th>R max / "
          "m</th><th>MPE / µm</th><th>u(noise) / µm</th><th>u(params) / µm</th><th>u / µm</th><th>conformance</th><th "
          "class=\"l\">binding</th></tr>";
  for (const PriorTest& t : result.tests) {
    body << "<tr><td class=\"l\">" << HtmlEscape(t.name) << "</td><td class=\"l\">" << TestKindName(t.kind)
         << "</td><td>" << Fixed(t.range_max, 3) << "</td><td>" << Fixed(t.mpe * 1e6, 2) << "</td><td>"
         << Fixed(t.u_noise * 1e6, 2) << "</td><td>" << Fixed(t.u_parameters * 1e6, 2) << "</td><td>"
         << Fixed(t.u * 1e6, 2) << "</td><td>" << Fixed(t.conformance, 4) << "</td><td class=\"l\">"
         << (t.binding ? "yes" : "") << "</td></tr>";
  }
  body << "</table></section>\n";
}

// Each parameter's share of each test's u^2: where the datasheet's budget goes.
void PriorSharesHeatmap(std::ostringstream& body, std::ostringstream& script, const PriorResult& result) {
  body << "<section><h2>Budget: each parameter's share of each test's u²</h2><p class=\"note\">shares.csv has "
          "the numbers; the last column is the reading noise. A column without colour is a parameter the "
          "statements do not see.</p><div id=\"shares\" class=\"plot\" style=\"height:"
       << 160 + 9 * result.tests.size() << "px\"></div></section>\n";
  nlohmann::json x = nlohmann::json::array(), y = nlohmann::json::array(), z = nlohmann::json::array();
  for (const PriorParameter& p : result.parameters) x.push_back(p.name);
  x.push_back("noise");
  for (const PriorTest& t : result.tests) {
    y.push_back(t.name);
    nlohmann::json row = nlohmann::json::array();
    for (Eigen::Index k = 0; k < t.share.size(); ++k) row.push_back(t.share(k));
    row.push_back(NoiseShare(t));
    z.push_back(row);
  }
  script << "Plotly.newPlot('shares',[{type:'heatmap',colorscale:'Viridis',zmin:0,zmax:1,x:" << ScriptJson(x)
         << ",y:" << ScriptJson(y) << ",z:" << ScriptJson(z)
         << ",hovertemplate:'%{y}<br>%{x}: %{z:.3f}<extra></extra>'}],{margin:{l:140,b:100},"
            "yaxis:{autorange:'reversed',dtick:1,tickfont:{size:8}}},{responsive:true}).then(done);";
}

}  // namespace

Files PriorFiles(const PriorJob& job, const PriorResult& result, const CalibrationProvenance& provenance) {
  Files files;
  files.emplace_back("prior.toml", PriorFileToml(job, result, provenance));
  files.emplace_back("parameters.csv", PriorParametersCsv(result));
  files.emplace_back("tests.csv", PriorTestsCsv(result));
  files.emplace_back("shares.csv", PriorSharesCsv(result));
  files.emplace_back("results.json", PriorResultsJson(job, result, provenance));
  std::ostringstream body, script;
  PriorProvenanceSection(body, job, result, provenance);
  PriorParametersSection(body, result);
  PriorTestsSection(body, result);
  PriorSharesHeatmap(body, script, result);
  files.emplace_back("report.html", Page("vlt prior — " + job.name, "Error-parameter uncertainties from a datasheet",
                                         body.str(), script.str()));
  return files;
}

std::string PriorSummary(const PriorJob& job, const PriorResult& result) {
  std::ostringstream os;
  int binding = 0;
  double lowest = 1.0;
  for (const PriorTest& t : result.tests) {
    binding += t.binding;
    lowest = std::min(lowest, t.conformance);
  }
  os << job.name << ": " << result.model << " tracker, prior from the MPE of "
     << (job.instrument.empty() ? std::string("the datasheet") : "'" + job.instrument + "'") << "; "
     << result.tests.size() << " tests with an MPE (layout '" << job.layout.name << "'), " << binding
     << " binding; lowest conformance probability " << Fixed(lowest, 4) << " (stated "
     << Fixed(job.settings.conformance_probability, 4) << ")\n";
  std::vector<std::string> unconstrained, at_bound;
  for (const PriorParameter& p : result.parameters) {
    const auto [unit, per] = DisplayUnit(p.quantity, p.unit);
    char line[200];
    // The unit padded by columns ("µm" is two bytes, one column).
    std::snprintf(line, sizeof line, "  %-8s %-16s u = %10s %s (generic %s)\n", p.name.c_str(),
                  PriorStatusName(p.status), Fixed(p.u * per, 3).c_str(),
                  base_internal::PadColumns(HumanUnit(unit), 6, true).c_str(), Fixed(p.u0 * per, 3).c_str());
    os << line;
    if (p.status == PriorStatus::kNotConstrained) unconstrained.push_back(p.name);
    if (p.status == PriorStatus::kAtBound) at_bound.push_back(p.name);
  }
  if (!at_bound.empty()) {
    os << "  at their bound (the statements allow more; the bound decides):";
    for (const std::string& n : at_bound) os << ' ' << n;
    os << "\n";
  }
  if (!unconstrained.empty()) {
    os << "  the statements do not constrain:";
    for (const std::string& n : unconstrained) os << ' ' << n;
    os << " (generic u kept)\n";
  }
  return os.str();
}

}  // namespace vlt::calibration_outputs
