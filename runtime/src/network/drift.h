// network/drift.h — internal to runtime/src/network/: a station's drift model (docs/network.md
// N-12), piecewise linear in time between its knots, as the adjustment, the simulation and the
// outputs use it.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "vlt/network.h"

namespace vlt::network_internal {

// The pose of a reading at time t as the adjustment has it (N-12): a combination of the poses at
// the knots around t (hat functions), each term (block, weight) with block -1 = the station's pose
// at t_0 and block first + k - 1 = its pose at knot k >= 1; weights > 0 and summing to 1.
std::vector<std::pair<int, double>> PoseTerms(const NetworkDrift& drift, double t, int first);

// The drift segments of a network, numbered over its drifting stations in station order.
struct DriftSegments {
  std::vector<int> first;       // per station: the number of its first segment, -1 without drift
  std::vector<int> station;     // per segment: its station
  std::vector<double> duration;  // per segment: t_{k+1} - t_k [s]
  int count() const { return static_cast<int>(station.size()); }
};

// Checks every drift model (knots ascending, at least 2; rates positive and finite; a given
// truth with one increment per segment) and numbers the segments. InputError naming the station.
DriftSegments NumberDriftSegments(const Network& network);

// The prior's standard uncertainty of D_k per pose component (rx, ry, rz, tx, ty, tz):
// rate x duration of the segment.
StationPoseVector DriftPriorU(const NetworkDrift& drift, double duration);

}  // namespace vlt::network_internal
