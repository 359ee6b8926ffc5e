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

// targets.csv, stations.csv, residuals.csv, covariance.csv, tasks.csv (with [[task]]: the
// results of NetworkTasks), parameters.csv (with self-calibration), results.json, report.html.
// With a Monte Carlo validation (`mc` not null) also mcm.csv.
Files NetworkFiles(const NetworkJob& job, const NetworkResult& result, const std::vector<NetworkTaskResult>& tasks,
                   const std::string& created, const NetworkMonteCarlo* mc = nullptr);

// An offline network's simulated measurement (SimulateNetwork, truth = [targets] and the
// stations' poses): simulated_<station>.csv per station (the readings, SI: m, rad) and
// simulated_network.toml, the same file made online (stations read their CSVs, references at
// their simulated coordinates): `vlt network simulated_network.toml` adjusts it.
Files SimulatedNetworkFiles(const NetworkJob& job, const Network& simulated, std::uint64_t seed);

// The terminal summary.
std::string NetworkSummary(const NetworkJob& job, const NetworkResult& result, const NetworkMonteCarlo* mc = nullptr);

}  // namespace vlt::network_outputs
