// job/network.cc — the network file of `vlt network` (vlt/network.h): several stations of one
// instrument. It reuses the job's readers for [tracker], [environment], [correlations], the
// readings CSV of each station ([readings] keys) and the nominal targets ([plan] keys), so a
// tracker, its readings and a plan are written the same way everywhere. Keys: docs/network.md.
#include <cmath>
#include <map>
#include <set>

#include <toml++/toml.h>

#include "job/job_detail.h"
#include "vlt/error.h"
#include "vlt/network.h"
#include "vlt/units.h"

namespace vlt {

using namespace job_detail;

namespace {

// A length [m] of a table (number in m or a quantity string).
double Length(Section& s, std::string_view key) {
  const double v = AsQuantity(s.Require(key), Dimension::kLength, s.Where(key));
  if (!std::isfinite(v) || std::abs(v) > kMaxRange) throw InputError(s.Where(key) + ": not a plausible coordinate");
  return v;
}

}  // namespace

NetworkJob LoadNetworkJob(const std::string& path) {
  const std::string text = ReadTextFile(path, "the network file");
  toml::table root = ParseToml(text, path);
  Section top(root, path, "");
  top.set_hint("job, tracker, environment, correlations, instrument, network, datum, reference, targets, station, task, output");
  NetworkJob job;
  job.file = path;
  job.text = text;
  job.base_dir = BaseDirectory(path);
  job.input_files.emplace_back("network", path);
  ReadJobMeta(top, job.name, &job.description, std::filesystem::path(path).stem().string());
  Job holder;  // the job readers fill a Job
  holder.file = path;
  holder.base_dir = BaseDirectory(path);
  Network& net = job.network;
  net.where = path;
  net.name = job.name;
  // The instruments: [[instrument]] tables (each with its own [instrument.tracker],
  // [instrument.environment], [instrument.correlations] read as a job's), or the file's single
  // [tracker] (+ [environment], [correlations]) named "tracker".
  auto read_instrument = [&](Section& s, const std::string& name) {
    Job instrument = holder;
    ReadTracker(s, instrument);
    ReadEnvironment(s, instrument);
    ReadCorrelations(s, instrument);
    if (instrument.calibration) job.input_files.emplace_back("calibration", instrument.calibration->file);
    for (const std::string& w : instrument.warnings) job.warnings.push_back(w);
    net.instruments.push_back({name, instrument.setup});
  };
  if (top.Get("instrument")) {
    if (top.Get("tracker")) throw InputError(top.Where("tracker") + ": give either [tracker] (one instrument) or [[instrument]] tables, not both");
    ForEachTable(top, path, "instrument", [&](Section& s) {
      s.set_hint("name, tracker, environment, correlations");
      const std::string name = AsString(s.Require("name"), s.Where("name"));
      if (name.empty() || name.find('.') != std::string::npos) throw InputError(s.Where("name") + ": a non-empty name without '.'");
      for (const NetworkInstrument& other : net.instruments) {
        if (other.name == name) throw InputError(s.Where("name") + ": instrument '" + name + "' defined twice");
      }
      read_instrument(s, name);
    });
  } else {
    read_instrument(top, "tracker");
  }
  const bool several = net.instruments.size() > 1;

  Section settings = top.Sub("network", false);
  if (settings.exists()) {
    settings.set_hint("self_calibrate, coverage_probability, outlier_limit, max_iterations, monte_carlo");
    Section mc = settings.Sub("monte_carlo", false);
    if (mc.exists()) {
      mc.set_hint("trials, seed");
      const std::int64_t trials = AsInteger(mc.Require("trials"), mc.Where("trials"));
      if (trials < 2 || trials > 1000000) throw InputError(mc.Where("trials") + ": must be 2 .. 1000000");
      job.monte_carlo_trials = static_cast<int>(trials);
      if (const toml::node* n = mc.Get("seed")) {
        const std::int64_t seed = AsInteger(*n, mc.Where("seed"));
        if (seed < 0) throw InputError(mc.Where("seed") + ": must be >= 0");
        job.monte_carlo_seed = static_cast<std::uint64_t>(seed);
      }
      mc.Finish();
    }
    if (const toml::node* n = settings.Get("self_calibrate")) {
      const std::string where = settings.Where("self_calibrate");
      if (n->is_boolean()) {
        // true: every error parameter of every instrument with a prior u > 0.
        if (AsBool(*n, where)) {
          for (const NetworkInstrument& instrument : net.instruments) {
            for (const UncertainInput& p : instrument.setup.params) {
              if (p.u > 0.0) net.self_calibrate.push_back(several ? instrument.name + "." + p.name : p.name);
            }
          }
        }
      } else if (n->is_array()) {
        for (const toml::node& e : *n->as_array()) net.self_calibrate.push_back(AsString(e, where));
      } else {
        throw InputError(where + ": expected true, false or an array of input names");
      }
    }
    if (const toml::node* n = settings.Get("coverage_probability")) {
      net.coverage_probability = AsNumber(*n, settings.Where("coverage_probability"));
      if (!(net.coverage_probability > 0.0 && net.coverage_probability < 1.0)) {
        throw InputError(settings.Where("coverage_probability") + ": must be in (0, 1)");
      }
    }
    if (const toml::node* n = settings.Get("outlier_limit")) {
      net.outlier_limit = AsNumber(*n, settings.Where("outlier_limit"));
      if (!(net.outlier_limit > 0.0) || !std::isfinite(net.outlier_limit)) throw InputError(settings.Where("outlier_limit") + ": must be positive");
    }
    if (const toml::node* n = settings.Get("max_iterations")) {
      const std::int64_t v = AsInteger(*n, settings.Where("max_iterations"));
      if (v < 1 || v > 10000) throw InputError(settings.Where("max_iterations") + ": must be 1 .. 10000");
      net.max_iterations = static_cast<int>(v);
    }
    settings.Finish();
  }

  // Offline targets: [targets] with the keys of [plan] (csv or [[targets.point]]).
  Section targets = top.Sub("targets", false);
  if (targets.exists()) {
    Job points;
    points.file = path;
    points.base_dir = holder.base_dir;
    ReadPlan(targets, points, false);
    std::set<std::string> names;
    for (const JobPoint& p : points.points) {
      if (!names.insert(p.name).second) throw InputError(p.where + ": target '" + p.name + "' defined twice");
      job.nominal.emplace_back(p.name, p.nominal);
    }
    for (const InputFile& f : points.input_files) job.input_files.emplace_back("targets csv", f.path);
  }

  // Stations.
  std::vector<std::vector<PlannedSighting>> sees;
  bool any_online = false, any_offline = false;
  ForEachTable(top, path, "station", [&](Section& s) {
    s.set_hint("name, instrument, rx, ry, rz, tx, ty, tz, readings, sees, face");
    NetworkStation st;
    st.where = s.WhereSelf();
    st.name = AsString(s.Require("name"), s.Where("name"));
    if (st.name.empty()) throw InputError(s.Where("name") + ": empty station name");
    if (const toml::node* n = s.Get("instrument")) {
      const std::string name = AsString(*n, s.Where("instrument"));
      st.instrument = -1;
      for (std::size_t k = 0; k < net.instruments.size(); ++k) {
        if (net.instruments[k].name == name) st.instrument = static_cast<int>(k);
      }
      if (st.instrument < 0) throw InputError(s.Where("instrument") + ": unknown instrument '" + name + "'");
    } else if (several) {
      throw InputError(s.Where("instrument") + ": required key is missing (the network has several instruments)");
    }
    for (int c = 0; c < 6; ++c) {
      const Dimension dim = c < 3 ? Dimension::kAngle : Dimension::kLength;
      UncertainInput in = MakeInput(std::string("pose.") + kPoseNames[c], "pose", dim, 0.0, 0.0);
      if (s.Get(kPoseNames[c])) {
        ReadUncertain(s, kPoseNames[c], dim, dim, in);
        st.pose_given = true;
      }
      st.pose(c) = in.estimate;
      st.pose_u(c) = in.u;
    }
    const bool has_readings = s.Get("readings") != nullptr;
    const toml::node* see = s.Get("sees");
    if (has_readings == (see != nullptr)) {
      throw InputError(st.where + ": give either readings (online: a CSV of what the station read) or sees (offline: the "
                       "targets it will read), not " + std::string(has_readings ? "both" : "neither"));
    }
    if ((has_readings && any_offline) || (!has_readings && any_online)) {
      throw InputError(st.where + ": every station gives readings (online) or every station gives sees (offline), not a mix");
    }
    if (has_readings) {
      any_online = true;
      Section readings = s.Sub("readings", true);
      Job r;
      r.file = path;
      r.base_dir = holder.base_dir;
      r.setup = net.instruments[st.instrument].setup;
      ReadReadings(readings, r);
      for (const JobPoint& p : r.points) st.readings.push_back({p.name, p.face, p.readings, p.where});
      job.input_files.emplace_back("readings csv", r.readings_file);
      for (const std::string& w : r.warnings) job.warnings.push_back(w);
      sees.emplace_back();
    } else {
      any_offline = true;
      std::vector<Face> faces = {Face::kFront};
      if (const toml::node* f = s.Get("face")) {
        const std::string text = AsString(*f, s.Where("face"));
        if (text == "both") faces = {Face::kFront, Face::kBack};
        else faces = {ParseFace(text.c_str(), s.Where("face").c_str())};
      }
      std::vector<std::string> names;
      const std::string where = s.Where("sees");
      if (see->is_string() && AsString(*see, where) == "all") {
        for (const auto& [name, x] : job.nominal) names.push_back(name);
      } else if (see->is_array()) {
        for (const toml::node& e : *see->as_array()) names.push_back(AsString(e, where));
      } else {
        throw InputError(where + ": expected \"all\" or an array of target names");
      }
      if (names.empty()) throw InputError(where + ": the station sees no target");
      sees.emplace_back();
      for (const std::string& name : names) {
        for (Face face : faces) sees.back().push_back({name, face, where});
      }
    }
    net.stations.push_back(std::move(st));
  });
  if (net.stations.empty()) throw InputError(path + ": station: required key is missing (give [[station]] tables)");
  job.offline = any_offline;
  if (job.offline && job.nominal.empty()) {
    throw InputError(path + ": targets: required key is missing (offline stations see targets of [targets])");
  }
  if (!job.offline && targets.exists()) {
    throw InputError(path + ": targets: nominal targets are for offline networks (stations with sees); online stations "
                     "give their readings");
  }

  // Datum.
  Section datum = top.Sub("datum", false);
  if (datum.exists()) {
    datum.set_hint("station");
    const std::string name = AsString(datum.Require("station"), datum.Where("station"));
    bool found = false;
    for (NetworkStation& st : net.stations) {
      if (st.name == name) {
        st.datum = true;
        st.pose_given = true;
        found = true;
      }
    }
    if (!found) throw InputError(datum.Where("station") + ": unknown station '" + name + "'");
    datum.Finish();
  }
  ForEachTable(top, path, "reference", [&](Section& s) {
    s.set_hint("target, x, y, z, u");
    NetworkReference ref;
    ref.where = s.WhereSelf();
    ref.target = AsString(s.Require("target"), s.Where("target"));
    ref.position = {Length(s, "x"), Length(s, "y"), Length(s, "z")};
    ref.u = AsQuantity(s.Require("u"), Dimension::kLength, s.Where("u"));
    if (!(ref.u > 0.0) || !std::isfinite(ref.u)) throw InputError(s.Where("u") + ": must be positive");
    net.references.push_back(ref);
  });
  OutputSettings output;
  ReadOutput(top, output);
  job.output_directory = output.directory;

  if (job.offline) {
    for (std::size_t i = 0; i < net.stations.size(); ++i) {
      if (!net.stations[i].pose_given) {
        throw InputError(net.stations[i].where + ": an offline network needs every station's pose (rx, ry, rz, tx, ty, tz; "
                         "omitted ones are 0)");
      }
    }
    PlanNetworkReadings(net, job.nominal, sees);
  }
  // [[task]] as in a job, over the targets the stations read (in order of first reading).
  Job tasks;
  tasks.file = path;
  std::set<std::string> read;
  for (const NetworkStation& st : net.stations) {
    for (const TargetReading& r : st.readings) {
      if (read.insert(r.target).second) tasks.points.push_back({r.target, Face::kFront, {}, {}, r.where});
    }
  }
  ReadTasks(top, tasks);
  job.tasks = tasks.tasks;
  top.Finish();
  return job;
}

}  // namespace vlt
