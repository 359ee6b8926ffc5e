// network/length_test.cc — NetworkLengthErrors (vlt/network.h, docs/network.md N-13): the ISO
// 10360-10 length-measurement errors of each station against lengths the network calibrates.
#include <cmath>
#include <map>
#include <set>

#include "network/instruments.h"
#include "vlt/network.h"

namespace vlt {

namespace {

bool Rejected(const NetworkResult& result, const std::string& station, const TargetReading& r) {
  for (const RejectedObservation& gone : result.rejected) {
    if (!gone.distance && gone.station == station && gone.target == r.target && gone.face == r.face &&
        gone.where == r.where)
      return true;
  }
  return false;
}

// Station i's own point of every target it read (station frame, the instrument at its estimates:
// what the instrument reports), the mean of its kept readings.
std::map<std::string, Eigen::Vector3d> StationPoints(const Network& network, const NetworkResult& result,
                                                     const network_internal::Instruments& instruments,
                                                     int i) {
  const NetworkStation& st = network.stations[i];
  std::map<std::string, std::pair<Eigen::Vector3d, int>> sum;
  for (const TargetReading& r : st.readings) {
    if (Rejected(result, st.name, r)) continue;
    const int k = instruments.ReadingModel(i, r);  // the air in force at the reading (N-2a)
    const Eigen::VectorXd shared = instruments.Local(k, instruments.s0);
    Eigen::Vector3d y;
    instruments.models[k].Evaluate(r.readings.data(), shared.data(), y.data());
    auto& [acc, count] = sum[r.target];
    if (count == 0) acc.setZero();
    acc += y;
    ++count;
  }
  std::map<std::string, Eigen::Vector3d> points;
  for (const auto& [name, acc_count] : sum) points[name] = acc_count.first / acc_count.second;
  return points;
}

}  // namespace

std::vector<NetworkLengthError> NetworkLengthErrors(const Network& network, const NetworkResult& result,
                                                    const NetworkLengthTest& test) {
  const network_internal::Instruments instruments = network_internal::MakeInstruments(network);
  std::vector<NetworkLengthError> errors;
  for (int i = 0; i < static_cast<int>(network.stations.size()); ++i) {
    const std::map<std::string, Eigen::Vector3d> own = StationPoints(network, result, instruments, i);
    for (std::size_t a = 0; a < result.targets.size(); ++a) {
      const auto pa = own.find(result.targets[a].name);
      if (pa == own.end()) continue;
      for (std::size_t b = a + 1; b < result.targets.size(); ++b) {
        const auto pb = own.find(result.targets[b].name);
        if (pb == own.end()) continue;
        const Eigen::Vector3d d = result.targets[b].position - result.targets[a].position;
        const double length = d.norm();
        if (!(length >= test.min_length) || !(length > 0.0)) continue;
        // u(L_ref): the gradient [-e, e] over the two targets and their joint covariance.
        const Eigen::Vector3d e = d / length;
        const int oa = result.target_offset[a], ob = result.target_offset[b];
        const double var = e.dot(result.covariance.block<3, 3>(oa, oa) * e) +
                           e.dot(result.covariance.block<3, 3>(ob, ob) * e) -
                           2.0 * e.dot(result.covariance.block<3, 3>(oa, ob) * e);
        NetworkLengthError out;
        out.station = network.stations[i].name;
        out.from = result.targets[a].name;
        out.to = result.targets[b].name;
        out.length = length;
        out.error = (pb->second - pa->second).norm() - length;
        out.u = std::sqrt(std::max(0.0, var));
        out.U = result.k * out.u;
        out.mpe = test.mpe_a + test.mpe_b * length;
        out.decision = DecideConformity({-out.mpe, out.mpe}, out.error, out.u, out.U);
        errors.push_back(std::move(out));
      }
    }
  }
  return errors;
}

}  // namespace vlt
