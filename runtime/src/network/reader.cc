// network/reader.cc — the network file of `vlt network` (vlt/network.h): several stations of one
// instrument. It reuses the job's readers for [tracker], [environment], [correlations], the
// readings CSV of each station ([readings] keys) and the nominal targets ([plan] keys), so a
// tracker, its readings and a plan are written the same way everywhere. Keys: docs/network.md.
#include <algorithm>
#include <cmath>
#include <sstream>
#include <map>
#include <set>

#include <toml++/toml.h>

#include "job/job_detail.h"
#include "base/shared_settings.h"
#include "base/time.h"
#include "vlt/error.h"
#include "vlt/network.h"
#include "vlt/units.h"

namespace vlt {

using namespace base_internal;
using namespace instrument_internal;
using namespace job_internal;  // Section, AsString and the section readers

namespace {

// A length [m] of a table (number in m or a quantity string).
double Length(Section& s, std::string_view key) {
  const double v = AsQuantity(s.Require(key), Dimension::kLength, s.Where(key));
  if (!std::isfinite(v) || std::abs(v) > kMaxRange)
    throw InputError(s.Where(key) + ": not a plausible coordinate");
  return v;
}

// A time of a TOML value (docs/network.md N-12): a number of seconds, a string ParseTime reads
// ("90 min", "10:30:00", "2026-11-26T10:30:00Z") or a TOML date-time / time.
TimeValue Time(const toml::node& node, const std::string& where) {
  if (node.is_number()) {
    const double seconds = AsNumber(node, where);
    if (!std::isfinite(seconds) || std::abs(seconds) > 1e10)
      throw InputError(where + ": not a plausible time");
    return {seconds, TimeKind::kSeconds};
  }
  if (node.is_date_time() || node.is_time()) {
    std::ostringstream text;
    if (node.is_date_time())
      text << *node.as_date_time();
    else
      text << *node.as_time();
    return ParseTime(text.str(), 1.0, where);
  }
  return ParseTime(AsString(node, where), 1.0, where);
}

// A rate of drift [m/s or rad/s]: a number in SI or "<quantity>/<time unit>" ("10 um/h",
// "2 arcsec/h").
double Rate(Section& s, std::string_view key, Dimension dimension) {
  const toml::node& node = s.Require(key);
  const std::string where = s.Where(key);
  if (node.is_number()) return AsNumber(node, where);
  const std::string text = AsString(node, where);
  const std::size_t slash = text.rfind('/');
  if (slash == std::string::npos) {
    throw InputError(where + ": expected a rate such as \"" +
                     std::string(dimension == Dimension::kLength ? "10 um/h" : "2 arcsec/h") + "\"");
  }
  const double amount = ParseQuantity(text.substr(0, slash), dimension, where);
  const double per = ParseQuantity("1 " + text.substr(slash + 1), Dimension::kTime, where);
  return amount / per;
}

// The reading of one network file: the job being filled and what the sections read later need
// from the earlier ones (the instruments of the stations, the targets the offline ones see).
struct NetworkFileReader {
  const std::string& path;
  Section& top;
  NetworkJob& job;
  Network& net;
  Job holder;            // the job readers fill a Job
  bool several = false;  // several instruments: every station names its own
  bool has_targets = false;
  std::vector<std::vector<PlannedSighting>> sees;
  // Offline drift (N-12): the planned time [s] of each sighting of a drifting station, in `sees` order.
  std::vector<std::vector<double>> planned_times;
  bool any_online = false, any_offline = false;
  struct CheckTime {
    const NetworkStation* station;
    double seconds;
    TimeKind kind;
    std::string where;
  };
  std::vector<CheckTime> check_times;  // [[drift_check]] times, knots of their stations' drift

  NetworkFileReader(const std::string& path, Section& top, NetworkJob& job)
      : path(path), top(top), job(job), net(job.network) {
    holder.file = path;
    holder.base_dir = BaseDirectory(path);
  }

  void ReadInstrument(Section& s, const std::string& name);
  void ReadInstruments();
  void ReadValidation(Section& settings);
  void ReadSelfCalibration(Section& settings);
  void ReadLengthTest(Section& settings);
  void ReadSettings();
  void ReadTargets();
  int InstrumentOf(Section& s);
  void ReadPose(Section& s, NetworkStation& st);
  void ReadAirSensors();
  Environment ReadOneAir(Section& air, const NetworkStation& st, std::string& sensor_name);
  void ReadStationAir(Section& s, NetworkStation& st);
  void ReadOnlineReadings(Section& s, NetworkStation& st);
  std::vector<PlannedSighting> Sightings(Section& s, const toml::node& see);
  void ReadSightings(Section& s, const toml::node& see);
  void ReadStation(Section& s);
  void ReadStations();
  void ReadDatum();
  void ReadReferences();
  void ReadDistance(Section& s, bool scale_bar);
  void ReadDistances();
  void PlanOfflineReadings();
  void ReadNetworkTasks();
  void ReadDrift(Section& s, NetworkStation& st);
  void PlanTimes(Section& drift);
  void ReadPlannedCheck(Section& s, std::size_t station, const TimeValue& time);
  void ReadDriftChecks();
  void DriftKnots();
  void CheckTimes();
  void CheckAirChanges() const;
};

// The instruments: [[instrument]] tables (each with its own [instrument.tracker],
// [instrument.environment], [instrument.correlations] read as a job's), or the file's single
// [tracker] (+ [environment], [correlations]) named "tracker".
void NetworkFileReader::ReadInstrument(Section& s, const std::string& name) {
  Job instrument = holder;
  ReadTracker(s, instrument);
  ReadEnvironment(s, instrument);
  ReadCorrelations(s, instrument);
  if (instrument.calibration)
    job.input_files.push_back({"calibration", instrument.calibration->file, instrument.calibration->sha256});
  for (const std::string& w : instrument.warnings) job.warnings.push_back(w);
  net.instruments.push_back({name, instrument.setup});
}

void NetworkFileReader::ReadInstruments() {
  if (top.Get("instrument")) {
    if (top.Get("tracker"))
      throw InputError(top.Where("tracker") +
                       ": give either [tracker] (one instrument) or [[instrument]] tables, not both");
    ForEachTable(top, path, "instrument", [&](Section& s) {
      s.set_hint("name, tracker, environment, correlations");
      const std::string name = AsString(s.Require("name"), s.Where("name"));
      CheckName(name, s.Where("name"), "instrument");
      if (name.find('.') != std::string::npos) throw InputError(s.Where("name") + ": a name without '.'");
      for (const NetworkInstrument& other : net.instruments) {
        if (other.name == name)
          throw InputError(s.Where("name") + ": instrument '" + name + "' defined twice");
      }
      ReadInstrument(s, name);
    });
  } else {
    ReadInstrument(top, "tracker");
  }
  several = net.instruments.size() > 1;
}

// [network.monte_carlo]: the validation by re-adjusted simulated networks.
void NetworkFileReader::ReadValidation(Section& settings) {
  Section mc = settings.Sub("monte_carlo", false);
  if (!mc.exists()) return;
  mc.set_hint("trials, seed");
  mc.Require("trials");
  std::int64_t trials = 0;
  ReadTrials(mc, "trials", 2, 1000000, "", trials);
  job.monte_carlo_trials = static_cast<int>(trials);
  ReadSeed(mc, "seed", job.monte_carlo_seed);
  mc.Finish();
}

// [network.length_test] (N-13): the MPE of the length-measurement error "A + B" and the shortest
// length tested.
void NetworkFileReader::ReadLengthTest(Section& settings) {
  Section test = settings.Sub("length_test", false);
  if (!test.exists()) return;
  test.set_hint("mpe, min_length");
  NetworkLengthTest t;
  ParseLengthPlusRatio(AsString(test.Require("mpe"), test.Where("mpe")), test.Where("mpe"), t.mpe_a, t.mpe_b);
  if (!(t.mpe_a > 0.0 || t.mpe_b > 0.0)) throw InputError(test.Where("mpe") + ": must be positive");
  if (const toml::node* n = test.Get("min_length")) {
    t.min_length = AsQuantity(*n, Dimension::kLength, test.Where("min_length"));
    if (!(t.min_length >= 0.0) || !(t.min_length <= kMaxRange))
      throw InputError(test.Where("min_length") + ": a length in [0, 10 km]");
  }
  test.Finish();
  job.length_test = t;
}

void NetworkFileReader::ReadSelfCalibration(Section& settings) {
  const toml::node* n = settings.Get("self_calibrate");
  if (!n) return;
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

void NetworkFileReader::ReadSettings() {
  Section settings = top.Sub("network", false);
  if (!settings.exists()) return;
  settings.set_hint(
      "self_calibrate, coverage_probability, outlier_limit, robust, robust_alpha, max_iterations, "
      "monte_carlo, "
      "length_test");
  ReadValidation(settings);
  ReadLengthTest(settings);
  if (const toml::node* n = settings.Get("robust")) net.robust = AsBool(*n, settings.Where("robust"));
  if (const toml::node* n = settings.Get("robust_alpha")) {
    net.robust_alpha = AsNumber(*n, settings.Where("robust_alpha"));
    if (!(net.robust_alpha > 0.0 && net.robust_alpha <= 0.5))
      throw InputError(settings.Where("robust_alpha") + ": a probability in (0, 0.5]");
  }
  ReadSelfCalibration(settings);
  ReadCoverageProbability(settings, "coverage_probability", net.coverage_probability);
  ReadOutlierLimit(settings, "outlier_limit", net.outlier_limit);
  ReadIterationLimit(settings, "max_iterations", net.max_iterations);
  settings.Finish();
}

// Offline targets: [targets] with the keys of [plan] (csv or [[targets.point]]).
void NetworkFileReader::ReadTargets() {
  Section targets = top.Sub("targets", false);
  has_targets = targets.exists();
  if (!has_targets) return;
  Job points;
  points.file = path;
  points.base_dir = holder.base_dir;
  ReadPlan(targets, points, false);
  std::set<std::string> names;
  for (const JobPoint& p : points.points) {
    if (!names.insert(p.name).second) throw InputError(p.where + ": target '" + p.name + "' defined twice");
    job.nominal.emplace_back(p.name, p.nominal);
  }
  for (const InputFile& f : points.input_files) job.input_files.push_back({"targets csv", f.path, ""});
}

// The index of the station's instrument (the first when it names none and the network has one).
int NetworkFileReader::InstrumentOf(Section& s) {
  if (const toml::node* n = s.Get("instrument")) {
    const std::string name = AsString(*n, s.Where("instrument"));
    int instrument = -1;
    for (std::size_t k = 0; k < net.instruments.size(); ++k) {
      if (net.instruments[k].name == name) instrument = static_cast<int>(k);
    }
    if (instrument < 0) throw InputError(s.Where("instrument") + ": unknown instrument '" + name + "'");
    return instrument;
  }
  if (several) {
    throw InputError(s.Where("instrument") +
                     ": required key is missing (the network has several instruments)");
  }
  return 0;
}

void NetworkFileReader::ReadPose(Section& s, NetworkStation& st) {
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
}

// [[air_sensor]]: a weather station whose calibration error is common to the stations it serves (N-2a).
void NetworkFileReader::ReadAirSensors() {
  ForEachTable(top, path, "air_sensor", [&](Section& s) {
    s.set_hint("name, temperature, pressure, humidity");
    NetworkAirSensor sensor;
    sensor.where = s.WhereSelf();
    sensor.name = AsString(s.Require("name"), s.Where("name"));
    CheckName(sensor.name, s.Where("name"), "sensor");
    for (const NetworkAirSensor& other : net.air_sensors) {
      if (other.name == sensor.name)
        throw InputError(s.Where("name") + ": air sensor '" + sensor.name + "' defined twice");
    }
    const struct {
      const char* key;
      Dimension dimension;
      double* u;
    } quantities[3] = {{"temperature", Dimension::kTemperatureDifference, &sensor.u_temperature},
                       {"pressure", Dimension::kPressure, &sensor.u_pressure},
                       {"humidity", Dimension::kHumidity, &sensor.u_humidity}};
    for (const auto& q : quantities) {
      if (const toml::node* n = s.Get(q.key)) {
        *q.u = AsQuantity(*n, q.dimension, s.Where(q.key));
        CheckUncertainty(*q.u, s.Where(q.key));
      }
    }
    net.air_sensors.push_back(sensor);
  });
}

// One air of a station ([station.environment] or one of its [[station.environment]] tables), read
// as an [environment]; the wavelength and the equation default to the instrument's (the same
// laser). `sensor` names an [[air_sensor]] (default: `sensor_name`, the station's first air's),
// whose u is part of the station's: the station's u of each quantity may not be smaller.
Environment NetworkFileReader::ReadOneAir(Section& air, const NetworkStation& st, std::string& sensor_name) {
  const NetworkAirSensor* sensor = nullptr;
  if (const toml::node* n = air.Get("sensor")) sensor_name = AsString(*n, air.Where("sensor"));
  if (!sensor_name.empty()) {
    for (const NetworkAirSensor& candidate : net.air_sensors)
      if (candidate.name == sensor_name) sensor = &candidate;
    if (!sensor)
      throw InputError(air.Where("sensor") + ": unknown air sensor '" + sensor_name +
                       "' (not in [[air_sensor]])");
  }
  const bool wavelength = air.table().contains("wavelength"), equation = air.table().contains("equation");
  Environment env = ReadAir(air, job.warnings, "sensor, from");
  if (const auto& own = net.instruments[st.instrument].setup.environment) {
    if (!wavelength) env.vacuum_wavelength = own->vacuum_wavelength;
    if (!equation) env.equation = own->equation;
  }
  if (sensor) {
    const struct {
      const char* key;
      double station_u, sensor_u;
    } quantities[3] = {{"temperature", env.temperature.u, sensor->u_temperature},
                       {"pressure", env.pressure.u, sensor->u_pressure},
                       {"humidity", env.humidity.u, sensor->u_humidity}};
    for (const auto& q : quantities) {
      if (q.station_u < q.sensor_u) {
        throw InputError(air.Where(q.key) + ": u below the u of its sensor '" + sensor_name +
                         "' (the air at a station is not known better than its sensor knows it)");
      }
    }
  }
  return env;
}

// [station.environment]: the air at the station (N-2a). As [[station.environment]] tables, the air
// changes while the station reads: the first table's air holds from its first reading, each later
// one's from its `from` (a time, as the readings' times) on, as a tracker applies its weather
// station's latest values to every reading it takes.
void NetworkFileReader::ReadStationAir(Section& s, NetworkStation& st) {
  const toml::node* node = s.Get("environment");
  if (!node) return;
  if (node->is_table()) {
    Section air = s.Sub("environment", false);
    if (air.Get("from"))
      throw InputError(air.Where("from") +
                       ": one air holds for all the station's readings; air that changes "
                       "is given as [[station.environment]] tables");
    st.environment = ReadOneAir(air, st, st.air_sensor);
    return;
  }
  if (!node->is_array() || node->as_array()->empty())
    throw InputError(s.Where("environment") + ": expected a table or [[station.environment]] tables");
  int index = 0;
  for (const toml::node& e : *node->as_array()) {
    const std::string path = s.path() + ".environment[" + std::to_string(index) + "]";
    if (!e.is_table()) throw InputError(this->path + ": " + path + ": expected a table");
    Section air(*e.as_table(), this->path, path);
    const toml::node* from = air.Get("from");
    if (index == 0) {
      if (from)
        throw InputError(air.Where("from") +
                         ": the first air holds from the station's first reading (no from)");
      st.environment = ReadOneAir(air, st, st.air_sensor);
    } else {
      if (!from)
        throw InputError(air.Where("from") + ": required key is missing (the time this air holds from)");
      NetworkAirChange change;
      change.where = air.WhereSelf();
      const TimeValue time = Time(*from, air.Where("from"));
      change.from = time.seconds;
      change.from_kind = time.kind;
      if (!st.air_changes.empty() && change.from_kind != st.air_changes.back().from_kind) {
        throw InputError(air.Where("from") + ": " + std::string(TimeKindName(change.from_kind)) + ", but " +
                         st.air_changes.back().where + ".from gives " +
                         std::string(TimeKindName(st.air_changes.back().from_kind)) +
                         " (one kind of time, one origin, in a network)");
      }
      if (!st.air_changes.empty() && !(change.from > st.air_changes.back().from)) {
        throw InputError(air.Where("from") +
                         ": not after the air before it (the station's air is given in the "
                         "order of time)");
      }
      change.sensor = st.air_sensor;
      change.environment = ReadOneAir(air, st, change.sensor);
      st.air_changes.push_back(std::move(change));
    }
    ++index;
  }
}

// Online: the CSV of what the station read, with its instrument's reading noise.
void NetworkFileReader::ReadOnlineReadings(Section& s, NetworkStation& st) {
  any_online = true;
  Section readings = s.Sub("readings", true);
  Job r;
  r.file = path;
  r.base_dir = holder.base_dir;
  r.setup = net.instruments[st.instrument].setup;
  ReadReadings(readings, r, true);
  for (const JobPoint& p : r.points)
    st.readings.push_back({p.name, p.face, p.readings, p.where, p.time, p.time_kind});
  job.input_files.push_back({"readings csv", r.readings_file, ""});
  for (const std::string& w : r.warnings) job.warnings.push_back(w);
  sees.emplace_back();
}

// The targets a station (or its drift check) will read, in `sees` order, each in every face of
// `face` (front; "both": front then back).
std::vector<PlannedSighting> NetworkFileReader::Sightings(Section& s, const toml::node& see) {
  std::vector<Face> faces = {Face::kFront};
  if (const toml::node* f = s.Get("face")) {
    const std::string text = AsString(*f, s.Where("face"));
    if (text == "both")
      faces = {Face::kFront, Face::kBack};
    else
      faces = {ParseFace(text.c_str(), s.Where("face").c_str())};
  }
  std::vector<std::string> names;
  const std::string where = s.Where("sees");
  if (see.is_string() && AsString(see, where) == "all") {
    for (const auto& [name, x] : job.nominal) names.push_back(name);
  } else if (see.is_array()) {
    for (const toml::node& e : *see.as_array()) names.push_back(AsString(e, where));
  } else {
    throw InputError(where + ": expected \"all\" or an array of target names");
  }
  if (names.empty()) throw InputError(where + ": no target named");
  std::vector<PlannedSighting> sightings;
  for (const std::string& name : names) {
    for (Face face : faces) sightings.push_back({name, face, where});
  }
  return sightings;
}

void NetworkFileReader::ReadSightings(Section& s, const toml::node& see) {
  any_offline = true;
  sees.push_back(Sightings(s, see));
  planned_times.emplace_back();
}

void NetworkFileReader::ReadStation(Section& s) {
  s.set_hint("name, instrument, rx, ry, rz, tx, ty, tz, environment, drift, readings, sees, face");
  NetworkStation st;
  st.where = s.WhereSelf();
  st.name = AsString(s.Require("name"), s.Where("name"));
  CheckName(st.name, s.Where("name"), "station");
  st.instrument = InstrumentOf(s);
  ReadPose(s, st);
  ReadStationAir(s, st);
  const bool has_readings = s.Get("readings") != nullptr;
  const toml::node* see = s.Get("sees");
  if (has_readings == (see != nullptr)) {
    throw InputError(st.where +
                     ": give either readings (online: a CSV of what the station read) or sees (offline: the "
                     "targets it will read), not " +
                     std::string(has_readings ? "both" : "neither"));
  }
  if ((has_readings && any_offline) || (!has_readings && any_online)) {
    throw InputError(
        st.where +
        ": every station gives readings (online) or every station gives sees (offline), not a mix");
  }
  if (has_readings) {
    ReadOnlineReadings(s, st);
  } else {
    if (!st.air_changes.empty()) {
      throw InputError(
          st.air_changes.front().where +
          ": air that changes during a station's readings is for measured readings (their times); "
          "plan a station per air");
    }
    ReadSightings(s, *see);
  }
  ReadDrift(s, st);
  net.stations.push_back(std::move(st));
}

void NetworkFileReader::ReadStations() {
  ForEachTable(top, path, "station", [&](Section& s) { ReadStation(s); });
  if (net.stations.empty())
    throw InputError(path + ": station: required key is missing (give [[station]] tables)");
  job.offline = any_offline;
  if (job.offline && job.nominal.empty()) {
    throw InputError(path + ": targets: required key is missing (offline stations see targets of [targets])");
  }
  if (!job.offline && has_targets) {
    throw InputError(
        path +
        ": targets: nominal targets are for offline networks (stations with sees); online stations "
        "give their readings");
  }
}

void NetworkFileReader::ReadDatum() {
  Section datum = top.Sub("datum", false);
  if (!datum.exists()) return;
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

void NetworkFileReader::ReadReferences() {
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
}

// [[scale_bar]] and [[distance]]: a measured length between two targets (docs/network.md N-4a).
// A scale bar's length is calibrated at `reference` (20 degC) and corrected to its temperature:
// L = L_cal (1 + cte (T - T_ref)), with the GUM's first-order u (vlt/network.h). Offline, a length
// left out is the nominal distance of the two targets.
void NetworkFileReader::ReadDistance(Section& s, bool scale_bar) {
  s.set_hint(scale_bar ? "name, from, to, length, u, cte, temperature, reference"
                       : "name, from, to, length, u");
  NetworkDistance d;
  d.scale_bar = scale_bar;
  d.where = s.WhereSelf();
  d.name = AsString(s.Require("name"), s.Where("name"));
  CheckName(d.name, s.Where("name"), scale_bar ? "scale bar" : "distance");
  for (const NetworkDistance& other : net.distances) {
    if (other.name == d.name) throw InputError(s.Where("name") + ": '" + d.name + "' defined twice");
  }
  d.from = AsString(s.Require("from"), s.Where("from"));
  d.to = AsString(s.Require("to"), s.Where("to"));
  if (d.from == d.to) throw InputError(s.Where("to") + ": the same target as `from`");
  std::map<std::string, Eigen::Vector3d> nominal(job.nominal.begin(), job.nominal.end());
  if (job.offline) {
    for (const char* key : {"from", "to"}) {
      const std::string& target = std::string_view(key) == "from" ? d.from : d.to;
      if (!nominal.count(target))
        throw InputError(s.Where(key) + ": unknown target '" + target + "' (not in [targets])");
    }
  }
  // Offline without a length: the bar is as long as its targets are apart (at its temperature).
  double nominal_length = 0.0;
  if (s.Get("length")) {
    d.calibrated_length = Length(s, "length");
    // Positive and of a size a network can read (a bar of 1e-300 m left the adjustment to fail
    // without a key): from 1 um to a tracker's reach.
    if (!(d.calibrated_length >= 1e-6 && d.calibrated_length <= kMaxRange))
      throw InputError(s.Where("length") + ": a length from 1 um to 10 km");
  } else if (job.offline) {
    nominal_length = (nominal[d.to] - nominal[d.from]).norm();
  } else {
    s.Require("length");
  }
  d.u_calibrated_length = AsQuantity(s.Require("u"), Dimension::kLength, s.Where("u"));
  if (!(d.u_calibrated_length > 0.0) || !std::isfinite(d.u_calibrated_length))
    throw InputError(s.Where("u") + ": must be positive");
  if (scale_bar) {
    UncertainInput cte = MakeInput("cte", "scale_bar", Dimension::kPerKelvin, 0.0, 0.0);
    UncertainInput temperature = MakeInput("temperature", "scale_bar", Dimension::kTemperature, 20.0, 0.0);
    if (s.Get("cte")) ReadUncertain(s, "cte", Dimension::kPerKelvin, Dimension::kPerKelvin, cte);
    if (s.Get("temperature"))
      ReadUncertain(s, "temperature", Dimension::kTemperature, Dimension::kTemperatureDifference,
                    temperature);
    if (const toml::node* n = s.Get("reference"))
      d.reference_temperature = AsQuantity(*n, Dimension::kTemperature, s.Where("reference"));
    d.cte = cte.estimate;
    d.u_cte = cte.u;
    d.temperature = temperature.estimate;
    d.u_temperature = temperature.u;
  }
  const double dt = d.temperature - d.reference_temperature, factor = 1.0 + d.cte * dt;
  if (!(factor > 0.5 && factor < 1.5))
    throw InputError(s.Where("cte") + ": the expansion factor 1 + cte (T - T_ref) is not plausible");
  if (nominal_length > 0.0) d.calibrated_length = nominal_length / factor;
  if (!(d.calibrated_length > 0.0)) throw InputError(s.Where("length") + ": must be positive");
  d.length = d.calibrated_length * factor;
  d.u = std::sqrt(std::pow(factor * d.u_calibrated_length, 2) +
                  std::pow(d.calibrated_length * dt * d.u_cte, 2) +
                  std::pow(d.calibrated_length * d.cte * d.u_temperature, 2));
  net.distances.push_back(std::move(d));
}

void NetworkFileReader::ReadDistances() {
  ForEachTable(top, path, "scale_bar", [&](Section& s) { ReadDistance(s, true); });
  ForEachTable(top, path, "distance", [&](Section& s) { ReadDistance(s, false); });
}

void NetworkFileReader::PlanOfflineReadings() {
  for (std::size_t i = 0; i < net.stations.size(); ++i) {
    if (!net.stations[i].pose_given) {
      throw InputError(net.stations[i].where +
                       ": an offline network needs every station's pose (rx, ry, rz, tx, ty, tz; "
                       "omitted ones are 0)");
    }
  }
  PlanNetworkReadings(net, job.nominal, sees);
  // The planned readings follow `sees` one for one: a drifting station's take their planned times.
  for (std::size_t i = 0; i < net.stations.size() && i < planned_times.size(); ++i) {
    std::vector<TargetReading>& readings = net.stations[i].readings;
    for (std::size_t j = 0; j < planned_times[i].size() && j < readings.size(); ++j)
      readings[j].time = planned_times[i][j];
  }
}

// [station.drift] (N-12): the rates of the piecewise-linear drift model; the knots follow from the
// readings' times and the drift checks (DriftKnots).
void NetworkFileReader::ReadDrift(Section& s, NetworkStation& st) {
  Section drift = s.Sub("drift", false);
  if (!drift.exists()) return;
  drift.set_hint("model, translation_rate, rotation_rate, interval");
  PlanTimes(drift);
  if (const toml::node* n = drift.Get("model")) {
    const std::string model = AsString(*n, drift.Where("model"));
    if (model != "linear")
      throw InputError(drift.Where("model") + ": unknown drift model '" + model + "' (linear)");
  }
  st.drift.enabled = true;
  st.drift.where = drift.WhereSelf();
  st.drift.translation_rate = Rate(drift, "translation_rate", Dimension::kLength);
  st.drift.rotation_rate = Rate(drift, "rotation_rate", Dimension::kAngle);
  // From 1 nm/h and 1e-6 arcsec/h (below, the prior's weights overflow; hold the station still
  // instead) to 1 m/s and 1 rad/s.
  if (!(st.drift.translation_rate >= 1e-9 / 3600.0) || !(st.drift.translation_rate <= 1.0))
    throw InputError(drift.Where("translation_rate") + ": from 1 nm/h to 1 m/s");
  if (!(st.drift.rotation_rate >= 4.8e-12 / 3600.0) || !(st.drift.rotation_rate <= 1.0))
    throw InputError(drift.Where("rotation_rate") + ": from 1e-6 arcsec/h to 1 rad/s");
  drift.Finish();
}

// Offline (N-12): a drifting station's readings are planned `interval` apart in `sees` order
// (each face one reading), from 0 s; a measured station's readings carry their own times.
void NetworkFileReader::PlanTimes(Section& drift) {
  const toml::node* n = drift.Get("interval");
  if (!any_offline) {
    if (n) {
      throw InputError(drift.Where("interval") +
                       ": for an offline station (sees) only: measured readings carry their times");
    }
    return;
  }
  if (!n) {
    throw InputError(drift.WhereSelf() +
                     ": interval: required key is missing (offline: the planned time from one reading to the "
                     "next, e.g. \"30 s\")");
  }
  const TimeValue interval = Time(*n, drift.Where("interval"));
  // At least 1 s: knots closer than that are one (DriftKnots).
  if (interval.kind != TimeKind::kSeconds || !(interval.seconds >= 1.0) || !(interval.seconds <= 86400.0))
    throw InputError(drift.Where("interval") + ": a duration from 1 s to 24 h (\"30 s\", \"2 min\")");
  for (std::size_t j = 0; j < sees.back().size(); ++j)
    planned_times.back().push_back(interval.seconds * static_cast<double>(j));
}

// Offline (N-12): a planned drift check re-reads `sees` (targets of [targets], in `face`) at `time`,
// a duration from the station's first planned reading (0 s).
void NetworkFileReader::ReadPlannedCheck(Section& s, std::size_t station, const TimeValue& time) {
  if (s.Get("readings")) {
    throw InputError(
        s.Where("readings") +
        ": an offline drift check plans what it will re-read: give sees (target names), not readings");
  }
  if (time.kind != TimeKind::kSeconds || !(time.seconds > 0.0)) {
    throw InputError(s.Where("time") +
                     ": offline, a duration after the station's first planned reading (\"45 min\"), not " +
                     (time.kind == TimeKind::kSeconds ? std::string("0 or before it")
                                                      : std::string(TimeKindName(time.kind))));
  }
  std::vector<PlannedSighting> planned = Sightings(s, s.Require("sees"));
  for (PlannedSighting& p : planned) {
    p.where = s.WhereSelf();
    planned_times[station].push_back(time.seconds);
  }
  job.drift_check_where.push_back(s.WhereSelf());
  sees[station].insert(sees[station].end(), planned.begin(), planned.end());
}

// [[drift_check]] (N-12): a drifting station re-reads chosen targets (drift nests) at a stated
// time; the readings join the station's, each at the check's time unless its file has a time
// column, and the time becomes a knot of the station's drift model. Offline, the check plans
// the targets it will re-read (ReadPlannedCheck).
void NetworkFileReader::ReadDriftChecks() {
  ForEachTable(top, path, "drift_check", [&](Section& s) {
    s.set_hint(any_offline ? "station, time, sees, face" : "station, time, readings");
    const std::string name = AsString(s.Require("station"), s.Where("station"));
    NetworkStation* st = nullptr;
    for (NetworkStation& candidate : net.stations)
      if (candidate.name == name) st = &candidate;
    if (!st) throw InputError(s.Where("station") + ": unknown station '" + name + "'");
    if (!st->drift.enabled) {
      throw InputError(s.Where("station") + ": station '" + name +
                       "' has no drift model: give it [station.drift] (translation_rate, rotation_rate" +
                       (any_offline ? ", interval)" : ")"));
    }
    const TimeValue time = Time(s.Require("time"), s.Where("time"));
    if (any_offline) {
      ReadPlannedCheck(s, static_cast<std::size_t>(st - net.stations.data()), time);
      check_times.push_back({st, time.seconds, time.kind, s.Where("time")});
      s.Finish();
      return;
    }
    if (s.Get("sees")) {
      throw InputError(
          s.Where("sees") +
          ": a measured drift check gives what it read (readings = { csv = ... }); sees plans an "
          "offline one");
    }
    Section readings = s.Sub("readings", true);
    Job r;
    r.file = path;
    r.base_dir = holder.base_dir;
    r.setup = net.instruments[st->instrument].setup;
    ReadReadings(readings, r, true);
    for (const JobPoint& p : r.points) {
      st->readings.push_back({p.name, p.face, p.readings, p.where, p.time ? p.time : time.seconds,
                              p.time ? p.time_kind : time.kind});
    }
    job.input_files.push_back({"readings csv", r.readings_file, ""});
    for (const std::string& w : r.warnings) job.warnings.push_back(w);
    check_times.push_back({st, time.seconds, time.kind, s.Where("time")});
    s.Finish();
  });
}

// One kind of time in a file (N-12): dates and times, or seconds / clock times, not both.
void NetworkFileReader::CheckTimes() {
  const TargetReading* first = nullptr;
  for (const NetworkStation& st : net.stations) {
    for (const TargetReading& r : st.readings) {
      if (!r.time) continue;
      if (!first) first = &r;
      if (r.time_kind != first->time_kind) {
        throw InputError(r.where + ": time: " + std::string(TimeKindName(r.time_kind)) + ", but " +
                         first->where + " gives " + std::string(TimeKindName(first->time_kind)) +
                         " (one kind of time, one origin, in a network)");
      }
    }
  }
}

// A station whose air changes (N-2a) takes each reading's air by its time: every reading needs one,
// of the kind the changes are given in; an offline station plans no times for its air.
void NetworkFileReader::CheckAirChanges() const {
  for (const NetworkStation& st : net.stations) {
    if (st.air_changes.empty()) continue;
    const NetworkAirChange& change = st.air_changes.front();  // all of one kind (ReadStationAir)
    for (const TargetReading& r : st.readings) {
      if (!r.time) {
        throw InputError(r.where + ": station '" + st.name +
                         "' has air that changes: every reading needs its time (readings.columns.time)");
      }
      if (r.time_kind != change.from_kind) {
        throw InputError(change.where + ".from: " + std::string(TimeKindName(change.from_kind)) + ", but " +
                         r.where + " gives " + std::string(TimeKindName(r.time_kind)) +
                         " (one kind of time, one origin, in a network)");
      }
    }
    const auto [earliest, latest] =
        std::minmax_element(st.readings.begin(), st.readings.end(),
                            [](const TargetReading& a, const TargetReading& b) { return *a.time < *b.time; });
    for (const NetworkAirChange& c : st.air_changes) {
      if (!(c.from > *earliest->time) || c.from > *latest->time) {
        throw InputError(c.where +
                         ".from: outside the station's readings (after its first, at or before its "
                         "last): no reading would take this air");
      }
    }
  }
}

// The knots of each drifting station: its first reading, its drift checks, its last reading.
void NetworkFileReader::DriftKnots() {
  for (NetworkStation& st : net.stations) {
    if (!st.drift.enabled) continue;
    std::set<double> knots;
    for (const TargetReading& r : st.readings) {
      if (!r.time) {
        throw InputError(r.where + ": station '" + st.name +
                         "' has a drift model: every reading needs its time (readings.columns.time)");
      }
    }
    const auto [earliest, latest] =
        std::minmax_element(st.readings.begin(), st.readings.end(),
                            [](const TargetReading& a, const TargetReading& b) { return *a.time < *b.time; });
    knots.insert(*earliest->time);
    knots.insert(*latest->time);
    for (const CheckTime& check : check_times) {
      if (check.station != &st) continue;
      if (check.kind != earliest->time_kind) {
        throw InputError(check.where + ": " + std::string(TimeKindName(check.kind)) +
                         ", but the station's readings give " +
                         std::string(TimeKindName(earliest->time_kind)) +
                         " (one kind of time, one origin, in a network)");
      }
      knots.insert(check.seconds);
    }
    // Knots closer than 1 s are one (a check written at the first reading's time in another
    // spelling): a segment of a rounding step would carry a prior of 1e11 / rate.
    st.drift.knots.clear();
    for (double t : knots)
      if (st.drift.knots.empty() || t - st.drift.knots.back() >= 1.0) st.drift.knots.push_back(t);
    if (st.drift.knots.size() >= 2 && *latest->time - st.drift.knots.back() > 0.0)
      st.drift.knots.back() = std::max(st.drift.knots.back(), *latest->time);
    if (st.drift.knots.size() < 2) {
      throw InputError(
          st.drift.where + ": station '" + st.name + "' read everything at one time: nothing can drift (" +
          (any_offline ? "plan more than one reading, or a drift check)" : "give the readings' times)"));
    }
  }
}

// [[task]] as in a job, over the targets the stations read (in order of first reading).
void NetworkFileReader::ReadNetworkTasks() {
  Job tasks;
  tasks.file = path;
  std::set<std::string> read;
  for (const NetworkStation& st : net.stations) {
    for (const TargetReading& r : st.readings) {
      if (!read.insert(r.target).second) continue;
      JobPoint point;
      point.name = r.target;
      point.where = r.where;
      tasks.points.push_back(std::move(point));
    }
  }
  ReadTasks(top, tasks);
  job.tasks = tasks.tasks;
}

}  // namespace

NetworkJob LoadNetworkJob(const std::string& path) {
  const std::string text = ReadTextFile(path, "the network file");
  toml::table root = ParseToml(text, path);
  Section top(root, path, "");
  top.set_hint(
      "job, tracker, environment, correlations, instrument, network, datum, reference, scale_bar, distance, "
      "air_sensor, targets, station, drift_check, task, output");
  NetworkJob job;
  job.file = path;
  job.text = text;
  job.base_dir = BaseDirectory(path);
  job.input_files.push_back({"network", path, ""});
  ReadJobMeta(top, job.name, &job.description, std::filesystem::path(path).stem().string(), &job.record);
  NetworkFileReader reader(path, top, job);
  job.network.where = path;
  job.network.name = job.name;
  reader.ReadInstruments();
  reader.ReadSettings();
  reader.ReadTargets();
  reader.ReadAirSensors();
  reader.ReadStations();
  reader.ReadDriftChecks();
  reader.ReadDatum();
  reader.ReadReferences();
  reader.ReadDistances();
  OutputSettings output;
  ReadOutput(top, output);
  job.output_directory = output.directory;
  if (job.offline) reader.PlanOfflineReadings();
  // After the planning: an offline station's readings (and their planned times) exist from here.
  reader.CheckTimes();
  reader.CheckAirChanges();
  reader.DriftKnots();
  reader.ReadNetworkTasks();
  top.Finish();
  return job;
}

}  // namespace vlt
