// network/monte_carlo.cc — ValidateNetworkByMonteCarlo (vlt/network.h): the adjustment's GUM
// checked by re-adjusting simulated measurements of the adjusted network (docs/network.md N-10).
#include <cmath>

#include "gum/internal.h"
#include "vlt/error.h"
#include "vlt/gum.h"
#include "vlt/network.h"

namespace vlt {

NetworkMonteCarlo ValidateNetworkByMonteCarlo(const Network& network, const NetworkResult& result, int trials,
                                              std::uint64_t seed, int threads) {
  if (trials < 2) throw InputError(network.where + ": network.monte_carlo.trials: at least 2");
  // The truth: the adjusted targets and station poses.
  Network truth_network = network;
  for (std::size_t i = 0; i < network.stations.size(); ++i) truth_network.stations[i].pose = result.stations[i].pose;
  std::vector<std::pair<std::string, Eigen::Vector3d>> truth;
  for (const AdjustedTarget& t : result.targets) truth.emplace_back(t.name, t.position);
  const std::size_t T = result.targets.size();
  // Deviations of every trial, stored by trial: the reduction below runs in trial order.
  std::vector<Eigen::VectorXd> deviation(static_cast<std::size_t>(trials));
  gum_internal::ParallelChunks(static_cast<std::size_t>(trials), 1, threads,
                               [&](std::size_t, std::size_t begin, std::size_t end) {
    for (std::size_t trial = begin; trial < end; ++trial) {
      // One Philox key per trial (splitmix-style spacing of the user's seed).
      const std::uint64_t key = seed * 0x9E3779B97F4A7C15ULL + trial + 1;
      const Network simulated = SimulateNetwork(truth_network, truth, key);
      const NetworkResult r = AdjustNetwork(simulated);
      Eigen::VectorXd d(3 * T);
      for (std::size_t t = 0; t < T; ++t) d.segment<3>(3 * t) = r.targets[t].position - truth[t].second;
      deviation[trial] = d;
    }
  });
  NetworkMonteCarlo mc;
  mc.trials = trials;
  mc.seed = seed;
  mc.covariance.assign(T, Eigen::Matrix3d::Zero());
  mc.bias.assign(T, Eigen::Vector3d::Zero());
  for (const Eigen::VectorXd& d : deviation) {
    for (std::size_t t = 0; t < T; ++t) {
      const Eigen::Vector3d v = d.segment<3>(3 * t);
      mc.bias[t] += v / trials;
      mc.covariance[t] += v * v.transpose() / trials;
    }
  }
  // Family-wise: 95 % that no coordinate of an agreeing GUM falls outside (Bonferroni over 3T),
  // with the standard error 1 / sqrt(2 (M - 1)) of a standard deviation from M normal values.
  mc.tolerance = NormalCoverageFactor(1.0 - 0.05 / (3.0 * static_cast<double>(T))) / std::sqrt(2.0 * (trials - 1));
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
