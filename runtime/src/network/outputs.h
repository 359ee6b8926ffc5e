// network/outputs.h — the files `vlt network` writes (docs/network.md "Outputs"): (file name,
// content) pairs for an all-or-none write.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "vlt/network.h"

namespace vlt::network_outputs {

using Files = std::vector<std::pair<std::string, std::string>>;

// A distance between adjusted targets with its GUM uncertainty (vlt/network.h NetworkDistance).
struct DistanceResult {
  std::string from, to;
  double length = 0.0, u = 0.0, U = 0.0;   // [m]
};
// d = |x_b - x_a|, u^2 = g^T C g over the 6 coordinates (C from the full covariance: the two
// targets' correlation through the adjustment), g = (-n, n), n = (x_b - x_a) / d.
std::vector<DistanceResult> Distances(const NetworkJob& job, const NetworkResult& result);

// targets.csv, stations.csv, residuals.csv, covariance.csv, distances.csv (with [[distance]]),
// parameters.csv (with self-calibration), results.json.
// With a Monte Carlo validation (`mc` not null) also mcm.csv.
Files NetworkFiles(const NetworkJob& job, const NetworkResult& result, const std::string& created,
                   const NetworkMonteCarlo* mc = nullptr);

// An offline network's simulated measurement (SimulateNetwork, truth = [targets] and the
// stations' poses): simulated_<station>.csv per station (the readings, SI: m, rad) and
// simulated_network.toml, the same file made online (stations read their CSVs, references at
// their simulated coordinates): `vlt network simulated_network.toml` adjusts it.
Files SimulatedNetworkFiles(const NetworkJob& job, const Network& simulated, std::uint64_t seed);

// The terminal summary.
std::string NetworkSummary(const NetworkJob& job, const NetworkResult& result, const NetworkMonteCarlo* mc = nullptr);

}  // namespace vlt::network_outputs
