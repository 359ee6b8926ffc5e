// custom/reader.cc — a job on a custom model (vlt/custom_job.h): [model], [inputs.<name>],
// [observations], [correlations.<group>], [outputs.<name>], [monte_carlo], [output].
// Keys, units and defaults: docs/custom-models.md; keep the two in step.
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <toml++/toml.h>

#include "base/csv.h"
#include "job/job_detail.h"
#include "vlt/custom_job.h"
#include "vlt/distributions.h"
#include "vlt/error.h"
#include "vlt/input_file.h"
#include "vlt/models.h"

namespace vlt {

using namespace base_internal;
using namespace instrument_internal;
using namespace job_internal;  // Section, AsString and the section readers

namespace {

// The dimension of a model quantity when vlt knows its units ("length", "temperature", ...) AND
// the spec states it in vlt's unit of that kind (m, degC, ...): then job values may carry units.
// None for quantities such as "voltage", or a length the spec gives in mm: values are plain
// numbers in the spec's unit (a quantity string would be converted to vlt's unit, not the spec's).
std::optional<Dimension> KnownDimension(const QuantityInfo& q) {
  try {
    const Dimension d = DimensionOfQuantity(q.quantity, "");
    if (SiUnit(d) == q.unit) return d;
  } catch (const InputError&) {}
  return std::nullopt;
}

double Value(const toml::node& node, std::optional<Dimension> dim, const std::string& unit,
             const std::string& where) {
  double v = 0.0;
  if (dim) {
    v = AsQuantity(node, *dim, where);
  } else {
    if (!node.is_number()) {
      throw InputError(where + ": give a number in the model's unit (" + unit + ")");
    }
    v = AsNumber(node, where);
  }
  if (!std::isfinite(v) || std::abs(v) > kMaxMagnitude) {
    throw InputError(where + ": beyond what vlt computes with (at most 1e12 in the model's unit)");
  }
  return v;
}

// Standard uncertainties of a temperature are temperature differences.
std::optional<Dimension> UncertaintyDimension(std::optional<Dimension> dim) {
  if (dim && *dim == Dimension::kTemperature) return Dimension::kTemperatureDifference;
  return dim;
}

struct Observations {
  std::vector<double> values;
  std::string from;
};

// Type A (JCGM 100 4.2.1-4.2.3): mean, s(q_k), u = s / sqrt(n), nu = n - 1.
void SetTypeA(const Observations& obs, UncertainInput& input, CustomInputSource& source, double& dof,
              const std::string& where) {
  const int n = static_cast<int>(obs.values.size());
  if (n < 2) throw InputError(where + ": at least 2 observations are needed for a Type A evaluation");
  double mean = 0.0;
  for (double v : obs.values) mean += v;
  mean /= n;
  double ss = 0.0;
  for (double v : obs.values) ss += (v - mean) * (v - mean);
  const double s = std::sqrt(ss / (n - 1));
  input.estimate = mean;
  input.u = s / std::sqrt(static_cast<double>(n));
  input.distribution = "normal";
  input.shape = 0.0;
  source.kind = "type A";
  source.observations = n;
  source.standard_deviation = s;
  source.from = obs.from;
  dof = n - 1.0;
}

// The reading of a custom job: the model, its inputs (the spec's values, then Type A from
// observations or Type B from the job), their correlations, and what Monte Carlo samples.
struct CustomJobReader {
  Section& top;
  CustomJob& job;
  const ModelInfo* model = nullptr;
  int n_in = 0;
  // [observations]: the CSV file of observed columns.
  std::optional<CsvTable> table;
  bool simultaneous = false;
  std::string observations_where;
  std::vector<int> from_table;                // inputs observed in a column of `table`
  std::vector<std::vector<double>> observed;  // Type A values, SI

  CustomJobReader(Section& top, CustomJob& job) : top(top), job(job) {}

  void FindCustomModel();
  void SetSpecValues();
  void ReadObservationsFile();
  Observations ReadObservations(Section& s, const toml::node& obs, int i, std::optional<Dimension> dim);
  void ReadTypeB(Section& s, int i, std::optional<Dimension> dim);
  void ReadInput(Section& inputs, const std::string& name, const toml::node& node);
  void ReadInputs();
  void WarnUnusedObservations();
  CorrelationGroup ObservationCorrelation() const;
  void ReadCorrelations();
  void SetMonteCarloInputs();
  void ReadTolerances();
};

// [model] name = "<a custom model: compiled in, or built (vlt model build)>", or spec = "<its spec>":
// the spec is built into the model cache first, or found there when it has not changed (vlt/models.h
// BuildModel; docs/custom-models.md "Without rebuilding vlt").
void CustomJobReader::FindCustomModel() {
  Section model_section = top.Sub("model", true);
  model_section.set_hint("name, spec");
  std::string model_name;
  std::string named_by = model_section.Where("name");
  if (const toml::node* spec = model_section.Get("spec")) {
    named_by = model_section.Where("spec");
    const std::filesystem::path path = job.base_dir / AsString(*spec, model_section.Where("spec"));
    try {
      model_name = BuildModel(path).name;
    } catch (const InputError& e) {
      throw InputError(model_section.Where("spec") + ": " + e.what());
    }
    if (const toml::node* n = model_section.Get("name")) {
      const std::string given = AsString(*n, model_section.Where("name"));
      if (given != model_name) {
        throw InputError(model_section.Where("name") + ": '" + given + "', but the spec defines '" +
                         model_name + "' (give one of the two)");
      }
    }
  } else {
    model_name = AsString(model_section.Require("name"), model_section.Where("name"));
  }
  model = FindModel(model_name);
  if (model == nullptr || std::string_view(model->kind) != "custom") {
    std::string list;
    for (const ModelInfo* m : AllModels()) {
      if (std::string_view(m->kind) == "custom") list += (list.empty() ? "" : ", ") + std::string(m->name);
    }
    throw InputError(
        model_section.Where("name") + ": '" + model_name +
        (model == nullptr ? "' is not a compiled or built model" : "' is a tracker model (use [tracker])") +
        " (custom models: " + list + "; build one from its spec: vlt model build SPEC.toml, or [model] " +
        "spec = \"SPEC.toml\", docs/custom-models.md)");
  }
  model_section.Finish();
  job.model = model;
  n_in = model->num_params;
}

// The spec's values first.
void CustomJobReader::SetSpecValues() {
  job.inputs.resize(n_in);
  job.sources.resize(n_in);
  job.dof.assign(n_in, std::numeric_limits<double>::infinity());
  for (int i = 0; i < n_in; ++i) {
    const QuantityInfo& q = model->params[i];
    UncertainInput& in = job.inputs[i];
    in.name = q.name;
    in.unit = q.unit;
    in.group = "input";
    in.estimate = q.default_estimate;
    in.u = q.default_u;
    in.distribution = q.default_distribution;
    in.shape = q.default_shape;
  }
}

// [observations] file = "<csv>", simultaneous = true|false
void CustomJobReader::ReadObservationsFile() {
  Section obs_section = top.Sub("observations", false);
  if (!obs_section.exists()) return;
  obs_section.set_hint("file, simultaneous");
  const std::string rel = AsString(obs_section.Require("file"), obs_section.Where("file"));
  std::filesystem::path path = rel;
  if (path.is_relative()) path = job.base_dir / path;
  if (const std::string problem = InputFileProblem(path.string()); !problem.empty()) {
    throw InputError(obs_section.Where("file") + ": cannot read '" + path.string() + "': " + problem);
  }
  table = ReadCsvFile(path.string(), path.string());
  if (table->rows.empty()) throw InputError(table->file + ": no observations (only a header)");
  simultaneous = AsBool(obs_section.Require("simultaneous"), obs_section.Where("simultaneous"));
  observations_where = obs_section.Where("simultaneous");
  obs_section.Finish();
}

// The observations of input i: an array of values or a column of [observations] file.
Observations CustomJobReader::ReadObservations(Section& s, const toml::node& obs, int i,
                                               std::optional<Dimension> dim) {
  const QuantityInfo& q = model->params[i];
  Observations o;
  if (const toml::array* arr = obs.as_array()) {
    int index = 0;
    for (const toml::node& e : *arr) {
      o.values.push_back(
          Value(e, dim, q.unit, s.Where("observations") + "[" + std::to_string(index++) + "]"));
    }
    o.from = s.Where("observations");
  } else if (obs.is_string()) {
    if (!table) {
      throw InputError(s.Where("observations") + ": a column name needs [observations] file = \"<csv>\"");
    }
    const std::string column = *obs.value<std::string>();
    const int c = table->Column(column);
    if (c < 0) {
      throw InputError(s.Where("observations") + ": " + table->file + " has no column '" + column + "'");
    }
    for (const CsvRow& row : table->rows) {
      const std::string where = table->Where(row) + ": column " + column;
      const double v = CsvQuantity(row.fields[c], dim, 1.0, 0.0, where);
      if (std::abs(v) > kMaxMagnitude)
        throw InputError(where + ": beyond what vlt computes with (at most 1e12)");
      o.values.push_back(v);
    }
    o.from = table->file + ": column " + column;
    from_table.push_back(i);
  } else {
    throw InputError(s.Where("observations") +
                     ": expected an array of values or a column name of [observations] file");
  }
  return o;
}

void CustomJobReader::ReadTypeB(Section& s, int i, std::optional<Dimension> dim) {
  const QuantityInfo& q = model->params[i];
  UncertainInput& in = job.inputs[i];
  job.sources[i].kind = "type B";
  if (const toml::node* n = s.Get("estimate")) in.estimate = Value(*n, dim, q.unit, s.Where("estimate"));
  if (const toml::node* n = s.Get("u")) {
    in.u = Value(*n, UncertaintyDimension(dim), q.unit, s.Where("u"));
    CheckUncertainty(in.u, s.Where("u"));
  }
  if (const toml::node* n = s.Get("distribution")) in.distribution = AsString(*n, s.Where("distribution"));
  if (const toml::node* n = s.Get("shape")) in.shape = AsNumber(*n, s.Where("shape"));
  CheckDistribution(in, s.Where("distribution"), s.Where("shape"));
  if (const toml::node* n = s.Get("dof")) {
    // JCGM 100 G.4.2: a Type B input has nu = (1/2) (u / Delta u)^-2; "infinity" = exact.
    if (n->is_string() && *n->value<std::string>() == "infinity") {
      job.dof[i] = std::numeric_limits<double>::infinity();
    } else {
      job.dof[i] = AsNumber(*n, s.Where("dof"));
      if (!(job.dof[i] >= 1.0) || !std::isfinite(job.dof[i])) {
        throw InputError(s.Where("dof") + ": degrees of freedom must be a number >= 1 (or \"infinity\")");
      }
    }
  }
}

// [inputs.<name>]: a bare estimate, or a table with observations (Type A) or estimate, u, ... (Type B).
void CustomJobReader::ReadInput(Section& inputs, const std::string& name, const toml::node& node) {
  int i = FindParam(*model, name);
  if (i < 0) {
    std::string list;
    for (int k = 0; k < n_in; ++k) list += (k ? ", " : "") + std::string(model->params[k].name);
    throw InputError(inputs.Where(name) + ": model '" + model->name + "' has no input '" + name +
                     "' (inputs: " + list + ")");
  }
  const QuantityInfo& q = model->params[i];
  const std::optional<Dimension> dim = KnownDimension(q);
  if (!node.is_table()) {
    job.inputs[i].estimate = Value(node, dim, q.unit, inputs.Where(name));
    job.sources[i].kind = "type B";
    inputs.Get(name);
    return;
  }
  Section s = inputs.Sub(name, false);
  s.set_hint("estimate, u, distribution, shape, dof, observations");
  if (const toml::node* obs = s.Get("observations")) {
    for (const char* k : {"estimate", "u", "distribution", "shape", "dof"}) {
      if (s.Get(k)) {
        throw InputError(s.Where(k) +
                         ": an input with observations takes its estimate, u and "
                         "degrees of freedom from them (JCGM 100 4.2)");
      }
    }
    Observations o = ReadObservations(s, *obs, i, dim);
    SetTypeA(o, job.inputs[i], job.sources[i], job.dof[i], s.Where("observations"));
    observed[i] = std::move(o.values);
  } else {
    ReadTypeB(s, i, dim);
  }
  s.Finish();
  inputs.Get(name);
}

void CustomJobReader::ReadInputs() {
  observed.resize(n_in);
  Section inputs = top.Sub("inputs", false);
  if (!inputs.exists()) return;
  for (const auto& [key, node] : inputs.table()) ReadInput(inputs, std::string(key.str()), node);
  inputs.Finish();
}

void CustomJobReader::WarnUnusedObservations() {
  if (table && from_table.empty()) {
    job.warnings.push_back(observations_where.substr(0, observations_where.rfind('.')) +
                           ".file: no input reads a column of " + table->file);
  } else if (table && from_table.size() == 1 && simultaneous) {
    job.warnings.push_back(observations_where + ": only one input reads " + table->file +
                           ": there is no correlation to estimate");
  }
}

// The group "observations": the sample correlation of the simultaneous observations.
CorrelationGroup CustomJobReader::ObservationCorrelation() const {
  const int rows = static_cast<int>(table->rows.size());
  const int m = static_cast<int>(from_table.size());
  CorrelationGroup g;
  g.name = "observations";
  g.where_inputs = g.where_matrix = observations_where;
  g.matrix = Eigen::MatrixXd::Identity(m, m);
  for (int a = 0; a < m; ++a) {
    g.inputs.push_back(job.inputs[from_table[a]].name);
    for (int b = a + 1; b < m; ++b) {
      const int ia = from_table[a], ib = from_table[b];
      const double ma = job.inputs[ia].estimate, mb = job.inputs[ib].estimate;
      const double sa = job.sources[ia].standard_deviation, sb = job.sources[ib].standard_deviation;
      double sab = 0.0;
      for (int k = 0; k < rows; ++k) sab += (observed[ia][k] - ma) * (observed[ib][k] - mb);
      sab /= rows - 1;
      const double r = sa > 0.0 && sb > 0.0 ? sab / (sa * sb) : 0.0;
      g.matrix(a, b) = g.matrix(b, a) = std::clamp(r, -1.0, 1.0);
    }
  }
  return g;
}

// Correlations: the sample correlation of simultaneous observations (JCGM 100 5.2.3, C.3.6
// eq. 17: r(q, w) = s(q, w) / (s(q) s(w)), the same for the means) as the group
// "observations", then [correlations.<g>]; all through SharedCorrelation, the one checker.
void CustomJobReader::ReadCorrelations() {
  std::vector<CorrelationGroup> groups;
  WarnUnusedObservations();
  if (table && from_table.size() >= 2 && simultaneous) {
    job.simultaneous.push_back(from_table);
    groups.push_back(ObservationCorrelation());
  }
  Section corr = top.Sub("correlations", false);
  if (corr.exists()) {
    for (const auto& [key, node] : corr.table()) {
      (void)node;
      groups.push_back(ReadCorrelationGroup(corr, std::string(key.str()), "inputs"));
    }
    corr.Finish();
  }
  std::vector<std::string> names;
  for (const UncertainInput& in : job.inputs) names.push_back(in.name);
  job.correlation = SharedCorrelation(names, groups);
}

// What Monte Carlo samples: Type A alone -> t_nu with scale u (JCGM 101 6.4.9.2); N simultaneous
// ones jointly the multivariate t of JCGM 102 6.5.3, t_nu(xbar, Q / (n (n - N))) with
// nu = n - N, Q = sum (q_k - qbar)(q_k - qbar)^T: the members stay normal with u = the scale
// s / sqrt(n) sqrt((n - 1) / (n - N)) and their sample correlation, drawn as one group.
void CustomJobReader::SetMonteCarloInputs() {
  job.mcm_inputs = job.inputs;
  for (std::size_t g = 0; g < job.simultaneous.size(); ++g) {
    const double n = job.sources[job.simultaneous[g].front()].observations;
    const double members = static_cast<double>(job.simultaneous[g].size());
    job.simultaneous_mcm_dof.push_back(n - members);
    for (int i : job.simultaneous[g]) {
      job.mcm_inputs[i].u =
          n > members ? job.inputs[i].u * std::sqrt((n - 1.0) / (n - members)) : job.inputs[i].u;
    }
  }
  for (int i = 0; i < n_in; ++i) {
    if (job.sources[i].kind != "type A") continue;
    bool grouped = false;
    for (const auto& set : job.simultaneous) {
      for (int k : set) grouped = grouped || k == i;
    }
    if (grouped) continue;
    const double nu = job.dof[i];
    UncertainInput& m = job.mcm_inputs[i];
    if (nu > 2.0) {
      m.distribution = "student_t";
      m.shape = nu;
      m.u = job.inputs[i].u * std::sqrt(nu / (nu - 2.0));
    }
  }
}

// [outputs.<name>] tolerance = { lower = ..., upper = ... }
void CustomJobReader::ReadTolerances() {
  job.tolerances.assign(model->num_outputs, std::nullopt);
  Section outputs = top.Sub("outputs", false);
  if (!outputs.exists()) return;
  for (const auto& [key, node] : outputs.table()) {
    const std::string name(key.str());
    int o = -1;
    for (int k = 0; k < model->num_outputs; ++k) {
      if (name == model->outputs[k].name) o = k;
    }
    if (o < 0)
      throw InputError(outputs.Where(name) + ": model '" + model->name + "' has no output '" + name + "'");
    const std::optional<Dimension> dim = KnownDimension(model->outputs[o]);
    Section s = outputs.Sub(name, true);
    s.set_hint("tolerance");
    Section t = s.Sub("tolerance", true);
    t.set_hint("lower, upper");
    Tolerance tol;
    if (const toml::node* n = t.Get("lower"))
      tol.lower = Value(*n, dim, model->outputs[o].unit, t.Where("lower"));
    if (const toml::node* n = t.Get("upper"))
      tol.upper = Value(*n, dim, model->outputs[o].unit, t.Where("upper"));
    if (std::isinf(tol.lower) && std::isinf(tol.upper))
      throw InputError(t.WhereSelf() + ": give lower, upper or both");
    if (!(tol.lower < tol.upper)) throw InputError(t.Where("upper") + ": must be above lower");
    t.Finish();
    s.Finish();
    outputs.Get(name);
    job.tolerances[o] = tol;
  }
  outputs.Finish();
}

}  // namespace

bool IsCustomModelJob(std::string_view text) {
  try {
    const toml::table root = ParseToml(text, "");
    return root.contains("model") && !root.contains("tracker");
  } catch (const InputError&) {
    return false;  // the job's reader says what is wrong
  }
}

bool IsCustomModelJobFile(const std::string& path) {
  return IsCustomModelJob(ReadTextFile(path, "the job file"));
}

CustomJob ParseCustomJob(std::string_view text, const std::string& file,
                         const std::filesystem::path& base_dir) {
  toml::table root = ParseToml(text, file);
  CustomJob job;
  job.file = file;
  job.base_dir = base_dir;
  Section top(root, file, "");
  top.set_hint("job, model, observations, inputs, correlations, outputs, monte_carlo, output");
  ReadJobMeta(top, job.name, &job.description, std::filesystem::path(file).stem().string(), &job.record);
  CustomJobReader reader(top, job);
  reader.FindCustomModel();
  reader.SetSpecValues();
  reader.ReadObservationsFile();
  reader.ReadInputs();
  reader.ReadCorrelations();
  reader.SetMonteCarloInputs();
  reader.ReadTolerances();
  ReadMonteCarlo(top, job.monte_carlo);
  ReadOutput(top, job.output);
  top.Finish();
  return job;
}

CustomJob LoadCustomJob(const std::string& path) {
  const std::string text = ReadTextFile(path, "the job file");
  return ParseCustomJob(text, path, BaseDirectory(path));
}

}  // namespace vlt
