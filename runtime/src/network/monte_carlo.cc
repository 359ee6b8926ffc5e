// network/monte_carlo.cc — ValidateNetworkByMonteCarlo (vlt/network.h): the adjustment's GUM
// checked by re-adjusting simulated measurements of the adjusted network (docs/network.md N-10).
#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <exception>
#include <span>
#include <utility>
#include <vector>

#include "mpi/ranks.h"
#include "network/adjust.h"
#include "parallel/pool.h"
#include "vlt/error.h"
#include "vlt/gum.h"
#include "vlt/network.h"

namespace vlt {

namespace {

// The network the adjustment kept: without the observations its robust rule removed (N-8a), which
// the simulated trials then do not have either.
Network KeptObservations(const Network& network, const NetworkResult& result) {
  Network kept = network;
  for (const RejectedObservation& gone : result.rejected) {
    if (gone.distance) {
      std::erase_if(kept.distances,
                    [&](const NetworkDistance& d) { return d.name == gone.target && d.where == gone.where; });
      continue;
    }
    for (NetworkStation& st : kept.stations) {
      if (st.name != gone.station) continue;
      const auto it = std::find_if(st.readings.begin(), st.readings.end(), [&](const TargetReading& r) {
        return r.target == gone.target && r.face == gone.face && r.where == gone.where;
      });
      if (it != st.readings.end()) st.readings.erase(it);
    }
  }
  return kept;
}

}  // namespace

NetworkMonteCarlo ValidateNetworkByMonteCarlo(const Network& network, const NetworkResult& result, int trials,
                                              std::uint64_t seed, int threads) {
  if (trials < 2) throw InputError(network.where + ": network.monte_carlo.trials: at least 2");
  // The truth: the adjusted targets and station poses.
  Network truth_network = KeptObservations(network, result);
  // A drifting station's drift is drawn in every trial from its prior (N-12): the prior's
  // pseudo-observation D_k = 0 is then as far from the truth as the adjustment assumes.
  // Each trial starts from the truth's poses (its targets then start from its readings): the same
  // converged solution as from the chained starting values (N-1), in fewer iterations.
  for (std::size_t i = 0; i < network.stations.size(); ++i) {
    truth_network.stations[i].pose = result.stations[i].pose;
    truth_network.stations[i].pose_given = true;
    truth_network.stations[i].drift.increments.clear();
  }
  std::vector<std::pair<std::string, Eigen::Vector3d>> truth;
  for (const AdjustedTarget& t : result.targets) truth.emplace_back(t.name, t.position);
  const std::size_t T = result.targets.size();
  // Deviations of every trial, stored by trial: the reduction below runs in trial order. Under
  // MPI (docs/mpi.md) each rank re-adjusts a contiguous block of the trials; every rank then
  // receives every trial's deviations (exact copies), so the reduction is the one of one process.
  const std::size_t width = 3 * T;
  // (Not a structured binding: Clang 14 cannot capture one in the lambda below.)
  const std::pair<int, int> share = mpi_internal::Share(trials);
  const int first = share.first, last = share.second;
  std::vector<double> mine(static_cast<std::size_t>(last - first) * width);
  std::exception_ptr failure;
  try {
    parallel_internal::ForEachChunk(
        static_cast<std::size_t>(last - first), 1, threads,
        [&](std::size_t, std::size_t begin, std::size_t end) {
          for (std::size_t i = begin; i < end; ++i) {
            const std::size_t trial = static_cast<std::size_t>(first) + i;
            // One Philox key per trial (splitmix-style spacing of the user's seed).
            const std::uint64_t key = seed * 0x9E3779B97F4A7C15ULL + trial + 1;
            const Network simulated = SimulateNetwork(truth_network, truth, key);
            const NetworkResult r = network_internal::AdjustNetworkTrial(simulated);
            // By name: a trial's robust rule may remove a target's first reading.
            std::map<std::string, const AdjustedTarget*> by_name;
            for (const AdjustedTarget& target : r.targets) by_name[target.name] = &target;
            for (std::size_t t = 0; t < T; ++t) {
              const auto it = by_name.find(truth[t].first);
              if (it == by_name.end())
                throw NumericalError(network.where + ": a simulated trial lost target '" + truth[t].first +
                                     "'");
              const Eigen::Vector3d d = it->second->position - truth[t].second;
              for (int c = 0; c < 3; ++c) mine[i * width + 3 * t + static_cast<std::size_t>(c)] = d(c);
            }
          }
        });
  } catch (...) {
    failure = std::current_exception();
  }
  ranks::Agree(failure);
  std::vector<std::size_t> counts;
  for (int r = 0; r < ranks::Count(); ++r) {
    const auto [f, l] = mpi_internal::ShareOf(trials, r);
    counts.push_back(static_cast<std::size_t>(l - f) * width);
  }
  std::vector<double> deviation(static_cast<std::size_t>(trials) * width);
  mpi_internal::AllGather(std::span<const double>(mine), std::span<double>(deviation), counts);
  NetworkMonteCarlo mc;
  mc.trials = trials;
  mc.seed = seed;
  mc.ranks = ranks::Count();
  mc.covariance.assign(T, Eigen::Matrix3d::Zero());
  mc.bias.assign(T, Eigen::Vector3d::Zero());
  for (int trial = 0; trial < trials; ++trial) {
    const double* d = deviation.data() + static_cast<std::size_t>(trial) * width;
    for (std::size_t t = 0; t < T; ++t) {
      const Eigen::Vector3d v(d[3 * t], d[3 * t + 1], d[3 * t + 2]);
      mc.bias[t] += v / trials;
      mc.covariance[t] += v * v.transpose() / trials;
    }
  }
  // Family-wise: 95 % that no coordinate of an agreeing GUM falls outside (Bonferroni over 3T),
  // with the standard error 1 / sqrt(2 (M - 1)) of a standard deviation from M normal values.
  mc.tolerance =
      NormalCoverageFactor(1.0 - 0.05 / (3.0 * static_cast<double>(T))) / std::sqrt(2.0 * (trials - 1));
  static const char* kAxis[3] = {"x", "y", "z"};
  double worst = 0.0;
  for (std::size_t t = 0; t < T; ++t) {
    for (int c = 0; c < 3; ++c) {
      const double u_gum = std::sqrt(result.targets[t].covariance(c, c));
      if (!(u_gum > 0.0)) continue;
      const double ratio = std::sqrt(mc.covariance[t](c, c)) / u_gum;
      if (std::abs(ratio - 1.0) >= worst) {
        worst = std::abs(ratio - 1.0);
        mc.worst_ratio = ratio;
        mc.worst = result.targets[t].name + "." + kAxis[c];
      }
    }
  }
  mc.agrees = worst <= mc.tolerance;
  return mc;
}

}  // namespace vlt
