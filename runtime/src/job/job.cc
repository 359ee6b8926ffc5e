// Job file (TOML) -> vlt::Job. The keys and their units are documented in docs/job-file.md;
// keep the two in step. Every table is read through a Section that remembers which keys were
// used, so that a misspelt key is an error instead of a silently ignored input.
#include "vlt/job.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <toml++/toml.h>

#include "csv.h"
#include "job_detail.h"
#include "vlt/distributions.h"
#include "vlt/error.h"
#include "vlt/models.h"
#include "vlt/units.h"

namespace vlt {

std::vector<std::string> Job::point_names() const {
  std::vector<std::string> names;
  names.reserve(points.size());
  for (const JobPoint& p : points) names.push_back(p.name);
  return names;
}

namespace job_detail {

std::string Section::Where(std::string_view key) const {
  if (path_.empty()) return file_ + ": " + std::string(key);
  return file_ + ": " + path_ + "." + std::string(key);
}

std::string Section::WhereSelf() const { return file_ + ": " + (path_.empty() ? "(top)" : path_); }

const toml::node* Section::Get(std::string_view key) {
  used_.insert(std::string(key));
  return table_->get(key);
}

const toml::node& Section::Require(std::string_view key) {
  const toml::node* node = Get(key);
  if (!node) throw InputError(Where(key) + ": required key is missing");
  return *node;
}

void Section::Finish() const {
  for (auto&& [key, node] : *table_) {
    (void)node;
    if (!used_.count(std::string(key.str()))) {
      throw InputError(Where(key.str()) + ": unknown key" +
                       (allowed_hint_.empty() ? "" : " (expected one of: " + allowed_hint_ + ")"));
    }
  }
}

Section Section::Sub(std::string_view key, bool required) {
  const toml::node* node = required ? &Require(key) : Get(key);
  std::string sub_path = path_.empty() ? std::string(key) : path_ + "." + std::string(key);
  if (!node) return Section(file_, sub_path);
  if (!node->is_table()) throw InputError(Where(key) + ": expected a table");
  return Section(*node->as_table(), file_, sub_path);
}

std::string AsString(const toml::node& node, const std::string& where) {
  if (!node.is_string()) throw InputError(where + ": expected a string");
  return std::string(node.value<std::string>().value());
}

bool AsBool(const toml::node& node, const std::string& where) {
  if (!node.is_boolean()) throw InputError(where + ": expected true or false");
  return *node.value<bool>();
}

std::int64_t AsInteger(const toml::node& node, const std::string& where) {
  if (node.is_integer()) return *node.value<std::int64_t>();
  if (node.is_floating_point()) {
    double v = *node.value<double>();
    if (std::isfinite(v) && v == std::floor(v) && std::abs(v) < 9e15) {
      return static_cast<std::int64_t>(v);
    }
  }
  throw InputError(where + ": expected an integer");
}

double AsNumber(const toml::node& node, const std::string& where) {
  if (!node.is_number()) throw InputError(where + ": expected a number");
  double v = *node.value<double>();
  if (!std::isfinite(v)) throw InputError(where + ": not a finite number");
  return v;
}

double AsQuantity(const toml::node& node, Dimension dimension, const std::string& where) {
  if (node.is_string()) return ParseQuantity(*node.value<std::string>(), dimension, where);
  if (node.is_number()) return AsNumber(node, where);
  throw InputError(where + ": expected a " + std::string(DimensionName(dimension)) +
                   " (a string with a unit, e.g. \"12 um\", or a number in " +
                   std::string(SiUnit(dimension)) + ")");
}

Dimension DimensionOfQuantity(std::string_view quantity, const std::string& where) {
  for (Dimension d : {Dimension::kLength, Dimension::kAngle, Dimension::kRatio,
                      Dimension::kTemperature, Dimension::kTemperatureDifference,
                      Dimension::kPressure, Dimension::kHumidity, Dimension::kFraction,
                      Dimension::kPerKelvin, Dimension::kDimensionless, Dimension::kTime}) {
    if (DimensionName(d) == quantity) return d;
  }
  throw InputError(where + ": the model declares an unknown quantity kind '" +
                   std::string(quantity) + "'");
}

}  // namespace job_detail

namespace {

using job_detail::AsBool;
using job_detail::AsInteger;
using job_detail::AsNumber;
using job_detail::AsQuantity;
using job_detail::AsString;
using job_detail::Section;

constexpr double kPi = 3.14159265358979323846;

// The distribution name is parsed by the Monte Carlo engine's parser (vlt/distributions.h) and
// stored in its canonical spelling; the Distribution constructor checks the shape parameter.
void CheckDistribution(UncertainInput& input, const std::string& where_distribution,
                       const std::string& where_shape) {
  DistributionKind kind = ParseDistribution(input.distribution, where_distribution);
  input.distribution = std::string(DistributionName(kind));
  if (!HasShape(kind) && input.shape != 0.0) {
    throw InputError(where_shape + ": distribution '" + input.distribution + "' has no shape parameter");
  }
  (void)Distribution(kind, input.estimate, input.u, input.shape, where_shape);
}

void CheckUncertainty(double u, const std::string& where) {
  if (!std::isfinite(u)) throw InputError(where + ": uncertainty is not finite");
  if (u < 0.0) throw InputError(where + ": negative uncertainty");
}

// An uncertain input: either a table {estimate, u, distribution, shape} (omitted keys keep the
// defaults in `input`) or a bare quantity (the estimate; u keeps its default).
void ReadUncertain(Section& parent, std::string_view key, Dimension value_dim, Dimension u_dim,
                   UncertainInput& input) {
  const toml::node* node = parent.Get(key);
  if (!node) return;
  if (!node->is_table()) {
    input.estimate = AsQuantity(*node, value_dim, parent.Where(key));
    return;
  }
  Section s = parent.Sub(key, false);
  s.set_hint("estimate, u, distribution, shape");
  if (const toml::node* n = s.Get("estimate")) input.estimate = AsQuantity(*n, value_dim, s.Where("estimate"));
  if (const toml::node* n = s.Get("u")) {
    input.u = AsQuantity(*n, u_dim, s.Where("u"));
    CheckUncertainty(input.u, s.Where("u"));
  }
  if (const toml::node* n = s.Get("distribution")) input.distribution = AsString(*n, s.Where("distribution"));
  if (const toml::node* n = s.Get("shape")) input.shape = AsNumber(*n, s.Where("shape"));
  CheckDistribution(input, s.Where("distribution"), s.Where("shape"));
  s.Finish();
}

UncertainInput MakeInput(std::string name, std::string group, Dimension dim, double estimate, double u) {
  UncertainInput input;
  input.name = std::move(name);
  input.unit = std::string(SiUnit(dim));
  input.group = std::move(group);
  input.estimate = estimate;
  input.u = u;
  return input;
}

// "5 um + 0.5 um/m" -> (a, b). Either term may be absent; a '+' inside an exponent is not a split.
void ParseRangeNoise(const std::string& text, const std::string& where, double& a, double& b) {
  std::vector<std::string> terms;
  std::string current;
  for (std::size_t i = 0; i < text.size(); ++i) {
    char c = text[i];
    bool exponent_sign = i > 0 && (text[i - 1] == 'e' || text[i - 1] == 'E') && i >= 2 &&
                         std::isdigit(static_cast<unsigned char>(text[i - 2]));
    if (c == '+' && !exponent_sign && !current.empty() &&
        current.find_first_not_of(" \t") != std::string::npos) {
      terms.push_back(current);
      current.clear();
    } else {
      current += c;
    }
  }
  terms.push_back(current);
  if (terms.size() > 2) throw InputError(where + ": expected '<length> + <ratio>', e.g. \"5 um + 0.5 um/m\"");
  bool have_a = false, have_b = false;
  a = b = 0.0;
  for (const std::string& term : terms) {
    bool is_length = true;
    double v = 0.0;
    try {
      v = ParseQuantity(term, Dimension::kLength, where);
    } catch (const InputError&) {
      is_length = false;
    }
    if (!is_length) {
      try {
        v = ParseQuantity(term, Dimension::kRatio, where);
      } catch (const InputError&) {
        throw InputError(where + ": '" + term + "' is neither a length nor a ratio; expected '<length> + <ratio>', e.g. \"5 um + 0.5 um/m\"");
      }
    }
    bool& have = is_length ? have_a : have_b;
    if (have) throw InputError(where + ": two " + std::string(is_length ? "length" : "ratio") + " terms; expected '<length> + <ratio>'");
    have = true;
    (is_length ? a : b) = v;
  }
  CheckUncertainty(a, where);
  CheckUncertainty(b, where);
}

void ReadTracker(Section& top, Job& job) {
  Section tracker = top.Sub("tracker", true);
  tracker.set_hint("model, parameters, correlations, noise");
  std::string model_name = AsString(tracker.Require("model"), tracker.Where("model"));
  const ModelInfo* model = FindModel(model_name);
  if (!model) {
    std::string list;
    for (const ModelInfo* m : AllModels()) {
      if (std::string_view(m->kind) == "tracker") list += (list.empty() ? "" : ", ") + std::string(m->name);
    }
    throw InputError(tracker.Where("model") + ": unknown model '" + model_name +
                     "' (tracker models: " + (list.empty() ? "none built" : list) + ")");
  }
  if (std::string_view(model->kind) != "tracker" || model->num_readings != 3) {
    throw InputError(tracker.Where("model") + ": model '" + model_name +
                     "' is not a tracker model (it has no range/azimuth/elevation readings)");
  }
  MeasurementSetup& setup = job.setup;
  setup.model = model;
  setup.params.clear();
  std::vector<Dimension> dims;
  for (int k = 0; k < model->num_params; ++k) {
    const QuantityInfo& q = model->params[k];
    Dimension dim = job_detail::DimensionOfQuantity(q.quantity, tracker.Where("model"));
    dims.push_back(dim);
    UncertainInput input = MakeInput(q.name, "parameter", dim, q.default_estimate, q.default_u);
    input.unit = q.unit;
    input.distribution = q.default_distribution ? q.default_distribution : "normal";
    input.shape = q.default_shape;
    setup.params.push_back(input);
  }

  // [tracker.parameters.<name>]: override the model's defaults.
  Section params = tracker.Sub("parameters", false);
  if (params.exists()) {
    for (auto&& [key, node] : params.table()) {
      (void)node;
      std::string name(key.str());
      int k = FindParam(*model, name);
      if (k < 0) {
        std::string list;
        for (int j = 0; j < model->num_params; ++j) list += (j ? ", " : "") + std::string(model->params[j].name);
        throw InputError(params.Where(name) + ": unknown parameter '" + name + "' of model '" +
                         model_name + "' (parameters: " + list + ")");
      }
      Dimension u_dim = dims[k] == Dimension::kTemperature ? Dimension::kTemperatureDifference : dims[k];
      ReadUncertain(params, name, dims[k], u_dim, setup.params[k]);
    }
    params.Finish();
  }

  // [tracker.correlations.<name>]: parameters = [...], matrix = [[...], ...]
  setup.param_correlation.resize(0, 0);
  Section corr = tracker.Sub("correlations", false);
  if (corr.exists()) {
    const int n = model->num_params;
    Eigen::MatrixXd full = Eigen::MatrixXd::Identity(n, n);
    std::vector<std::string> owner(n);
    for (auto&& [key, node] : corr.table()) {
      (void)node;
      std::string group_name(key.str());
      Section g = corr.Sub(group_name, true);
      g.set_hint("parameters, matrix");
      const toml::node& names_node = g.Require("parameters");
      if (!names_node.is_array()) throw InputError(g.Where("parameters") + ": expected an array of parameter names");
      std::vector<int> idx;
      for (const toml::node& e : *names_node.as_array()) {
        std::string pname = AsString(e, g.Where("parameters"));
        int k = FindParam(*model, pname);
        if (k < 0) throw InputError(g.Where("parameters") + ": unknown parameter '" + pname + "' of model '" + model_name + "'");
        if (!owner[k].empty()) {
          throw InputError(g.Where("parameters") + ": parameter '" + pname + "' already appears in correlation matrix '" + owner[k] + "'");
        }
        owner[k] = group_name;
        idx.push_back(k);
      }
      const int m = static_cast<int>(idx.size());
      const toml::node& mat_node = g.Require("matrix");
      std::string wm = g.Where("matrix");
      if (!mat_node.is_array() || static_cast<int>(mat_node.as_array()->size()) != m) {
        throw InputError(wm + ": expected " + std::to_string(m) + " rows of " + std::to_string(m) + " numbers");
      }
      Eigen::MatrixXd c(m, m);
      for (int i = 0; i < m; ++i) {
        const toml::node& row = *mat_node.as_array()->get(i);
        if (!row.is_array() || static_cast<int>(row.as_array()->size()) != m) {
          throw InputError(wm + ": row " + std::to_string(i + 1) + ": expected " + std::to_string(m) + " numbers");
        }
        for (int j = 0; j < m; ++j) c(i, j) = AsNumber(*row.as_array()->get(j), wm);
      }
      for (int i = 0; i < m; ++i) {
        if (std::abs(c(i, i) - 1.0) > 1e-12) throw InputError(wm + ": diagonal element " + std::to_string(i + 1) + " is not 1");
        for (int j = 0; j < m; ++j) {
          if (std::abs(c(i, j) - c(j, i)) > 1e-12) throw InputError(wm + ": not symmetric");
          if (std::abs(c(i, j)) > 1.0) throw InputError(wm + ": correlation coefficient outside [-1, 1]");
        }
      }
      // A correlation matrix must be positive semi-definite (JCGM 101 6.4.8.1), else no joint
      // distribution has it and the GUM variance can come out negative.
      Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(c);
      if (eig.eigenvalues().minCoeff() < -1e-10) {
        throw InputError(wm + ": correlation matrix is not positive semi-definite (smallest eigenvalue " +
                         std::to_string(eig.eigenvalues().minCoeff()) + ")");
      }
      for (int i = 0; i < m; ++i)
        for (int j = 0; j < m; ++j) full(idx[i], idx[j]) = c(i, j);
      g.Finish();
    }
    corr.Finish();
    setup.param_correlation = full;
  }

  // [tracker.noise]: reading noise of every point.
  Section noise = tracker.Sub("noise", true);
  noise.set_hint("range, range_a, range_b, azimuth, elevation");
  const toml::node* range = noise.Get("range");
  const toml::node* range_a = noise.Get("range_a");
  const toml::node* range_b = noise.Get("range_b");
  if (range && (range_a || range_b)) {
    throw InputError(noise.Where("range") + ": give either range or range_a/range_b, not both");
  }
  if (range) {
    if (range->is_string()) {
      ParseRangeNoise(*range->value<std::string>(), noise.Where("range"), setup.noise.range_a, setup.noise.range_b);
    } else {
      setup.noise.range_a = AsQuantity(*range, Dimension::kLength, noise.Where("range"));
      setup.noise.range_b = 0.0;
      CheckUncertainty(setup.noise.range_a, noise.Where("range"));
    }
  } else if (range_a || range_b) {
    if (range_a) setup.noise.range_a = AsQuantity(*range_a, Dimension::kLength, noise.Where("range_a"));
    if (range_b) setup.noise.range_b = AsQuantity(*range_b, Dimension::kRatio, noise.Where("range_b"));
    CheckUncertainty(setup.noise.range_a, noise.Where("range_a"));
    CheckUncertainty(setup.noise.range_b, noise.Where("range_b"));
  } else {
    throw InputError(noise.Where("range") + ": required key is missing (e.g. range = \"5 um + 0.5 um/m\")");
  }
  setup.noise.azimuth = AsQuantity(noise.Require("azimuth"), Dimension::kAngle, noise.Where("azimuth"));
  CheckUncertainty(setup.noise.azimuth, noise.Where("azimuth"));
  setup.noise.elevation = AsQuantity(noise.Require("elevation"), Dimension::kAngle, noise.Where("elevation"));
  CheckUncertainty(setup.noise.elevation, noise.Where("elevation"));
  noise.Finish();
  tracker.Finish();
}

void ReadEnvironment(Section& top, Job& job) {
  Section s = top.Sub("environment", false);
  if (!s.exists()) return;
  s.set_hint("equation, wavelength, temperature, pressure, humidity, co2");
  Environment env;
  if (const toml::node* n = s.Get("equation")) {
    std::string eq = AsString(*n, s.Where("equation"));
    if (eq == "ciddor") {
      env.equation = Environment::Equation::kCiddor;
    } else if (eq == "edlen" || eq == "edlen_boensch") {
      env.equation = Environment::Equation::kEdlenBoensch;
    } else {
      throw InputError(s.Where("equation") + ": unknown equation '" + eq + "' (expected ciddor or edlen)");
    }
  }
  if (const toml::node* n = s.Get("wavelength")) {
    env.vacuum_wavelength = AsQuantity(*n, Dimension::kLength, s.Where("wavelength"));
    if (!(env.vacuum_wavelength >= 300e-9 && env.vacuum_wavelength <= 1700e-9)) {
      throw InputError(s.Where("wavelength") + ": vacuum wavelength outside 300 nm .. 1700 nm");
    }
  }
  env.temperature = MakeInput("environment.temperature", "environment", Dimension::kTemperature, 20.0, 0.0);
  env.pressure = MakeInput("environment.pressure", "environment", Dimension::kPressure, 101325.0, 0.0);
  env.humidity = MakeInput("environment.humidity", "environment", Dimension::kHumidity, 50.0, 0.0);
  env.co2 = MakeInput("environment.co2", "environment", Dimension::kFraction, 450e-6, 0.0);
  if (!s.Get("temperature")) throw InputError(s.Where("temperature") + ": required key is missing");
  if (!s.Get("pressure")) throw InputError(s.Where("pressure") + ": required key is missing");
  if (!s.Get("humidity")) throw InputError(s.Where("humidity") + ": required key is missing");
  ReadUncertain(s, "temperature", Dimension::kTemperature, Dimension::kTemperatureDifference, env.temperature);
  ReadUncertain(s, "pressure", Dimension::kPressure, Dimension::kPressure, env.pressure);
  ReadUncertain(s, "humidity", Dimension::kHumidity, Dimension::kHumidity, env.humidity);
  ReadUncertain(s, "co2", Dimension::kFraction, Dimension::kFraction, env.co2);
  if (env.pressure.estimate <= 0.0) throw InputError(s.Where("pressure") + ": pressure must be positive");
  if (env.humidity.estimate < 0.0 || env.humidity.estimate > 100.0) {
    throw InputError(s.Where("humidity") + ": relative humidity outside 0 .. 100 %");
  }
  s.Finish();
  job.setup.environment = env;
}

void ReadStation(Section& top, Job& job) {
  Section s = top.Sub("station", false);
  if (!s.exists()) return;
  s.set_hint("rx, ry, rz, tx, ty, tz");
  StationPose pose;
  pose.rx = MakeInput("pose.rx", "pose", Dimension::kAngle, 0, 0);
  pose.ry = MakeInput("pose.ry", "pose", Dimension::kAngle, 0, 0);
  pose.rz = MakeInput("pose.rz", "pose", Dimension::kAngle, 0, 0);
  pose.tx = MakeInput("pose.tx", "pose", Dimension::kLength, 0, 0);
  pose.ty = MakeInput("pose.ty", "pose", Dimension::kLength, 0, 0);
  pose.tz = MakeInput("pose.tz", "pose", Dimension::kLength, 0, 0);
  ReadUncertain(s, "rx", Dimension::kAngle, Dimension::kAngle, pose.rx);
  ReadUncertain(s, "ry", Dimension::kAngle, Dimension::kAngle, pose.ry);
  ReadUncertain(s, "rz", Dimension::kAngle, Dimension::kAngle, pose.rz);
  ReadUncertain(s, "tx", Dimension::kLength, Dimension::kLength, pose.tx);
  ReadUncertain(s, "ty", Dimension::kLength, Dimension::kLength, pose.ty);
  ReadUncertain(s, "tz", Dimension::kLength, Dimension::kLength, pose.tz);
  s.Finish();
  job.setup.pose = pose;
}

void ReadPart(Section& top, Job& job) {
  Section s = top.Sub("part", false);
  if (!s.exists()) return;
  s.set_hint("cte, temperature, reference");
  PartThermal thermal;
  thermal.cte = MakeInput("thermal.cte", "thermal", Dimension::kPerKelvin, 0, 0);
  thermal.temperature = MakeInput("thermal.temperature", "thermal", Dimension::kTemperature, 20, 0);
  if (!s.Get("cte")) throw InputError(s.Where("cte") + ": required key is missing");
  if (!s.Get("temperature")) throw InputError(s.Where("temperature") + ": required key is missing");
  ReadUncertain(s, "cte", Dimension::kPerKelvin, Dimension::kPerKelvin, thermal.cte);
  ReadUncertain(s, "temperature", Dimension::kTemperature, Dimension::kTemperatureDifference, thermal.temperature);
  if (const toml::node* n = s.Get("reference")) {
    thermal.reference = AsQuantity(*n, Dimension::kTemperature, s.Where("reference"));
  }
  s.Finish();
  job.setup.thermal = thermal;
}

Face ParseFaceField(std::string text, const std::string& where) {
  std::transform(text.begin(), text.end(), text.begin(), [](unsigned char c) { return std::tolower(c); });
  if (text == "front" || text == "1" || text == "f" || text == "fs") return Face::kFront;
  if (text == "back" || text == "2" || text == "b" || text == "bs") return Face::kBack;
  throw InputError(where + ": face '" + text + "' (expected front or back, or 1 or 2)");
}

// A coordinate of a plan point: a number in the plan's unit or a string with its own unit.
double PlanCoordinate(const toml::node& node, double unit_scale, const std::string& where) {
  if (node.is_number()) return AsNumber(node, where) * unit_scale;
  return AsQuantity(node, Dimension::kLength, where);
}

double CsvQuantity(const std::string& field, Dimension dim, double unit_scale, double unit_offset,
                   const std::string& where) {
  if (field.empty()) throw InputError(where + ": empty field");
  char* end = nullptr;
  double v = std::strtod(field.c_str(), &end);
  if (end && *end == '\0') {
    if (!std::isfinite(v)) throw InputError(where + ": '" + field + "' is not a finite number");
    return v * unit_scale + unit_offset;
  }
  return ParseQuantity(field, dim, where);  // a field with its own unit
}

// Scale of `unit` for `dim` (value_SI = value * scale), with a job-file message for a bad unit.
double UnitScale(const std::string& unit, Dimension dim, const std::string& where) {
  double one = ParseQuantity("1 " + unit, dim, where);
  double zero = ParseQuantity("0 " + unit, dim, where);
  return one - zero;
}

void ReadPlan(Section& s, Job& job) {
  s.set_hint("unit, csv, point");
  std::string unit = "m";
  if (const toml::node* n = s.Get("unit")) unit = AsString(*n, s.Where("unit"));
  double scale = UnitScale(unit, Dimension::kLength, s.Where("unit"));

  if (const toml::node* n = s.Get("csv")) {
    std::string rel = AsString(*n, s.Where("csv"));
    std::filesystem::path path = job.base_dir / rel;
    if (!std::filesystem::is_regular_file(path)) {
      throw InputError(s.Where("csv") + ": cannot read '" + path.string() + "'");
    }
    CsvTable table = ReadCsvFile(path.string(), path.string());
    rel = path.string();
    for (const char* col : {"name", "x", "y", "z"}) {
      if (table.Column(col) < 0) {
        throw InputError(rel + ": line " + std::to_string(table.header_line) + ": missing column '" + col +
                         "' (plan CSV columns: name, x, y, z [, face])");
      }
    }
    for (const std::string& col : table.header) {
      if (col != "name" && col != "x" && col != "y" && col != "z" && col != "face") {
        throw InputError(rel + ": line " + std::to_string(table.header_line) + ": unknown column '" + col +
                         "' (plan CSV columns: name, x, y, z [, face])");
      }
    }
    int cn = table.Column("name"), cx = table.Column("x"), cy = table.Column("y"), cz = table.Column("z"),
        cf = table.Column("face");
    for (const CsvRow& row : table.rows) {
      JobPoint p;
      p.where = table.Where(row);
      p.name = row.fields[cn];
      if (p.name.empty()) throw InputError(p.where + ": empty point name");
      p.nominal = {CsvQuantity(row.fields[cx], Dimension::kLength, scale, 0, p.where + ": x"),
                   CsvQuantity(row.fields[cy], Dimension::kLength, scale, 0, p.where + ": y"),
                   CsvQuantity(row.fields[cz], Dimension::kLength, scale, 0, p.where + ": z")};
      if (cf >= 0 && !row.fields[cf].empty()) p.face = ParseFaceField(row.fields[cf], p.where);
      job.points.push_back(std::move(p));
    }
  }
  if (const toml::node* n = s.Get("point")) {
    if (!n->is_array()) throw InputError(s.Where("point") + ": expected [[plan.point]] tables");
    int index = 0;
    for (const toml::node& e : *n->as_array()) {
      std::string path = s.path() + ".point[" + std::to_string(index++) + "]";
      if (!e.is_table()) throw InputError(job.file + ": " + path + ": expected a table");
      Section pt(*e.as_table(), job.file, path);
      pt.set_hint("name, x, y, z, face");
      JobPoint p;
      p.where = job.file + ": " + path;
      p.name = AsString(pt.Require("name"), pt.Where("name"));
      if (p.name.empty()) throw InputError(pt.Where("name") + ": empty point name");
      p.nominal = {PlanCoordinate(pt.Require("x"), scale, pt.Where("x")),
                   PlanCoordinate(pt.Require("y"), scale, pt.Where("y")),
                   PlanCoordinate(pt.Require("z"), scale, pt.Where("z"))};
      if (const toml::node* f = pt.Get("face")) p.face = ParseFaceField(AsString(*f, pt.Where("face")), pt.Where("face"));
      pt.Finish();
      job.points.push_back(std::move(p));
    }
  }
  s.Finish();
  if (job.points.empty()) throw InputError(s.WhereSelf() + ": the plan has no points (give csv or [[plan.point]])");

  // A planned point must have a defined azimuth: not on the tracker's vertical axis.
  for (const JobPoint& p : job.points) {
    Eigen::Vector3d t = PartToTrackerNominal(job.setup, p.nominal);
    if (std::hypot(t.x(), t.y()) < kVerticalAxisTolerance) {
      throw InputError(p.where + ": point '" + p.name +
                       "' lies on the tracker's vertical axis (azimuth undefined; move the point or the station)");
    }
  }
}

void ReadReadings(Section& s, Job& job) {
  s.set_hint("csv, columns, units, vertical_angle");
  std::string rel = AsString(s.Require("csv"), s.Where("csv"));
  std::string names[5] = {"name", "range", "azimuth", "elevation", "face"};
  const char* keys[5] = {"name", "range", "azimuth", "elevation", "face"};
  Section cols = s.Sub("columns", false);
  if (cols.exists()) {
    cols.set_hint("name, range, azimuth, elevation, face");
    for (int k = 0; k < 5; ++k) {
      if (const toml::node* n = cols.Get(keys[k])) names[k] = AsString(*n, cols.Where(keys[k]));
    }
    cols.Finish();
  }
  std::string units[3] = {"m", "rad", "rad"};
  Dimension dims[3] = {Dimension::kLength, Dimension::kAngle, Dimension::kAngle};
  Section us = s.Sub("units", false);
  double scales[3];
  if (us.exists()) {
    us.set_hint("range, azimuth, elevation");
    for (int k = 0; k < 3; ++k) {
      if (const toml::node* n = us.Get(keys[k + 1])) units[k] = AsString(*n, us.Where(keys[k + 1]));
    }
    us.Finish();
  }
  for (int k = 0; k < 3; ++k) scales[k] = UnitScale(units[k], dims[k], s.Where(std::string("units.") + keys[k + 1]));
  bool zenith = false;
  if (const toml::node* n = s.Get("vertical_angle")) {
    std::string v = AsString(*n, s.Where("vertical_angle"));
    if (v == "zenith") zenith = true;
    else if (v != "elevation") throw InputError(s.Where("vertical_angle") + ": expected \"elevation\" or \"zenith\"");
  }
  s.Finish();

  std::filesystem::path path = job.base_dir / rel;
  if (!std::filesystem::is_regular_file(path)) {
    throw InputError(s.Where("csv") + ": cannot read '" + path.string() + "'");
  }
  CsvTable table = ReadCsvFile(path.string(), path.string());
  rel = path.string();
  int col[5];
  for (int k = 0; k < 5; ++k) {
    col[k] = table.Column(names[k]);
    if (col[k] < 0 && k < 4) {
      throw InputError(rel + ": line " + std::to_string(table.header_line) + ": missing column '" + names[k] +
                       "' (declared by readings.columns." + keys[k] + ")");
    }
  }
  for (const CsvRow& row : table.rows) {
    JobPoint p;
    p.where = table.Where(row);
    p.name = row.fields[col[0]];
    if (p.name.empty()) throw InputError(p.where + ": empty point name");
    double r[3];
    for (int k = 0; k < 3; ++k) {
      r[k] = CsvQuantity(row.fields[col[k + 1]], dims[k], scales[k], 0, p.where + ": " + names[k + 1]);
    }
    if (!(r[0] > 0.0)) throw InputError(p.where + ": range must be positive");
    double elevation = zenith ? kPi / 2 - r[2] : r[2];
    // Normalise the elevation into [-pi/2, 3pi/2): front face up to pi/2, back face beyond.
    elevation = std::fmod(elevation + kPi / 2, 2 * kPi);
    if (elevation < 0) elevation += 2 * kPi;
    elevation -= kPi / 2;
    Face face = elevation <= kPi / 2 + 1e-12 ? Face::kFront : Face::kBack;
    if (col[4] >= 0 && !row.fields[col[4]].empty()) {
      Face declared = ParseFaceField(row.fields[col[4]], p.where);
      if (declared != face) {
        throw InputError(p.where + ": face column says " + std::string(FaceName(declared)) +
                         " but the vertical angle is a " + std::string(FaceName(face)) + "-face reading");
      }
    }
    p.face = face;
    p.readings = {r[0], r[1], elevation};
    job.points.push_back(std::move(p));
  }
  if (job.points.empty()) throw InputError(rel + ": no readings (only a header)");
}

void ReadTasks(Section& top, Job& job) {
  const toml::node* n = top.Get("task");
  if (!n) return;
  if (!n->is_array()) throw InputError(top.Where("task") + ": expected [[task]] tables");
  std::vector<std::string> point_names = job.point_names();
  int index = 0;
  std::set<std::string> seen;
  for (const toml::node& e : *n->as_array()) {
    std::string path = "task[" + std::to_string(index++) + "]";
    if (!e.is_table()) throw InputError(job.file + ": " + path + ": expected a table");
    Section t(*e.as_table(), job.file, path);
    t.set_hint("kind, name, points");
    TaskSpec spec;
    spec.kind = ParseTaskKind(AsString(t.Require("kind"), t.Where("kind")), t.Where("kind"));
    spec.name = AsString(t.Require("name"), t.Where("name"));
    if (spec.name.empty()) throw InputError(t.Where("name") + ": empty task name");
    if (!seen.insert(spec.name).second) throw InputError(t.Where("name") + ": task '" + spec.name + "' defined twice");
    const toml::node& pts = t.Require("points");
    if (!pts.is_array()) throw InputError(t.Where("points") + ": expected an array of point names");
    for (const toml::node& p : *pts.as_array()) spec.points.push_back(AsString(p, t.Where("points")));
    t.Finish();
    job.task_points.push_back(ResolveTaskPoints(spec, point_names, t.Where("points")));
    job.tasks.push_back(std::move(spec));
  }
}

void ReadMonteCarlo(Section& top, Job& job) {
  Section s = top.Sub("monte_carlo", false);
  if (!s.exists()) return;
  s.set_hint("enabled, trials, adaptive, n_dig, seed, coverage_probability, threads");
  MonteCarloSettings& mc = job.monte_carlo;
  if (const toml::node* n = s.Get("enabled")) mc.enabled = AsBool(*n, s.Where("enabled"));
  if (const toml::node* n = s.Get("adaptive")) mc.adaptive = AsBool(*n, s.Where("adaptive"));
  if (const toml::node* n = s.Get("coverage_probability")) {
    mc.coverage_probability = AsQuantity(*n, Dimension::kRatio, s.Where("coverage_probability"));
    if (!(mc.coverage_probability > 0.0 && mc.coverage_probability < 1.0)) {
      throw InputError(s.Where("coverage_probability") + ": must be between 0 and 1 (e.g. 0.95 or \"95 %\")");
    }
  }
  if (const toml::node* n = s.Get("trials")) {
    mc.trials = AsInteger(*n, s.Where("trials"));
    // JCGM 101 7.2.2: M should be large compared with 1/(1-p); at least 100/(1-p).
    double minimum = std::ceil(100.0 / (1.0 - mc.coverage_probability));
    if (mc.trials < minimum) {
      throw InputError(s.Where("trials") + ": at least " + std::to_string(static_cast<long long>(minimum)) +
                       " trials for coverage probability " + std::to_string(mc.coverage_probability) +
                       " (JCGM 101 7.2.2: M >= 100/(1-p))");
    }
    if (mc.trials > 1000000000LL) throw InputError(s.Where("trials") + ": more than 1e9 trials");
  }
  if (const toml::node* n = s.Get("n_dig")) {
    std::int64_t v = AsInteger(*n, s.Where("n_dig"));
    if (v != 1 && v != 2) throw InputError(s.Where("n_dig") + ": must be 1 or 2 (JCGM 101 7.9.2)");
    mc.n_dig = static_cast<int>(v);
  }
  if (const toml::node* n = s.Get("seed")) {
    std::int64_t v = AsInteger(*n, s.Where("seed"));
    if (v < 0) throw InputError(s.Where("seed") + ": must be a non-negative integer");
    mc.seed = static_cast<std::uint64_t>(v);
  }
  if (const toml::node* n = s.Get("threads")) {
    std::int64_t v = AsInteger(*n, s.Where("threads"));
    if (v < 0 || v > 1024) throw InputError(s.Where("threads") + ": must be 0 (all) .. 1024");
    mc.threads = static_cast<int>(v);
  }
  s.Finish();
}

std::string ExtentString(const toml::node& node, const std::string& where) {
  if (node.is_string()) return *node.value<std::string>();
  if (!node.is_array()) throw InputError(where + ": expected \"a,b,c,d\" or an array of quantities");
  std::string out;
  for (const toml::node& e : *node.as_array()) {
    if (!out.empty()) out += ",";
    if (e.is_string()) out += *e.value<std::string>();
    else {
      std::ostringstream os;
      os.precision(17);
      os << AsNumber(e, where);
      out += os.str();
    }
  }
  return out;
}

void ReadMap(Section& top, Job& job) {
  Section s = top.Sub("map", false);
  if (!s.exists()) return;
  s.set_hint("plane, extent, box, step");
  const toml::node* plane = s.Get("plane");
  const toml::node* extent = s.Get("extent");
  const toml::node* box = s.Get("box");
  const toml::node* step = s.Get("step");
  std::string step_text = "0.25 m";
  if (step) step_text = step->is_string() ? *step->value<std::string>() : ExtentString(*step, s.Where("step"));
  if (plane && box) throw InputError(s.Where("box") + ": give either plane + extent or box, not both");
  if (plane) {
    if (!extent) throw InputError(s.Where("extent") + ": required key is missing (with plane)");
    job.map = ParseMapPlane(AsString(*plane, s.Where("plane")), ExtentString(*extent, s.Where("extent")),
                            step_text, s.WhereSelf());
  } else if (box) {
    if (extent) throw InputError(s.Where("extent") + ": extent goes with plane, not with box");
    job.map = ParseMapBox(ExtentString(*box, s.Where("box")), step_text, s.WhereSelf());
  } else {
    throw InputError(s.Where("plane") + ": required key is missing (plane + extent, or box)");
  }
  s.Finish();
}

void ReadOutput(Section& top, Job& job) {
  Section s = top.Sub("output", false);
  if (!s.exists()) return;
  s.set_hint("directory, ellipsoid_scale");
  if (const toml::node* n = s.Get("directory")) job.output.directory = AsString(*n, s.Where("directory"));
  if (const toml::node* n = s.Get("ellipsoid_scale")) {
    job.output.ellipsoid_scale = AsNumber(*n, s.Where("ellipsoid_scale"));
    if (!(job.output.ellipsoid_scale > 0)) throw InputError(s.Where("ellipsoid_scale") + ": must be positive");
  }
  s.Finish();
}

}  // namespace

Eigen::Vector3d PartToTrackerNominal(const MeasurementSetup& setup, const Eigen::Vector3d& part) {
  Eigen::Vector3d x = part;
  if (setup.thermal) {
    x *= 1.0 + setup.thermal->cte.estimate * (setup.thermal->temperature.estimate - setup.thermal->reference);
  }
  if (setup.pose) {
    const StationPose& p = *setup.pose;
    Eigen::Matrix3d r = (Eigen::AngleAxisd(p.rz.estimate, Eigen::Vector3d::UnitZ()) *
                         Eigen::AngleAxisd(p.ry.estimate, Eigen::Vector3d::UnitY()) *
                         Eigen::AngleAxisd(p.rx.estimate, Eigen::Vector3d::UnitX()))
                            .toRotationMatrix();
    Eigen::Vector3d t(p.tx.estimate, p.ty.estimate, p.tz.estimate);
    x = r.transpose() * (x - t);
  }
  return x;
}

Job ParseJob(std::string_view text, const std::string& file, const std::filesystem::path& base_dir) {
  toml::table root;
  try {
    root = toml::parse(text, file);
  } catch (const toml::parse_error& e) {
    std::string desc(e.description());
    std::replace(desc.begin(), desc.end(), '\n', ' ');
    throw InputError(file + ": line " + std::to_string(e.source().begin.line) + ", column " +
                     std::to_string(e.source().begin.column) + ": TOML syntax error: " + desc);
  }
  Job job;
  job.file = file;
  job.base_dir = base_dir;
  job.name = std::filesystem::path(file).stem().string();
  Section top(root, file, "");
  top.set_hint("job, tracker, environment, station, part, plan, readings, task, monte_carlo, map, output");

  Section meta = top.Sub("job", false);
  if (meta.exists()) {
    meta.set_hint("name, description");
    if (const toml::node* n = meta.Get("name")) job.name = AsString(*n, meta.Where("name"));
    if (const toml::node* n = meta.Get("description")) job.description = AsString(*n, meta.Where("description"));
    if (job.name.empty()) throw InputError(meta.Where("name") + ": empty job name");
    meta.Finish();
  }
  ReadTracker(top, job);
  ReadEnvironment(top, job);
  ReadStation(top, job);
  ReadPart(top, job);

  Section plan = top.Sub("plan", false);
  Section readings = top.Sub("readings", false);
  if (plan.exists() && readings.exists()) {
    throw InputError(file + ": readings: give either [plan] (offline) or [readings] (online), not both");
  }
  if (plan.exists()) {
    job.mode = JobMode::kPlan;
    ReadPlan(plan, job);
  } else if (readings.exists()) {
    job.mode = JobMode::kReadings;
    ReadReadings(readings, job);
  } else {
    throw InputError(file + ": plan: required key is missing (give [plan] points, or [readings] from a CSV)");
  }
  {
    std::set<std::string> names;
    for (const JobPoint& p : job.points) {
      if (!names.insert(p.name).second) throw InputError(p.where + ": point name '" + p.name + "' used twice");
    }
  }
  ReadTasks(top, job);
  ReadMonteCarlo(top, job);
  ReadMap(top, job);
  ReadOutput(top, job);
  top.Finish();
  return job;
}

Job LoadJob(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot read the job file");
  std::ostringstream buffer;
  buffer << in.rdbuf();
  std::filesystem::path base = std::filesystem::path(path).parent_path();
  if (base.empty()) base = ".";
  return ParseJob(buffer.str(), path, base);
}

}  // namespace vlt
