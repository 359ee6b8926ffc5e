// The Python module `vlt` (pybind11; docs/python.md): jobs run through the same engine as the
// `vlt` command, results as dicts and numpy arrays, the GUM of many points from a numpy array of
// readings in one call (the GIL released while the engine runs), and the models' metadata.
#include <pybind11/eval.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cstdint>
#include <fstream>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>

#include <toml++/toml.h>

#include "vlt/calibration.h"
#include "vlt/custom_job.h"
#include "vlt/error.h"
#include "vlt/input_file.h"
#include "vlt/gum.h"
#include "vlt/inverse.h"
#include "vlt/job.h"
#include "vlt/models.h"
#include "vlt/planning.h"
#include "vlt/network.h"
#include "vlt/results.h"

namespace py = pybind11;

namespace {

// A Python value as a TOML node (a job given as a dict): dict -> table, list/tuple -> array,
// str, bool, int, float. Anything else is a ValueError naming the key.
toml::table TableOf(const py::dict& d, const std::string& where);

void Insert(toml::table& t, const std::string& key, const py::handle& v, const std::string& where);

toml::array ArrayOf(const py::sequence& s, const std::string& where) {
  toml::array a;
  for (std::size_t i = 0; i < s.size(); ++i) {
    const py::handle v = s[i];
    const std::string at = where + "[" + std::to_string(i) + "]";
    if (py::isinstance<py::dict>(v))
      a.push_back(TableOf(v.cast<py::dict>(), at));
    else if (py::isinstance<py::bool_>(v))
      a.push_back(v.cast<bool>());
    else if (py::isinstance<py::int_>(v))
      a.push_back(v.cast<std::int64_t>());
    else if (py::isinstance<py::float_>(v))
      a.push_back(v.cast<double>());
    else if (py::isinstance<py::str>(v))
      a.push_back(v.cast<std::string>());
    else if (py::isinstance<py::list>(v) || py::isinstance<py::tuple>(v))
      a.push_back(ArrayOf(v.cast<py::sequence>(), at));
    else
      throw vlt::InputError(at + ": a job value must be a dict, list, str, bool, int or float");
  }
  return a;
}

void Insert(toml::table& t, const std::string& key, const py::handle& v, const std::string& where) {
  if (py::isinstance<py::dict>(v))
    t.insert(key, TableOf(v.cast<py::dict>(), where));
  else if (py::isinstance<py::bool_>(v))
    t.insert(key, v.cast<bool>());
  else if (py::isinstance<py::int_>(v))
    t.insert(key, v.cast<std::int64_t>());
  else if (py::isinstance<py::float_>(v))
    t.insert(key, v.cast<double>());
  else if (py::isinstance<py::str>(v))
    t.insert(key, v.cast<std::string>());
  else if (py::isinstance<py::list>(v) || py::isinstance<py::tuple>(v))
    t.insert(key, ArrayOf(v.cast<py::sequence>(), where));
  else
    throw vlt::InputError(where + ": a job value must be a dict, list, str, bool, int or float");
}

toml::table TableOf(const py::dict& d, const std::string& where) {
  toml::table t;
  for (const auto& [k, v] : d) {
    const std::string key = py::str(k);
    Insert(t, key, v, where.empty() ? key : where + "." + key);
  }
  return t;
}

// A job's TOML text and its name in messages: from a path to a job file, or from a dict.
struct JobText {
  std::string text, file;
  std::filesystem::path base_dir;
};
JobText JobTextOf(const py::object& job, const std::string& base_dir) {
  if (py::isinstance<py::dict>(job)) {
    std::ostringstream text;
    text << TableOf(job.cast<py::dict>(), "");
    return {text.str(), "<dict>", std::filesystem::path(base_dir)};
  }
  if (py::isinstance<py::str>(job) || py::hasattr(job, "__fspath__")) {
    const std::string path = py::str(job).cast<std::string>();
    const std::string text = vlt::ReadInputFile(path, path, "cannot read the job file");
    const std::filesystem::path parent = std::filesystem::path(path).parent_path();
    return {text, path, parent.empty() ? std::filesystem::path(".") : parent};
  }
  throw vlt::InputError("job: expected a path to a job file or a dict");
}

// A tracker job from a path to a job file, or from a dict (relative CSV paths against base_dir).
vlt::Job JobOf(const py::object& job, const std::string& base_dir) {
  if (py::isinstance<py::dict>(job)) {
    const JobText t = JobTextOf(job, base_dir);
    return vlt::ParseJob(t.text, t.file, t.base_dir);
  }
  if (py::isinstance<py::str>(job) || py::hasattr(job, "__fspath__")) {
    return vlt::LoadJob(py::str(job).cast<std::string>());
  }
  throw vlt::InputError("job: expected a path to a job file or a dict");
}

py::object JsonLoads(const std::string& text) { return py::module_::import("json").attr("loads")(text); }

// The expanded uncertainty per axis of a point's GUM result, full or as a run keeps it.
Eigen::Vector3d ExpandedOf(const vlt::PointUncertainty& g) { return g.U_part; }
Eigen::Vector3d ExpandedOf(const vlt::PointGum& g) { return g.U_part(); }

// "estimate" (N, 3) m, "covariance" (N, 3, 3) m^2, "U" (N, 3) m of N GUM results (part frame);
// `at(i)`: point i's (vlt::PointUncertainty or vlt::PointGum).
template <typename PointAt>
void AddGumArrays(py::dict& out, std::size_t count, const PointAt& at) {
  const auto n = static_cast<py::ssize_t>(count);
  py::array_t<double> estimate({n, py::ssize_t{3}}), covariance({n, py::ssize_t{3}, py::ssize_t{3}}),
      expanded({n, py::ssize_t{3}});
  auto e = estimate.mutable_unchecked<2>();
  auto c = covariance.mutable_unchecked<3>();
  auto u = expanded.mutable_unchecked<2>();
  for (py::ssize_t i = 0; i < n; ++i) {
    const auto& g = at(static_cast<std::size_t>(i));
    const Eigen::Vector3d U = ExpandedOf(g);
    for (int a = 0; a < 3; ++a) {
      e(i, a) = g.part[a];
      u(i, a) = U[a];
      for (int b = 0; b < 3; ++b) c(i, a, b) = g.cov_part(a, b);
    }
  }
  out["estimate"] = estimate;
  out["covariance"] = covariance;
  out["U"] = expanded;
}

// results.json as a dict, plus "points": the objects of points.jsonl, and numpy arrays of every
// point: "names", "estimate" (N, 3) m, "covariance" (N, 3, 3) m^2, "U" (N, 3) m (part frame).
py::dict ResultsDict(const vlt::Results& r) {
  py::dict out = JsonLoads(vlt::ResultsJson(r)).cast<py::dict>();
  py::list points;
  std::istringstream lines(vlt::PointsJsonl(r));
  for (std::string line; std::getline(lines, line);) points.append(JsonLoads(line));
  out["points"] = points;
  py::list names;
  for (const vlt::PointResult& p : r.points) names.append(p.input.name);
  out["names"] = names;
  AddGumArrays(out, r.points.size(),
               [&](std::size_t i) -> const vlt::PointGum& { return r.points[i].gum; });
  return out;
}

py::dict QuantityDict(const vlt::QuantityInfo& q, bool defaults) {
  py::dict d;
  d["name"] = q.name;
  d["unit"] = q.unit;
  d["quantity"] = q.quantity;
  d["description"] = q.description;
  if (defaults) {
    d["default_estimate"] = q.default_estimate;
    d["default_u"] = q.default_u;
    d["default_distribution"] = q.default_distribution;
  }
  return d;
}

// The file `name` of an all-or-none set of output files (results.json, calibration.toml, ...).
const std::string& FileNamed(const std::vector<std::pair<std::string, std::string>>& files,
                             const std::string& name) {
  for (const auto& [file, content] : files)
    if (file == name) return content;
  throw std::logic_error("no " + name + " among the outputs");
}

// The command line's rules for the numbers a caller passes (docs/cli.md, `--threads`, `--trials`):
// threads 0 .. 1024 (0: every hardware thread), trials 0 .. 10^9 (0: adaptive). A number past them
// is a ValueError with one line, as the command line refuses it (exit 2), never a run that asks the
// system for 10^5 threads.
std::optional<int> CheckedThreads(std::optional<int> threads, const std::string& function) {
  if (threads && (*threads < 0 || *threads > 1024)) {
    throw vlt::InputError(function + ": threads: " + std::to_string(*threads) +
                          " is not an integer in 0 .. 1024 (0: every hardware thread)");
  }
  return threads;
}

std::optional<std::int64_t> CheckedTrials(std::optional<std::int64_t> trials, const std::string& function) {
  if (trials && (*trials < 0 || *trials > 1000000000)) {
    throw vlt::InputError(function + ": trials: " + std::to_string(*trials) +
                          " is not an integer in 0 .. 1000000000 (0: adaptive)");
  }
  return trials;
}

}  // namespace

PYBIND11_MODULE(vlt, m) {
  m.doc() = "vlt — the Virtual Laser Tracker: GUM and Monte Carlo uncertainty of laser tracker measurements";
  m.attr("__version__") = VLT_VERSION;
  // Bad input is a ValueError carrying vlt's one-line message "<file>: <key>: <problem>".
  py::register_exception<vlt::InputError>(m, "InputError", PyExc_ValueError);
  py::register_exception<vlt::NumericalError>(m, "NumericalError", PyExc_ArithmeticError);

  m.def(
      "models",
      [] {
        py::list out;
        std::vector<const vlt::ModelInfo*> all(vlt::AllModels().begin(), vlt::AllModels().end());
        const std::size_t built_in = all.size();
        for (const vlt::BuiltModel& b : vlt::BuiltModels()) {
          // A cache entry that cannot be loaded is a warning, as in `vlt model list`.
          try {
            if (const vlt::ModelInfo* info = vlt::FindModel(b.name)) all.push_back(info);
          } catch (const vlt::InputError& e) {
            if (PyErr_WarnEx(PyExc_RuntimeWarning, e.what(), 1) != 0) throw py::error_already_set();
          }
        }
        for (std::size_t k = 0; k < all.size(); ++k) {
          const vlt::ModelInfo* info = all[k];
          py::dict d;
          d["name"] = info->name;
          d["kind"] = info->kind;
          d["built"] = k >= built_in;
          d["description"] = info->description;
          py::list readings, params, outputs;
          for (int i = 0; i < info->num_readings; ++i)
            readings.append(QuantityDict(info->readings[i], false));
          for (int i = 0; i < info->num_params; ++i) params.append(QuantityDict(info->params[i], true));
          for (int i = 0; i < info->num_outputs; ++i) outputs.append(QuantityDict(info->outputs[i], false));
          d["readings"] = readings;
          d["params"] = params;
          d["outputs"] = outputs;
          out.append(d);
        }
        return out;
      },
      "Every model, compiled in or built (vlt.models.build, `vlt model build`; 'built': True): name, kind,\n"
      "description, readings, params (with their defaults, SI), outputs.");

  m.def(
      "run",
      [](const py::object& job, bool monte_carlo, std::optional<std::int64_t> trials,
         std::optional<std::uint64_t> seed, std::optional<int> threads, const std::string& base_dir) {
        vlt::RunOptions options;
        options.monte_carlo = monte_carlo;
        options.trials = CheckedTrials(trials, "run");
        options.seed = seed;
        options.threads = CheckedThreads(threads, "run");
        options.compute_map = false;
        const JobText text = JobTextOf(job, base_dir);
        if (vlt::IsCustomModelJob(text.text)) {
          // A custom-model job ([model], docs/custom-models.md): its results.json as a dict.
          const vlt::CustomJob custom = vlt::ParseCustomJob(text.text, text.file, text.base_dir);
          std::string json;
          {
            py::gil_scoped_release release;
            const vlt::CustomResults results = vlt::RunCustomJob(custom, options);
            for (const auto& [name, content] : vlt::ResultFiles(results)) {
              if (name == "results.json") json = content;
            }
          }
          return JsonLoads(json).cast<py::dict>();
        }
        const vlt::Job parsed = JobOf(job, base_dir);
        vlt::Results results;
        {
          py::gil_scoped_release release;
          results = vlt::RunJob(parsed, options);
        }
        return ResultsDict(results);
      },
      py::arg("job"), py::arg("monte_carlo") = true, py::arg("trials") = py::none(),
      py::arg("seed") = py::none(), py::arg("threads") = py::none(), py::arg("base_dir") = ".",
      "Runs a job (a path to a job file, or the job as a dict) like `vlt run`, without writing files.\n"
      "A custom-model job ([model]) returns its results.json as a dict (\"schema\": "
      "\"vlt-custom-results/1\"). A tracker job:\n"
      "Returns results.json as a dict (docs/results.md) with 'points' (the objects of points.jsonl) and "
      "numpy\n"
      "arrays 'estimate' (N, 3) m, 'covariance' (N, 3, 3) m^2, 'U' (N, 3) m, part frame, and 'names'.");

  m.def(
      "simulate",
      [](const std::string& model_name,
         const py::array_t<double, py::array::c_style | py::array::forcecast>& points,
         const std::map<std::string, double>& params, const std::string& face_name) {
        const vlt::ModelInfo* model = vlt::FindModel(model_name);
        if (model == nullptr || std::string(model->kind) != "tracker") {
          throw vlt::InputError("model: '" + model_name + "' is not a tracker model (vlt.models())");
        }
        if (points.ndim() != 2 || points.shape(1) != 3) {
          throw vlt::InputError("points: expected an array of shape (N, 3) in metres, tracker frame");
        }
        std::vector<double> x(static_cast<std::size_t>(model->num_params), 0.0);
        for (const auto& [name, value] : params) {
          int k = 0;
          while (k < model->num_params && name != model->params[k].name) ++k;
          if (k == model->num_params)
            throw vlt::InputError("params: '" + name + "' is not a parameter of " + model_name);
          vlt::CheckValueMagnitude(value, "simulate: params: " + name);
          x[static_cast<std::size_t>(k)] = value;
        }
        const vlt::Face face = vlt::ParseFace(face_name.c_str(), "face");
        const auto n = points.shape(0);
        py::array_t<double> readings({n, py::ssize_t{3}}), reported({n, py::ssize_t{3}});
        auto p = points.unchecked<2>();
        auto rd = readings.mutable_unchecked<2>();
        auto rp = reported.mutable_unchecked<2>();
        for (py::ssize_t i = 0; i < n; ++i)
          vlt::CheckTrackerPoint({p(i, 0), p(i, 1), p(i, 2)}, "simulate: points[" + std::to_string(i) + "]");
        {
          py::gil_scoped_release release;
          const std::vector<double> zero(static_cast<std::size_t>(model->num_params), 0.0);
          for (py::ssize_t i = 0; i < n; ++i) {
            // What the tracker reads at the true point with this error state, and what its nominal
            // model (every parameter 0) reports from those readings: `vlt simulate`.
            const std::array<double, 3> r =
                vlt::InverseReadings(*model, x.data(), {p(i, 0), p(i, 1), p(i, 2)}, face);
            double y[3];
            model->forward(r.data(), zero.data(), y);
            for (int a = 0; a < 3; ++a) {
              rd(i, a) = r[static_cast<std::size_t>(a)];
              rp(i, a) = y[a];
            }
          }
        }
        py::dict out;
        out["readings"] = readings;
        out["reported"] = reported;
        return out;
      },
      py::arg("model"), py::arg("points"), py::arg("params") = std::map<std::string, double>{},
      py::arg("face") = "front",
      "What a tracker with an error state reads and reports (`vlt simulate`): points (N, 3) true reflector\n"
      "centres, tracker frame, m; params {name: value in SI} (others 0) -> dict of 'readings' (N, 3) =\n"
      "range [m], azimuth [rad], elevation [rad] and 'reported' (N, 3) m, the nominal model's coordinates.");

  m.def(
      "gum",
      [](const py::object& job,
         const py::array_t<double, py::array::c_style | py::array::forcecast>& readings,
         std::optional<int> threads, const std::string& base_dir) {
        if (readings.ndim() != 2 || readings.shape(1) != 3) {
          throw vlt::InputError(
              "readings: expected an array of shape (N, 3): range [m], azimuth [rad], elevation [rad]");
        }
        const vlt::Job parsed = JobOf(job, base_dir);
        const auto n = static_cast<std::size_t>(readings.shape(0));
        std::vector<vlt::PointReadings> points(n);
        auto r = readings.unchecked<2>();
        for (std::size_t i = 0; i < n; ++i) {
          points[i].name = "#" + std::to_string(i);
          points[i].readings = {r(i, 0), r(i, 1), r(i, 2)};
          // The command line's rule for every reading (vlt/job.h CheckReadings): finite, range in
          // (0, 10 km], angles within +-720 deg.
          vlt::CheckReadings({r(i, 0), r(i, 1), r(i, 2)}, "gum: readings[" + std::to_string(i) + "]",
                             {"range [m]", "azimuth [rad]", "elevation [rad]"});
        }
        std::vector<vlt::PointUncertainty> gum;
        {
          py::gil_scoped_release release;
          const vlt::MeasurementModel model(parsed.setup);
          vlt::GumOptions options;
          options.coverage_probability = parsed.monte_carlo.coverage_probability;
          options.budgets = false;
          options.threads = CheckedThreads(threads, "gum").value_or(parsed.monte_carlo.threads);
          gum = vlt::PropagatePoints(model, points, options);
        }
        py::dict out;
        AddGumArrays(out, n, [&](std::size_t i) -> const vlt::PointUncertainty& { return gum[i]; });
        return out;
      },
      py::arg("job"), py::arg("readings"), py::arg("threads") = py::none(), py::arg("base_dir") = ".",
      "The GUM of many points at once with the tracker, noise, environment and pose of `job`:\n"
      "readings (N, 3) = range [m], azimuth [rad], elevation [rad] -> dict of 'estimate' (N, 3) m,\n"
      "'covariance' (N, 3, 3) m^2, 'U' (N, 3) m (k of the job's coverage probability), part frame.");

  m.def(
      "network",
      [](const std::string& path, std::optional<bool> robust, std::optional<int> threads) {
        vlt::NetworkJob job = vlt::LoadNetworkJob(path);
        if (robust) job.network.robust = *robust;
        std::string json;
        {
          py::gil_scoped_release release;
          const vlt::NetworkResult result = vlt::AdjustNetwork(job.network);
          std::optional<vlt::NetworkMonteCarlo> mc;
          if (job.monte_carlo_trials > 0) {
            mc = vlt::ValidateNetworkByMonteCarlo(job.network, result, job.monte_carlo_trials,
                                                  job.monte_carlo_seed,
                                                  CheckedThreads(threads, "network").value_or(0));
          }
          const std::vector<vlt::NetworkTaskResult> tasks = vlt::NetworkTasks(job.tasks, result, job.file);
          json = FileNamed(vlt::network_outputs::NetworkFiles(job, result, tasks, vlt::RunCreatedTime(),
                                                              mc ? &*mc : nullptr),
                           "results.json");
        }
        return JsonLoads(json).cast<py::dict>();
      },
      py::arg("path"), py::arg("robust") = py::none(), py::arg("threads") = py::none(),
      "Adjusts a network file like `vlt network` (docs/network.md), without writing files: its\n"
      "results.json as a dict (\"schema\": \"vlt-network/1\": targets, stations, distances, robust, ...).\n"
      "robust: override [network] robust (False: keep every observation).");

  m.def(
      "plan",
      [](const std::string& path, std::optional<int> threads) {
        vlt::Job job = vlt::LoadJob(path);
        if (!job.optimize)
          throw vlt::InputError(job.file +
                                ": optimize: the job has no [optimize] section (docs/planning.md)");
        py::dict out;
        std::vector<std::pair<std::string, std::string>> files;
        {
          py::gil_scoped_release release;
          const vlt::StationPlan plan =
              vlt::PlanStation(job, CheckedThreads(threads, "plan").value_or(job.monte_carlo.threads));
          files = vlt::PlanFiles(plan);
        }
        out["plan"] = JsonLoads(FileNamed(files, "plan.json"));
        out["planned_job_toml"] = FileNamed(files, "planned_job.toml");
        out["warnings"] = job.warnings;
        return out;
      },
      py::arg("path"), py::arg("threads") = py::none(),
      "Plans the station of a job with [optimize] like `vlt plan` (docs/planning.md), without writing\n"
      "files: {'plan': plan.json as a dict (recommended station, objective, search, map), "
      "'planned_job_toml':\n"
      "the job with the recommended station, 'warnings': the job's warnings}.");

  m.def(
      "calibrate",
      [](const std::string& path) {
        const vlt::CalibrationJob job = vlt::LoadCalibrationJob(path);
        py::dict out;
        std::vector<std::pair<std::string, std::string>> files;
        {
          py::gil_scoped_release release;
          const vlt::CalibrationResult result = vlt::Calibrate(job.data, job.options);
          vlt::CalibrationProvenance provenance;
          provenance.instrument = job.instrument;
          provenance.created = vlt::RunCreatedTime();
          provenance.vlt_version = VLT_VERSION;
          for (const std::string& f : job.data_files)
            provenance.data_files.emplace_back(f, vlt::Sha256File(f));
          files = vlt::calibration_outputs::CalibrationFiles(job, result, provenance);
        }
        out["results"] = JsonLoads(FileNamed(files, "results.json"));
        out["calibration_toml"] = FileNamed(files, "calibration.toml");
        return out;
      },
      py::arg("path"),
      "Identifies a tracker's error parameters like `vlt calibrate` (docs/calibration.md), without\n"
      "writing files: {'results': results.json as a dict, 'calibration_toml': the calibration file's text}\n"
      "(its [calibration] fits says whether the calibration fits its data).");

  m.def(
      "build_model",
      [](const std::string& spec) {
        vlt::ModelBuild b;
        {
          py::gil_scoped_release release;
          b = vlt::BuildModel(spec);
        }
        py::dict out;
        out["name"] = b.name;
        out["library"] = b.library.string();
        out["cached"] = b.cached;
        out["seconds"] = b.seconds;
        return out;
      },
      py::arg("spec"),
      "Builds a model from its spec (TOML) into the model cache like `vlt model build` (also as\n"
      "vlt.models.build): {'name', 'library', 'cached', 'seconds'}; then every function takes it by name.");

  // Arguments of the wrong type: pybind11 answers with a multi-line TypeError that lists the
  // overloads and the values given; vlt's rule is one line (issue 32 item 5). Each function is
  // wrapped to re-raise it as "<function>: arguments of the wrong type; expected <signature>".
  py::exec(R"(
import functools as _functools

def _one_line_type_errors(f):
    @_functools.wraps(f)
    def call(*args, **kwargs):
        try:
            return f(*args, **kwargs)
        except TypeError as e:
            text = str(e)
            if "incompatible function arguments" not in text:
                raise
            lines = [line.strip() for line in text.splitlines() if line.strip()]
            expected = next((line.split(". ", 1)[1] for line in lines if line[:1].isdigit() and ". " in line), "")
            given = ", ".join([type(a).__name__ for a in args] + [k + "=" + type(v).__name__ for k, v in kwargs.items()])
            raise TypeError(f.__name__ + ": arguments of the wrong type (" + given + "); expected " + expected) from None
    return call

for _name in ("models", "run", "simulate", "gum", "network", "plan", "calibrate", "build_model"):
    globals()[_name] = _one_line_type_errors(globals()[_name])
models.build = build_model  # vlt.models.build(spec), as the command line's `vlt model build`
del _name, _functools, _one_line_type_errors
)",
           m.attr("__dict__"));
}
