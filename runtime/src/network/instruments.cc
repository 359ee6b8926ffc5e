// network/instruments.cc — MakeInstruments (instruments.h) and NetworkSharedInputNames.
#include "network/instruments.h"

#include <set>

#include "vlt/error.h"

namespace vlt {

namespace network_internal {

namespace {

// A model's shared inputs appended to the stack as a new block: returns their stacked indices.
std::vector<int> AppendBlock(Instruments& in, const MeasurementModel& m, int first, const std::string& prefix,
                             const ModelInfo* info) {
  const int n = m.num_shared() - first, o = in.size();
  std::vector<int> indices;
  Eigen::VectorXd s0(o + n);
  s0 << in.s0, m.shared_estimates().segment(first, n);
  in.s0 = s0;
  in.sigma.conservativeResize(o + n, o + n);
  in.correlation.conservativeResize(o + n, o + n);
  in.sigma.rightCols(n).setZero();
  in.sigma.bottomRows(n).setZero();
  in.correlation.rightCols(n).setZero();
  in.correlation.bottomRows(n).setZero();
  for (int i = 0; i < n; ++i) {
    const UncertainInput& input = m.shared_inputs()[first + i];
    in.names.push_back(prefix + input.name);
    in.stacked.push_back(input);
    const int p = first + i;
    in.quantities.push_back(info && p < info->num_params ? info->params[p].quantity : std::string());
    indices.push_back(o + i);
    for (int j = 0; j < n; ++j) {
      const double r = m.shared_correlation()(first + i, first + j);
      in.correlation(o + i, o + j) = r;
      in.sigma(o + i, o + j) = input.u * r * m.shared_inputs()[first + j].u;
    }
  }
  return indices;
}

// True when the model's correlation ties one of its air inputs (from index `params` on) to another
// input: the air of a station replaces those inputs, so the tie would be lost.
bool AirIsCorrelated(const MeasurementModel& m, int params) {
  const Eigen::MatrixXd& r = m.shared_correlation();
  for (int a = params; a < r.rows(); ++a)
    for (int b = 0; b < r.cols(); ++b)
      if (a != b && r(a, b) != 0.0) return true;
  return false;
}

// One air of a station: its model (the instrument with that air) and the sensor that gave it.
struct StationAir {
  int model = 0;
  const std::string* sensor = nullptr;
  std::string where;
};

// Airs read by one sensor share its calibration error (N-2a): cov = u_sensor^2 per quantity
// between their inputs — two stations', or two times' of one station — the rest of each air's u
// its own.
void CorrelateSharedSensors(const Network& network, const std::vector<StationAir>& airs, Instruments& in) {
  for (const StationAir& a : airs) {
    if (a.sensor->empty()) continue;
    const NetworkAirSensor* sensor = nullptr;
    for (const NetworkAirSensor& s : network.air_sensors)
      if (s.name == *a.sensor) sensor = &s;
    if (!sensor) throw InputError(a.where + ".sensor: unknown air sensor '" + *a.sensor + "'");
    const double u_sensor[3] = {sensor->u_temperature, sensor->u_pressure, sensor->u_humidity};
    for (const StationAir& b : airs) {
      if (&a == &b || *b.sensor != *a.sensor) continue;
      const std::vector<int>& ia = in.inputs[a.model];
      const std::vector<int>& ib = in.inputs[b.model];
      const int air_a = static_cast<int>(ia.size()) - 4, air_b = static_cast<int>(ib.size()) - 4;
      for (int q = 0; q < 3; ++q) {
        const int x = ia[air_a + q], y = ib[air_b + q];
        const double cov = u_sensor[q] * u_sensor[q];
        in.sigma(x, y) = cov;
        const double scale = in.stacked[x].u * in.stacked[y].u;
        in.correlation(x, y) = scale > 0.0 ? cov / scale : 0.0;
      }
    }
  }
}

// A model of station `st`'s instrument with the air `air`: the instrument's error parameters, the
// air's own inputs named `prefix`environment.temperature, ...; returns its index.
int AppendStationAir(const Network& network, const NetworkStation& st, const Environment& air,
                     const std::string& prefix, Instruments& in) {
  const MeasurementModel& instrument_model = in.models[st.instrument];
  const int params = static_cast<int>(network.instruments[st.instrument].setup.params.size());
  if (AirIsCorrelated(instrument_model, params)) {
    throw InputError(st.where +
                     ".environment: the instrument's [correlations] tie its air to other inputs; "
                     "air per station takes the air's inputs as independent");
  }
  MeasurementSetup setup = instrument_model.setup();
  setup.environment = air;
  in.models.emplace_back(setup);
  std::vector<int> indices(in.inputs[st.instrument].begin(), in.inputs[st.instrument].begin() + params);
  const std::vector<int> own = AppendBlock(in, in.models.back(), params, prefix, nullptr);
  indices.insert(indices.end(), own.begin(), own.end());
  in.inputs.push_back(indices);
  return static_cast<int>(in.models.size()) - 1;
}

}  // namespace

Eigen::VectorXd Instruments::Local(int model, const Eigen::VectorXd& stacked_values) const {
  const std::vector<int>& index = inputs[model];
  Eigen::VectorXd local(index.size());
  for (std::size_t i = 0; i < index.size(); ++i)
    local(static_cast<Eigen::Index>(i)) = stacked_values(index[i]);
  return local;
}

int Instruments::ReadingModel(int station, const TargetReading& reading) const {
  int model = station_model[station];
  if (!reading.time) return model;
  for (const auto& [from, later] : air_changes[station])
    if (*reading.time >= from) model = later;
  return model;
}

Instruments MakeInstruments(const Network& network) {
  if (network.instruments.empty())
    throw InputError(network.where + ": tracker: the network has no instrument");
  for (const NetworkStation& st : network.stations) {
    if (st.instrument < 0 || st.instrument >= static_cast<int>(network.instruments.size())) {
      throw InputError(st.where + ".instrument: no such instrument");
    }
  }
  Instruments in;
  const bool several = network.instruments.size() > 1;
  for (const NetworkInstrument& instrument : network.instruments) {
    MeasurementSetup setup = instrument.setup;
    setup.pose.reset();
    setup.thermal.reset();
    in.models.emplace_back(setup);
    in.inputs.push_back(
        AppendBlock(in, in.models.back(), 0, several ? instrument.name + "." : std::string(), setup.model));
  }
  // Stations with air of their own: the instrument's error parameters, the station's air (one model
  // per air when it changes).
  std::vector<StationAir> airs;
  for (const NetworkStation& st : network.stations) {
    in.air_changes.emplace_back();
    if (!st.air_changes.empty() && !st.environment)
      throw InputError(st.where + ".environment: later airs without a first one");
    for (std::size_t k = 1; k < st.air_changes.size(); ++k) {
      if (!(st.air_changes[k].from > st.air_changes[k - 1].from))
        throw InputError(st.air_changes[k].where + ".from: not after the air before it");
    }
    if (!st.environment) {
      in.station_model.push_back(st.instrument);
      continue;
    }
    in.station_model.push_back(AppendStationAir(network, st, *st.environment, st.name + ".", in));
    airs.push_back({in.station_model.back(), &st.air_sensor, st.where + ".environment"});
    for (std::size_t k = 0; k < st.air_changes.size(); ++k) {
      const NetworkAirChange& change = st.air_changes[k];
      const int model = AppendStationAir(network, st, change.environment,
                                         st.name + ".air" + std::to_string(k + 2) + ".", in);
      in.air_changes.back().emplace_back(change.from, model);
      airs.push_back({model, &change.sensor, change.where});
    }
  }
  CorrelateSharedSensors(network, airs, in);
  std::set<std::string> unique;
  for (const std::string& name : in.names) {
    if (!unique.insert(name).second)
      throw InputError(network.where + ": station: two inputs named '" + name +
                       "' (a station named like an instrument): rename one");
  }
  return in;
}

}  // namespace network_internal

std::vector<std::string> NetworkSharedInputNames(const Network& network) {
  return network_internal::MakeInstruments(network).names;
}

}  // namespace vlt
