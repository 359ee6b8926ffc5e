// network/instruments.h — internal to runtime/src/network/: the instruments of a network, and the
// air of the stations that have their own, as one stacked vector of shared inputs
// (docs/network.md "Several instruments", N-2a).
#pragma once

#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "vlt/measurement_model.h"
#include "vlt/network.h"

namespace vlt::network_internal {

// The stacked shared inputs s = (instrument 1, instrument 2, ..., the air of station a, of station b,
// ...) and the models that read them. A model is an instrument with its own air ([environment]),
// or a station with air of its own ([station.environment]): the station's instrument with that
// air; a station whose air changes has one model per air. A station's model takes the instrument's error parameters from the instrument's block and
// its air from its own block, so the error parameters stay common to every station of the
// instrument while the air is the station's.
struct Instruments {
  std::vector<MeasurementModel> models;  // pose and thermal removed
  std::vector<std::vector<int>> inputs;  // per model: the stacked index of each of its shared inputs
  std::vector<int> station_model;        // per station: the model of its (first) air's readings
  // Per station whose air changes (N-2a): (from [s], model) of each later air, in order of time.
  std::vector<std::vector<std::pair<double, int>>> air_changes;
  Eigen::VectorXd s0;                   // stacked estimates
  Eigen::MatrixXd sigma;                // stacked covariance
  Eigen::MatrixXd correlation;          // stacked correlation
  std::vector<std::string> names;       // NetworkSharedInputNames
  std::vector<UncertainInput> stacked;  // each stacked input as its model has it (unit, prior)
  std::vector<std::string> quantities;  // an error parameter's quantity (ModelInfo), else ""
  int size() const { return static_cast<int>(s0.size()); }
  int Size(int model) const { return models[model].num_shared(); }
  // The model of a reading of station `station`: the air in force at its time (the last change at or
  // before it).
  int ReadingModel(int station, const TargetReading& reading) const;
  // Model `model`'s shared vector (its MeasurementModel order) gathered from a stacked one.
  Eigen::VectorXd Local(int model, const Eigen::VectorXd& stacked_values) const;
};

// InputError "<file>: instrument: ..." without an instrument or with a station naming none;
// "<station>.environment...: ..." for air that cannot be stacked (an unknown sensor, an instrument
// whose [correlations] tie its air to its error parameters).
Instruments MakeInstruments(const Network& network);

}  // namespace vlt::network_internal
