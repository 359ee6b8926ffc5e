// instrument/readers.cc — the instrument sections of a job file: [tracker] (model, error parameters,
// correlations, range noise), [environment] (air), [station] (pose), [part] (thermal expansion),
// and [correlations] between any of their inputs.
// Keys and units: docs/job-file.md.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>

#include <toml++/toml.h>

#include "base/section.h"
#include "instrument/readers.h"
#include "vlt/error.h"
#include "vlt/input_file.h"
#include "vlt/job.h"
#include "vlt/calibration.h"
#include "vlt/models.h"
#include "vlt/refractive_index.h"
#include "vlt/units.h"

namespace vlt::instrument_internal {

// "5 um + 0.5 um/m" -> (a, b). Either term may be absent; a '+' inside an exponent is not a split.
void ParseLengthPlusRatio(const std::string& text, const std::string& where, double& a, double& b) {
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
        throw InputError(
            where + ": '" + term +
            "' is neither a length nor a ratio; expected '<length> + <ratio>', e.g. \"5 um + 0.5 um/m\"");
      }
    }
    bool& have = is_length ? have_a : have_b;
    if (have)
      throw InputError(where + ": two " + std::string(is_length ? "length" : "ratio") +
                       " terms; expected '<length> + <ratio>'");
    have = true;
    (is_length ? a : b) = v;
  }
  CheckUncertainty(a, where);
  CheckUncertainty(b, where);
}

// One correlation group table: `<inputs_key>` = [names...] and matrix = [[...], ...] (m x m
// numbers). What the names and the matrix mean is checked with every other group by
// SharedCorrelation (vlt/measurement_model.h), the one checker of every spelling.
CorrelationGroup ReadCorrelationGroup(Section& parent, const std::string& name,
                                      const std::string& inputs_key) {
  Section g = parent.Sub(name, true);
  g.set_hint(inputs_key + ", matrix");
  CorrelationGroup group;
  group.name = name;
  group.where_inputs = g.Where(inputs_key);
  group.where_matrix = g.Where("matrix");
  const toml::node& names_node = g.Require(inputs_key);
  if (!names_node.is_array()) {
    throw InputError(group.where_inputs + ": expected an array of " +
                     (inputs_key == "parameters" ? "parameter" : "input") + " names");
  }
  for (const toml::node& e : *names_node.as_array()) group.inputs.push_back(AsString(e, group.where_inputs));
  const int m = static_cast<int>(group.inputs.size());
  const toml::node& mat_node = g.Require("matrix");
  const std::string& wm = group.where_matrix;
  if (!mat_node.is_array() || static_cast<int>(mat_node.as_array()->size()) != m) {
    throw InputError(wm + ": expected " + std::to_string(m) + " rows of " + std::to_string(m) +
                     " numbers (one per name in " + inputs_key + ")");
  }
  group.matrix.resize(m, m);
  for (int i = 0; i < m; ++i) {
    const toml::node& row = *mat_node.as_array()->get(i);
    if (!row.is_array() || static_cast<int>(row.as_array()->size()) != m) {
      throw InputError(wm + ": row " + std::to_string(i + 1) + ": expected " + std::to_string(m) +
                       " numbers");
    }
    for (int j = 0; j < m; ++j) group.matrix(i, j) = AsNumber(*row.as_array()->get(j), wm);
  }
  g.Finish();
  return group;
}

namespace {

// The reading of [tracker]: the model, then its parameters from the model's defaults, a
// calibration file and the job's overrides, in that order.
struct TrackerReader {
  Section& tracker;
  Job& job;
  std::string model_name;
  const ModelInfo* model = nullptr;
  std::vector<Dimension> dims;                        // of each parameter
  std::vector<bool> calibrated;                       // given by the calibration file
  std::string calibration_path;                       // that file, for messages about its values
  const std::string* calibration_override = nullptr;  // `vlt run --calibration`

  TrackerReader(Section& tracker, Job& job) : tracker(tracker), job(job) {}
  void FindTrackerModel();
  void SetDefaultParameters();
  void ReadCalibrationFile();
  void ReadParameterOverrides();
  void ReadParameterCorrelations();
  void WarnImplausibleParameters();
};

void TrackerReader::FindTrackerModel() {
  model_name = AsString(tracker.Require("model"), tracker.Where("model"));
  model = FindModel(model_name);
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
}

void TrackerReader::SetDefaultParameters() {
  MeasurementSetup& setup = job.setup;
  setup.model = model;
  setup.params.clear();
  setup.correlations.clear();
  for (int k = 0; k < model->num_params; ++k) {
    const QuantityInfo& q = model->params[k];
    Dimension dim = DimensionOfQuantity(q.quantity, tracker.Where("model"));
    dims.push_back(dim);
    UncertainInput input = MakeInput(q.name, "parameter", dim, q.default_estimate, q.default_u);
    input.unit = q.unit;
    input.distribution = q.default_distribution ? q.default_distribution : "normal";
    input.shape = q.default_shape;
    setup.params.push_back(input);
  }
  calibrated.assign(model->num_params, false);
}

// [tracker] calibration = "<file>": estimates, u and correlation from `vlt calibrate`.
// `vlt run --calibration FILE` replaces the key (FILE as given on the command line, relative to the
// working directory): the calibration just identified, without editing the job.
// [tracker] profile = "<name>": the prior of a built-in instrument profile (docs/profiles.md), read
// as a calibration file; `--calibration` replaces it as it replaces `calibration`.
void TrackerReader::ReadCalibrationFile() {
  const toml::node* n = tracker.Get("calibration");
  const toml::node* profile = tracker.Get("profile");
  if (n && profile) {
    throw InputError(tracker.Where("profile") +
                     ": a job takes its parameters from a calibration or from a profile, not both");
  }
  if (!n && !profile && calibration_override == nullptr) return;
  MeasurementSetup& setup = job.setup;
  LoadedCalibration c;
  std::string where, sha256;
  if (profile && calibration_override == nullptr) {
    where = tracker.Where("profile");
    const std::string name = AsString(*profile, where);
    const std::string* text = nullptr;
    std::string names;
    for (const auto& [known, prior] : BuiltInProfiles()) {
      if (known == name) text = &prior;
      names += (names.empty() ? "" : ", ") + known;
    }
    if (text == nullptr)
      throw InputError(where + ": unknown profile '" + name + "' (built in: " + names +
                       "; a profile of your own: vlt prior, then [tracker] calibration)");
    calibration_path = "profile '" + name + "' (built in)";
    c = LoadCalibrationText(*text, calibration_path);
    sha256 = Sha256Bytes(*text);
  } else {
    where = calibration_override ? std::string("--calibration") : tracker.Where("calibration");
    const std::filesystem::path path = calibration_override ? std::filesystem::path(*calibration_override)
                                                            : job.base_dir / AsString(*n, where);
    if (const std::string problem = InputFileProblem(path.string()); !problem.empty())
      throw InputError(where + ": cannot read '" + path.string() + "': " + problem);
    c = LoadCalibrationFile(path.string());
    calibration_path = path.string();
    sha256 = Sha256File(calibration_path);
  }
  if (c.edited) {
    job.warnings.push_back(
        calibration_path +
        ": calibration.content_sha256: the file was edited after vlt wrote it (its text no "
        "longer matches the checksum vlt recorded): its values may not be the calibration's");
  }
  if (!c.fits) {
    job.warnings.push_back(where + ": '" + calibration_path + "' is a calibration that does not fit its data (" +
                           (c.fit_problem.empty() ? std::string("fits = false") : c.fit_problem) +
                           "): its uncertainties understate the tracker's errors");
  }
  if (c.model != model->name) {
    throw InputError(where + ": the calibration file is for model '" + c.model + "', the tracker is model '" +
                     model_name + "'");
  }
  std::vector<int> index;
  for (const std::string& name : c.names) {
    const int k = FindParam(*model, name);
    if (k < 0)
      throw InputError(where + ": parameter '" + name +
                       "' of the calibration file is not a parameter of model '" + model_name + "'");
    if (calibrated[k])
      throw InputError(where + ": parameter '" + name + "' appears twice in the calibration file");
    calibrated[k] = true;
    index.push_back(k);
  }
  for (std::size_t i = 0; i < index.size(); ++i) {
    UncertainInput& input = setup.params[index[i]];
    input.estimate = c.estimates[i];
    input.u = c.u[i];
    input.distribution = "normal";  // the calibration's covariance: multivariate normal
    input.shape = 0.0;
  }
  // The file's correlation: the correlation group "calibration" of the parameters it gives.
  if (!c.names.empty()) {
    setup.correlations.push_back({"calibration", c.names, c.correlation, where, where});
  }
  job.calibration = CalibrationSource{calibration_path, sha256, c.instrument, c.created, c.kind};
  job.input_files.push_back({"calibration", job.calibration->file, job.calibration->sha256});
}

// [tracker.parameters.<name>]: override the model's defaults.
void TrackerReader::ReadParameterOverrides() {
  Section params = tracker.Sub("parameters", false);
  if (!params.exists()) return;
  for (auto&& [key, node] : params.table()) {
    (void)node;
    std::string name(key.str());
    int k = FindParam(*model, name);
    if (k < 0) {
      std::string list;
      for (int j = 0; j < model->num_params; ++j)
        list += (j ? ", " : "") + std::string(model->params[j].name);
      throw InputError(params.Where(name) + ": unknown parameter '" + name + "' of model '" + model_name +
                       "' (parameters: " + list + ")");
    }
    if (calibrated[k]) {
      throw InputError(params.Where(name) + ": parameter '" + name +
                       "' is given by the calibration file (tracker.calibration); remove one of the two");
    }
    Dimension u_dim = dims[k] == Dimension::kTemperature ? Dimension::kTemperatureDifference : dims[k];
    ReadUncertain(params, name, dims[k], u_dim, job.setup.params[k]);
  }
  params.Finish();
}

// [tracker.correlations.<name>]: parameters = [...], matrix = [[...], ...]: a correlation group
// of parameters ([correlations.<name>] of ReadCorrelations without the restriction).
void TrackerReader::ReadParameterCorrelations() {
  Section corr = tracker.Sub("correlations", false);
  if (!corr.exists()) return;
  for (auto&& [key, node] : corr.table()) {
    (void)node;
    CorrelationGroup group = ReadCorrelationGroup(corr, std::string(key.str()), "parameters");
    for (const std::string& name : group.inputs) {
      if (FindParam(*model, name) < 0) {
        throw InputError(group.where_inputs + ": unknown parameter '" + name + "' of model '" + model_name +
                         "' (other inputs: [correlations." + group.name + "] with inputs = [...])");
      }
    }
    job.setup.correlations.push_back(std::move(group));
  }
  corr.Finish();
}

// [tracker.noise]: reading noise of every point.
void ReadReadingNoise(Section& noise, ReadingNoise& reading_noise) {
  noise.set_hint("range, range_a, range_b, azimuth, elevation");
  const toml::node* range = noise.Get("range");
  const toml::node* range_a = noise.Get("range_a");
  const toml::node* range_b = noise.Get("range_b");
  if (range && (range_a || range_b)) {
    throw InputError(noise.Where("range") + ": give either range or range_a/range_b, not both");
  }
  if (range) {
    if (range->is_string()) {
      ParseLengthPlusRatio(*range->value<std::string>(), noise.Where("range"), reading_noise.range_a,
                           reading_noise.range_b);
    } else {
      reading_noise.range_a = AsQuantity(*range, Dimension::kLength, noise.Where("range"));
      reading_noise.range_b = 0.0;
      CheckUncertainty(reading_noise.range_a, noise.Where("range"));
    }
  } else if (range_a || range_b) {
    if (range_a) reading_noise.range_a = AsQuantity(*range_a, Dimension::kLength, noise.Where("range_a"));
    if (range_b) reading_noise.range_b = AsQuantity(*range_b, Dimension::kRatio, noise.Where("range_b"));
    CheckUncertainty(reading_noise.range_a, noise.Where("range_a"));
    CheckUncertainty(reading_noise.range_b, noise.Where("range_b"));
  } else {
    throw InputError(noise.Where("range") + ": required key is missing (e.g. range = \"5 um + 0.5 um/m\")");
  }
  reading_noise.azimuth = AsQuantity(noise.Require("azimuth"), Dimension::kAngle, noise.Where("azimuth"));
  CheckUncertainty(reading_noise.azimuth, noise.Where("azimuth"));
  reading_noise.elevation =
      AsQuantity(noise.Require("elevation"), Dimension::kAngle, noise.Where("elevation"));
  CheckUncertainty(reading_noise.elevation, noise.Where("elevation"));
  noise.Finish();
}

// Implausible but legal (docs/cli.md "Warnings"): a tracker's residual errors are micrometres
// and arcseconds, not millimetres and degrees; such values are usually a unit slip.
void TrackerReader::WarnImplausibleParameters() {
  const MeasurementSetup& setup = job.setup;
  for (std::size_t k = 0; k < setup.params.size(); ++k) {
    const UncertainInput& in = setup.params[k];
    const double size = std::max(std::abs(in.estimate), in.u);
    const std::string quantity = model->params[k].quantity;
    // A value from the calibration file is that file's: its message names it, not the job.
    const std::string where = calibrated[k] ? calibration_path + ": parameter '" + in.name + "'"
                                            : tracker.Where("parameters." + in.name);
    if (quantity == "length" && size > 1e-3) {
      job.warnings.push_back(where + ": " + FormatQuantity(size, Dimension::kLength, "mm", 4) +
                             " is implausible for a tracker error parameter (micrometres expected)");
    } else if (quantity == "angle" && size > 100.0 * 4.84813681109536e-6) {
      job.warnings.push_back(where + ": " + FormatQuantity(size, Dimension::kAngle, "arcsec", 4) +
                             " is implausible for a tracker error parameter (arcseconds expected)");
    } else if (quantity == "ratio" && size > 1e-3) {
      job.warnings.push_back(where + ": " + FormatQuantity(size, Dimension::kRatio, "ppm", 4) +
                             " is implausible for a tracker error parameter (ppm expected)");
    }
  }
}

void WarnImplausibleNoise(const Section& noise, const ReadingNoise& reading_noise,
                          std::vector<std::string>& warnings) {
  if (reading_noise.range_a > 1e-3 || reading_noise.range_b > 1e-4) {
    warnings.push_back(noise.Where("range") +
                       ": range noise above 1 mm or 100 µm/m is implausible for a laser tracker");
  }
  if (std::max(reading_noise.azimuth, reading_noise.elevation) > 100.0 * 4.84813681109536e-6) {
    warnings.push_back(noise.Where("azimuth") +
                       ": angle noise above 100 arcsec is implausible for a laser tracker");
  }
}

}  // namespace

void ReadTracker(Section& top, Job& job, const std::string* calibration) {
  Section tracker = top.Sub("tracker", true);
  tracker.set_hint("model, ranging, calibration, profile, parameters, correlations, noise");
  TrackerReader reader(tracker, job);
  reader.calibration_override = calibration;
  reader.FindTrackerModel();
  // The ranging principle decides the refractive index of the range correction (docs/units.md
  // "Group index"): "ifm" (phase index, the default), "adm" or "aifm" (group index).
  if (const toml::node* n = tracker.Get("ranging")) {
    job.setup.ranging = ParseRanging(AsString(*n, tracker.Where("ranging")), tracker.Where("ranging"));
  }
  reader.SetDefaultParameters();
  reader.ReadCalibrationFile();
  reader.ReadParameterOverrides();
  reader.ReadParameterCorrelations();
  // The groups are checked with the others by ReadCorrelations (a calibration or test job: calibration/reader.cc).
  Section noise = tracker.Sub("noise", true);
  ReadReadingNoise(noise, job.setup.noise);
  reader.WarnImplausibleParameters();
  WarnImplausibleNoise(noise, job.setup.noise, job.warnings);
  tracker.Finish();
}

void ReadEnvironment(Section& top, Job& job) {
  Section s = top.Sub("environment", false);
  if (!s.exists()) return;
  job.setup.environment = ReadAir(s, job.warnings);
}

Environment ReadAir(Section& s, std::vector<std::string>& warnings, const std::string& more_keys) {
  s.set_hint("equation, wavelength, temperature, pressure, humidity, co2" +
             (more_keys.empty() ? std::string() : ", " + more_keys));
  Environment env;
  if (const toml::node* n = s.Get("equation")) {
    // Every spelling of vlt/refractive_index.h; an unknown one is a one-line error listing them.
    env.equation = ParseAirEquation(AsString(*n, s.Where("equation")), s.Where("equation"));
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
  ReadUncertain(s, "temperature", Dimension::kTemperature, Dimension::kTemperatureDifference,
                env.temperature);
  ReadUncertain(s, "pressure", Dimension::kPressure, Dimension::kPressure, env.pressure);
  ReadUncertain(s, "humidity", Dimension::kHumidity, Dimension::kHumidity, env.humidity);
  ReadUncertain(s, "co2", Dimension::kFraction, Dimension::kFraction, env.co2);
  if (env.pressure.estimate <= 0.0) throw InputError(s.Where("pressure") + ": pressure must be positive");
  if (env.humidity.estimate < 0.0 || env.humidity.estimate > 100.0) {
    throw InputError(s.Where("humidity") + ": relative humidity outside 0 .. 100 %");
  }
  // A bare number is in Pa (docs/units.md); 1013 means hPa to most people: say so.
  const toml::node* pressure = s.Get("pressure");
  if (pressure && pressure->is_number() && env.pressure.estimate < 2000.0) {
    char number[32];
    std::snprintf(number, sizeof number, "%g", env.pressure.estimate);
    throw InputError(s.Where("pressure") + ": " + number +
                     " Pa (a bare number is in Pa) is no air pressure at a tracker: did you mean \"" +
                     number + " hPa\"?");
  }
  // The estimates should lie in the equation's published range of validity (docs/units.md): outside
  // it n is computed all the same, as NIST's calculator does, and the job says so.
  const std::string outside = AirValidityProblem(EquationOf(env), AirAtEstimates(env), s.WhereSelf());
  if (!outside.empty()) warnings.push_back(outside + ": n computed outside it");
  s.Finish();
  return env;
}

// A job's station stands still (its pose is one shared input): a station that drifts while it
// measures is adjusted by `vlt network`, whose drift model (docs/network.md N-12) a network of that
// one station carries. Said where a user would write it, not as an unknown key.
constexpr const char* kDriftIsNetwork =
    ": a job takes its station as still; a drifting station and its drift checks are adjusted by "
    "`vlt network` (a network of this one station, docs/network.md N-12)";

void ReadStation(Section& top, Job& job) {
  if (top.Get("drift_check")) throw InputError(top.Where("drift_check") + kDriftIsNetwork);
  Section s = top.Sub("station", false);
  if (!s.exists()) return;
  s.set_hint("rx, ry, rz, tx, ty, tz");
  if (s.Get("drift")) throw InputError(s.Where("drift") + kDriftIsNetwork);
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
  ReadUncertain(s, "temperature", Dimension::kTemperature, Dimension::kTemperatureDifference,
                thermal.temperature);
  if (const toml::node* n = s.Get("reference")) {
    thermal.reference = AsQuantity(*n, Dimension::kTemperature, s.Where("reference"));
  }
  s.Finish();
  // The part's coordinates are divided by 1 + cte (T - T_ref): a factor <= 0 is no expansion.
  const double factor = 1.0 + thermal.cte.estimate * (thermal.temperature.estimate - thermal.reference);
  if (!(factor > 0.0)) {
    throw InputError(s.Where("cte") + ": the thermal expansion factor 1 + cte (T - T_ref) = " +
                     std::to_string(factor) + " is not positive: not a physical expansion");
  }
  if (std::abs(thermal.cte.estimate) > 1e-4 || thermal.cte.u > 1e-4) {
    job.warnings.push_back(s.Where("cte") + ": expansion coefficient " +
                           FormatQuantity(thermal.cte.estimate, Dimension::kPerKelvin, "1/K", 3) +
                           " is implausible for a part (engineering materials: below 3e-5 1/K)");
  }
  job.setup.thermal = thermal;
}

void ReadCorrelations(Section& top, Job& job) {
  MeasurementSetup& setup = job.setup;
  const std::vector<std::string> names = SharedInputNames(setup);
  Section corr = top.Sub("correlations", false);
  if (corr.exists()) {
    for (auto&& [key, node] : corr.table()) {
      (void)node;
      CorrelationGroup group = ReadCorrelationGroup(corr, std::string(key.str()), "inputs");
      // Names that SharedCorrelation would only call unknown: say what is meant.
      for (const std::string& name : group.inputs) {
        if (std::find(names.begin(), names.end(), name) != names.end()) continue;
        const std::size_t dot = name.find('.');
        const std::string head = name.substr(0, dot),
                          tail = dot == std::string::npos ? "" : name.substr(dot + 1);
        const char* prefix = head == "part" ? "thermal." : head == "station" ? "pose." : nullptr;
        if (prefix != nullptr && std::find(names.begin(), names.end(), prefix + tail) != names.end()) {
          throw InputError(group.where_inputs + ": unknown input '" + name +
                           "': inputs are named as results.json and budget.csv name them, '" + prefix + tail +
                           "' for [" + head + "] " + tail);
        }
        const char* section = head == "environment" ? "environment"
                              : head == "pose"      ? "station"
                              : head == "thermal"   ? "part"
                                                    : nullptr;
        const bool absent = (head == "environment" && !setup.environment) ||
                            (head == "pose" && !setup.pose) || (head == "thermal" && !setup.thermal);
        if (section != nullptr && absent) {
          throw InputError(group.where_inputs + ": input '" + name +
                           "' is not an input of this job: it has no [" + section + "] section");
        }
      }
      setup.correlations.push_back(std::move(group));
    }
    corr.Finish();
  }
  // Every group, of the calibration file, [tracker.correlations] and [correlations], through the
  // one checker: names known, an input in one group only, each matrix a correlation matrix.
  SharedCorrelation(names, setup.correlations);
}

}  // namespace vlt::instrument_internal
