// network/instruments.h — internal to runtime/src/network/: the instruments of a network as one
// stacked vector of shared inputs (docs/network.md "Several instruments").
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "vlt/measurement_model.h"
#include "vlt/network.h"

namespace vlt::network_internal {

struct Instruments {
  std::vector<MeasurementModel> models;  // per instrument, pose and thermal removed
  std::vector<int> offset;               // first index of each instrument's inputs in the stack
  Eigen::VectorXd s0;                    // stacked estimates
  Eigen::MatrixXd sigma;                 // stacked covariance: block diagonal (instruments independent)
  Eigen::MatrixXd correlation;           // stacked correlation
  std::vector<std::string> names;        // NetworkSharedInputNames
  int size() const { return static_cast<int>(s0.size()); }
  // The instrument `k`'s shared vector inside a stacked one.
  const double* Segment(int k, const Eigen::VectorXd& stacked) const { return stacked.data() + offset[k]; }
  int Size(int k) const { return models[k].num_shared(); }
};

// InputError "<file>: instrument: ..." without an instrument or with a station naming none.
Instruments MakeInstruments(const Network& network);

}  // namespace vlt::network_internal
