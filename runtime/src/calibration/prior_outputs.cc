// calibration/prior_outputs.cc — the files of `vlt prior` (vlt/calibration.h PriorFiles;
// docs/profiles.md "Outputs"): the prior file a job loads, the parameters, the tests' budgets.
#include <cstdio>
#include <sstream>

#include <nlohmann/json.hpp>

#include "base/format.h"
#include "base/toml_text.h"
#include "vlt/calibration.h"

namespace vlt::calibration_outputs {

namespace {

using base_internal::Fixed;
using base_internal::Num;
using base_internal::TomlQuoted;
std::string Csv(const std::string& s) { return base_internal::CsvField(s); }

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
    os << ',' << Num(t.u_noise * t.u_noise / (t.u * t.u)) << '\n';
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

}  // namespace

Files PriorFiles(const PriorJob& job, const PriorResult& result, const CalibrationProvenance& provenance) {
  Files files;
  files.emplace_back("prior.toml", PriorFileToml(job, result, provenance));
  files.emplace_back("parameters.csv", PriorParametersCsv(result));
  files.emplace_back("tests.csv", PriorTestsCsv(result));
  files.emplace_back("shares.csv", PriorSharesCsv(result));
  files.emplace_back("results.json", PriorResultsJson(job, result, provenance));
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
     << result.tests.size() << " tests of layout '" << job.layout.name << "', " << binding
     << " binding; lowest conformance probability " << Fixed(lowest, 4) << " (stated "
     << Fixed(job.settings.conformance_probability, 4) << ")\n";
  std::vector<std::string> unconstrained;
  for (const PriorParameter& p : result.parameters) {
    const auto [unit, per] = DisplayUnit(p.quantity, p.unit);
    char line[200];
    std::snprintf(line, sizeof line, "  %-8s %-16s u = %10s %-6s (generic %s)\n", p.name.c_str(),
                  PriorStatusName(p.status), Fixed(p.u * per, 3).c_str(), unit.c_str(), Fixed(p.u0 * per, 3).c_str());
    os << line;
    if (p.status == PriorStatus::kNotConstrained) unconstrained.push_back(p.name);
  }
  if (!unconstrained.empty()) {
    os << "  the statements do not constrain:";
    for (const std::string& n : unconstrained) os << ' ' << n;
    os << " (generic u kept)\n";
  }
  return os.str();
}

}  // namespace vlt::calibration_outputs
