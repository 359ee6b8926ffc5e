// network/drift.cc — the drift model of a station (network/drift.h, docs/network.md N-12).
#include "network/drift.h"

#include <algorithm>
#include <cmath>

#include "vlt/error.h"

namespace vlt {

namespace network_internal {

std::vector<std::pair<int, double>> PoseTerms(const NetworkDrift& drift, double t, int first) {
  const std::vector<double>& knots = drift.knots;
  const int last = static_cast<int>(knots.size()) - 1;
  if (!(t > knots.front())) return {{-1, 1.0}};
  if (!(t < knots.back())) return {{first + last - 1, 1.0}};
  const int m = static_cast<int>(std::upper_bound(knots.begin(), knots.end(), t) - knots.begin()) - 1;
  const double b = (t - knots[m]) / (knots[m + 1] - knots[m]);
  std::vector<std::pair<int, double>> terms;
  if (b < 1.0) terms.emplace_back(m == 0 ? -1 : first + m - 1, 1.0 - b);
  if (b > 0.0) terms.emplace_back(first + m, b);
  return terms;
}

DriftSegments NumberDriftSegments(const Network& network) {
  DriftSegments segments;
  for (std::size_t i = 0; i < network.stations.size(); ++i) {
    const NetworkStation& st = network.stations[i];
    const NetworkDrift& drift = st.drift;
    segments.first.push_back(-1);
    if (!drift.enabled) continue;
    const std::string where = drift.where.empty() ? st.where + ".drift" : drift.where;
    if (!(drift.translation_rate > 0.0) || !std::isfinite(drift.translation_rate))
      throw InputError(where + ".translation_rate: must be positive");
    if (!(drift.rotation_rate > 0.0) || !std::isfinite(drift.rotation_rate))
      throw InputError(where + ".rotation_rate: must be positive");
    if (drift.knots.size() < 2) {
      throw InputError(where + ": station '" + st.name +
                       "' needs readings at two different times at least (a time column, drift checks)");
    }
    for (std::size_t k = 0; k + 1 < drift.knots.size(); ++k) {
      if (!std::isfinite(drift.knots[k]) || !std::isfinite(drift.knots[k + 1]) ||
          !(drift.knots[k + 1] > drift.knots[k]))
        throw InputError(where +
                         ": the knots of the drift model must increase (two drift checks at one time?)");
    }
    const int n = static_cast<int>(drift.knots.size()) - 1;
    if (!drift.increments.empty() && static_cast<int>(drift.increments.size()) != n)
      throw InputError(where + ": a simulated drift needs one increment per segment (" + std::to_string(n) +
                       ")");
    segments.first.back() = segments.count();
    for (int k = 0; k < n; ++k) {
      segments.station.push_back(static_cast<int>(i));
      segments.duration.push_back(drift.knots[k + 1] - drift.knots[k]);
    }
  }
  return segments;
}

StationPoseVector DriftPriorU(const NetworkDrift& drift, double duration) {
  StationPoseVector u;
  u.head<3>().setConstant(drift.rotation_rate * duration);
  u.tail<3>().setConstant(drift.translation_rate * duration);
  return u;
}

}  // namespace network_internal

StationPoseVector DriftedPose(const StationPoseVector& pose, const NetworkDrift& drift, double t) {
  if (!drift.enabled || drift.increments.empty()) return pose;
  // The poses at the knots, P_0 = pose and P_{k+1} = P_k + increments_k, combined as the adjustment
  // combines them (PoseTerms).
  std::vector<StationPoseVector> knots = {pose};
  for (const StationPoseVector& d : drift.increments) knots.push_back(knots.back() + d);
  StationPoseVector drifted = StationPoseVector::Zero();
  for (const auto& [block, w] : network_internal::PoseTerms(drift, t, 0)) drifted += w * knots[block + 1];
  return drifted;
}

}  // namespace vlt
