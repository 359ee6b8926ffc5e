// instrument/calibration_file.cc — the calibration file (vlt/calibration.h; format in docs/calibration.md):
// written by `vlt calibrate`, read by a job's `[tracker] calibration = "<file>"`. Numbers are
// written with 17 significant digits so that the file round-trips the estimates bit for bit.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <set>
#include <sstream>

#include <Eigen/Eigenvalues>
#include <toml++/toml.h>

#include "base/toml_text.h"
#include "base/section.h"
#include "vlt/calibration.h"
#include "vlt/error.h"
#include "vlt/gum.h"
#include "vlt/units.h"

namespace vlt {

namespace {

std::string Exact(double v) {
  char buffer[40];
  std::snprintf(buffer, sizeof buffer, "%.17g", v);
  std::string s = buffer;
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";  // a TOML float, not an integer
  return s;
}

}  // namespace

// The status words of the calibration file (and of every table that shows a parameter).
const char* ParameterStatusName(ParameterStatus status) {
  switch (status) {
    case ParameterStatus::kIdentified: return "identified";
    case ParameterStatus::kPartly: return "partly";
    case ParameterStatus::kHeld: return "held";
    case ParameterStatus::kFixed: return "fixed";
  }
  return "?";
}

std::string CalibrationFitProblem(const CalibrationResult& result) {
  double largest_w = 0.0;
  for (const CalibrationResidual& r : result.residuals) largest_w = std::max(largest_w, std::abs(r.w));
  return FitProblem(result.chi2, result.dof, largest_w, static_cast<int>(result.residuals.size()));
}

// The key of a calibration file's checksum of itself (CalibrationFileToml, LoadCalibrationFile).
constexpr const char* kContentKey = "content_sha256";

std::string CalibrationFileToml(const CalibrationResult& result, const CalibrationProvenance& provenance) {
  std::ostringstream os;
  os << "# vlt calibration file: error parameters of one tracker identified from test data by\n"
        "# `vlt calibrate` (docs/calibration.md). Load it in a job with\n"
        "#   [tracker]\n#   calibration = \"<this file>\"\n"
        "# Values are SI (m, rad, 1); u is the standard uncertainty. status: identified (by the\n"
        "# data), partly (mixes data and prior), held (not determined by the data: prior kept),\n"
        "# fixed (prior kept on purpose). Written by vlt; edit by hand only knowingly.\n\n";
  os << "[calibration]\n";
  os << "model = " << base_internal::TomlQuoted(result.model) << "\n";
  os << "instrument = " << base_internal::TomlQuoted(provenance.instrument) << "\n";
  os << "created = " << base_internal::TomlQuoted(provenance.created) << "\n";
  os << "vlt_version = " << base_internal::TomlQuoted(provenance.vlt_version) << "\n";
  os << "observations = " << result.observations << "\n";
  os << "unknowns = " << result.unknowns << "\n";
  os << "chi2 = " << Exact(result.chi2) << "\n";
  os << "dof = " << result.dof << "\n";
  os << "birge_ratio = " << Exact(result.birge_ratio) << "\n";
  os << "outliers = " << result.outliers << "\n";
  // A calibration that does not fit its data says so; a job that loads it warns (docs/calibration.md).
  const std::string problem = CalibrationFitProblem(result);
  os << "fits = " << (problem.empty() ? "true" : "false") << "\n";
  if (!problem.empty()) os << "fit_problem = " << base_internal::TomlQuoted(problem) << "\n";
  os << "held = [";
  for (std::size_t i = 0; i < result.held.size(); ++i)
    os << (i ? ", " : "") << base_internal::TomlQuoted(result.held[i].description);
  os << "]\n\n";
  for (const auto& [file, sha] : provenance.data_files) {
    os << "[[calibration.data_file]]\nfile = " << base_internal::TomlQuoted(file)
       << "\nsha256 = " << base_internal::TomlQuoted(sha) << "\n\n";
  }
  for (const CalibratedParameter& p : result.parameters) {
    os << "[[parameter]]\n";
    os << "name = " << base_internal::TomlQuoted(p.name) << "\n";
    os << "unit = " << base_internal::TomlQuoted(p.unit) << "\n";
    os << "estimate = " << Exact(p.estimate) << "\n";
    os << "u = " << Exact(p.u) << "\n";
    os << "status = " << base_internal::TomlQuoted(ParameterStatusName(p.status)) << "\n";
    os << "prior_estimate = " << Exact(p.prior_estimate) << "\n";
    os << "prior_u = " << Exact(p.prior_u) << "\n\n";
  }
  os << "[correlation]\n# rows and columns in the order of the [[parameter]] tables\nmatrix = [\n";
  for (Eigen::Index i = 0; i < result.correlation.rows(); ++i) {
    os << "  [";
    for (Eigen::Index j = 0; j < result.correlation.cols(); ++j)
      os << (j ? ", " : "") << Exact(result.correlation(i, j));
    os << "],\n";
  }
  os << "]\n";
  return SealCalibrationText(os.str());
}

// The file's own checksum, over its text without the line that carries it (LoadCalibrationFile):
// a job can tell a file vlt wrote from one edited since.
std::string SealCalibrationText(std::string text) {
  const std::string header = "[calibration]\n";
  text.insert(text.find(header) + header.size(),
              std::string(kContentKey) + " = \"" + Sha256Bytes(text) + "\"\n");
  return text;
}

namespace {

// [calibration] content_sha256 against the SHA-256 of the file's text without the line that
// carries it (the first line that starts with the key).
void CheckContent(const toml::table& root, const std::string& text, const std::string& path,
                  LoadedCalibration& c) {
  const toml::node* node = root["calibration"][kContentKey].node();
  if (!node) return;
  if (!node->is_string()) throw InputError(path + ": calibration." + kContentKey + ": expected a string");
  const std::string recorded(*node->value<std::string>());
  const std::string key = std::string(kContentKey) + " = ";
  std::size_t at = text.compare(0, key.size(), key) == 0 ? 0 : text.find("\n" + key);
  if (at != 0 && at != std::string::npos) ++at;
  if (at == std::string::npos)
    throw InputError(path + ": calibration." + kContentKey + ": not on a line of its own");
  const std::size_t end = text.find('\n', at);
  std::string without = text;
  without.erase(at, end == std::string::npos ? std::string::npos : end - at + 1);
  c.content_checked = true;
  c.edited = Sha256Bytes(without) != recorded;
}

}  // namespace

LoadedCalibration LoadCalibrationFile(const std::string& path) {
  return LoadCalibrationText(base_internal::ReadTextFile(path, "the calibration file"), path);
}

LoadedCalibration LoadCalibrationText(const std::string& file_text, const std::string& path) {
  const toml::table root = base_internal::ParseToml(file_text, path);
  LoadedCalibration c;
  CheckContent(root, file_text, path, c);
  const toml::table* meta = root["calibration"].as_table();
  if (!meta) throw InputError(path + ": calibration: not a vlt calibration file (no [calibration] table)");
  auto text = [&](const toml::table& t, const char* key, const std::string& where) {
    const auto v = t[key].value<std::string>();
    if (!v) throw InputError(where + "." + key + ": required string is missing");
    return *v;
  };
  c.model = text(*meta, "model", path + ": calibration");
  if (auto v = (*meta)["instrument"].value<std::string>()) c.instrument = *v;
  if (auto v = (*meta)["created"].value<std::string>()) c.created = *v;
  if (const toml::node* kind = meta->get("kind")) {
    c.kind = kind->value<std::string>().value_or("");
    if (c.kind != "identified" && c.kind != "prior from MPE")
      throw InputError(path + ": calibration.kind: expected \"identified\" or \"prior from MPE\"");
  }
  if (const toml::node* fits = meta->get("fits")) {
    if (!fits->is_boolean()) throw InputError(path + ": calibration.fits: expected true or false");
    c.fits = fits->value<bool>().value_or(true);
  }
  if (auto v = (*meta)["fit_problem"].value<std::string>()) c.fit_problem = *v;
  const toml::array* params = root["parameter"].as_array();
  if (!params || params->empty()) throw InputError(path + ": parameter: no [[parameter]] tables");
  int index = 0;
  for (const toml::node& node : *params) {
    const std::string where = path + ": parameter[" + std::to_string(index++) + "]";
    const toml::table* t = node.as_table();
    if (!t) throw InputError(where + ": expected a table");
    c.names.push_back(text(*t, "name", where));
    const auto estimate = (*t)["estimate"].value<double>();
    const auto u = (*t)["u"].value<double>();
    if (!estimate || !std::isfinite(*estimate))
      throw InputError(where + ".estimate: expected a finite number");
    if (!u || !std::isfinite(*u) || *u < 0.0) throw InputError(where + ".u: expected a finite number >= 0");
    // The caps a job file's inputs get (base/section.h): beyond them sums of squared sensitivities
    // overflow and the run would end in "the model gives a non-finite result".
    if (std::abs(*estimate) > base_internal::kMaxMagnitude)
      throw InputError(where + ".estimate: beyond what vlt computes with (at most 1e12 in SI units)");
    base_internal::CheckUncertainty(*u, where + ".u");
    c.estimates.push_back(*estimate);
    c.u.push_back(*u);
    const std::string status = (*t)["status"].value<std::string>().value_or("");
    // vlt calibrate's words, and vlt prior's for a prior from a datasheet (PriorStatusName).
    static const std::set<std::string> kStatuses = {"identified", "partly",   "held",           "fixed",
                                                    "from_mpe",   "at_bound", "not_constrained"};
    if (!kStatuses.count(status)) {
      throw InputError(where + ".status: expected identified, partly, held, fixed (a calibration) or from_mpe, "
                               "at_bound, not_constrained (a prior from a datasheet)");
    }
    c.status.push_back(status);
  }
  const int n = static_cast<int>(c.names.size());
  c.correlation = Eigen::MatrixXd::Identity(n, n);
  const toml::array* rows = root["correlation"]["matrix"].as_array();
  const std::string where = path + ": correlation.matrix";
  if (!rows || static_cast<int>(rows->size()) != n)
    throw InputError(where + ": expected " + std::to_string(n) + " rows");
  for (int i = 0; i < n; ++i) {
    const toml::array* row = rows->get(i)->as_array();
    if (!row || static_cast<int>(row->size()) != n)
      throw InputError(where + ": row " + std::to_string(i + 1) + ": expected " + std::to_string(n) +
                       " numbers");
    for (int j = 0; j < n; ++j) {
      const auto v = row->get(j)->value<double>();
      if (!v || !std::isfinite(*v) || std::abs(*v) > 1.0 + 1e-12)
        throw InputError(where + ": row " + std::to_string(i + 1) +
                         ": expected correlation coefficients in [-1, 1]");
      c.correlation(i, j) = *v;
    }
  }
  if (!(c.correlation - c.correlation.transpose()).isZero(1e-12)) throw InputError(where + ": not symmetric");
  for (int i = 0; i < n; ++i) {
    if (std::abs(c.correlation(i, i) - 1.0) > 1e-12)
      throw InputError(where + ": diagonal element " + std::to_string(i + 1) + " is not 1");
  }
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(c.correlation);
  if (eig.eigenvalues().minCoeff() < -1e-10) throw InputError(where + ": not positive semi-definite");
  return c;
}

}  // namespace vlt
