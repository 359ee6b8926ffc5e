// network/simulate.cc — planned readings of a network (offline) and simulated measurements with
// a known truth (vlt/network.h): the exact inverse of the instrument model at each station.
#include <map>

#include <Eigen/Eigenvalues>

#include "mcm/random.h"
#include "network/drift.h"
#include "network/instruments.h"
#include "vlt/error.h"
#include "vlt/network.h"

namespace vlt {

namespace {

using TargetList = std::vector<std::pair<std::string, Eigen::Vector3d>>;

// Readings of the part-frame point `part` from a station at `pose`, by an instrument whose shared
// inputs are `shared`: m' = f^-1(R^T (x - t); params), then the range the tracker shows is
// rho = rho' / (n_est / n) (vlt/measurement_model.h: rho' = rho n_est / n).
Eigen::Vector3d ReadingsAt(const MeasurementModel& model, const double* shared, const StationPoseVector& pose,
                           const Eigen::Vector3d& part, Face face) {
  const Eigen::Matrix3d r = PoseRotationMatrix(pose(0), pose(1), pose(2));
  const Eigen::Vector3d local = r.transpose() * (part - pose.tail<3>());
  const std::array<double, 3> m = InverseReadings(*model.setup().model, shared + model.params_offset(),
                                                  {local(0), local(1), local(2)}, face);
  const double scale = model.PrepareShared(shared).range_scale;
  return {m[0] / scale, m[1], m[2]};
}

// The true drift of every drifting station (N-12): its given increments, or, without them, drawn
// from the drift prior N(0, (rate Delta t_k)^2) (stream 4 of the simulation's key).
template <class Normal>
void DrawDrift(Network& network, const Normal& normal) {
  const network_internal::DriftSegments segments = network_internal::NumberDriftSegments(network);
  for (std::size_t i = 0; i < network.stations.size(); ++i) {
    NetworkDrift& drift = network.stations[i].drift;
    if (!drift.enabled || !drift.increments.empty()) continue;
    for (std::size_t k = 0; k + 1 < drift.knots.size(); ++k) {
      const std::uint64_t segment = static_cast<std::uint64_t>(segments.first[i]) + k;
      const StationPoseVector u = network_internal::DriftPriorU(drift, drift.knots[k + 1] - drift.knots[k]);
      StationPoseVector d;
      for (int c = 0; c < 6; ++c) d(c) = u(c) * normal(4, 6 * segment + static_cast<std::uint64_t>(c));
      drift.increments.push_back(d);
    }
  }
}

}  // namespace

void PlanNetworkReadings(Network& network, const TargetList& nominal,
                         const std::vector<std::vector<PlannedSighting>>& sees) {
  const network_internal::Instruments instruments = network_internal::MakeInstruments(network);
  std::map<std::string, Eigen::Vector3d> where_is(nominal.begin(), nominal.end());
  for (std::size_t i = 0; i < network.stations.size() && i < sees.size(); ++i) {
    NetworkStation& st = network.stations[i];
    const int k = instruments.station_model[i];
    const Eigen::VectorXd shared = instruments.Local(k, instruments.s0);
    for (const PlannedSighting& s : sees[i]) {
      const auto it = where_is.find(s.target);
      if (it == where_is.end())
        throw InputError(s.where + ": unknown target '" + s.target + "' (not in [targets])");
      TargetReading reading;
      reading.target = s.target;
      reading.face = s.face;
      reading.where = s.where;
      try {
        reading.readings = ReadingsAt(instruments.models[k], shared.data(), st.pose, it->second, s.face);
      } catch (const NumericalError& error) {
        throw InputError(s.where + ": station '" + st.name + "' cannot read '" + s.target +
                         "': " + error.what());
      }
      st.readings.push_back(std::move(reading));
    }
  }
}

Network SimulateNetwork(const Network& network, const TargetList& truth, std::uint64_t seed,
                        Eigen::VectorXd* shared_true) {
  const network_internal::Instruments instruments = network_internal::MakeInstruments(network);
  const int S = instruments.size();
  const mcm_internal::KeyedStream stream(seed);
  // Draw `index` of stream `input`: one standard normal depending on (seed, input, index) only.
  auto normal = [&](std::uint64_t input, std::uint64_t index) {
    double z[4];
    stream.Normals(index / 4, input, z);
    return z[index % 4];
  };
  // True shared inputs of every instrument: s0 + D R^1/2 z (D = diag(u), R the correlation and
  // R^1/2 its symmetric square root: R may be singular, r = +-1; (D R^1/2)(D R^1/2)^T = Sigma).
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(instruments.correlation);
  const Eigen::MatrixXd root = instruments.sigma.diagonal().cwiseSqrt().asDiagonal() * eig.eigenvectors() *
                               eig.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal() *
                               eig.eigenvectors().transpose();
  Eigen::VectorXd z(S);
  for (int k = 0; k < S; ++k) z(k) = normal(0, static_cast<std::uint64_t>(k));
  const Eigen::VectorXd s_true = instruments.s0 + root * z;
  if (shared_true) *shared_true = s_true;

  std::map<std::string, Eigen::Vector3d> where_is(truth.begin(), truth.end());
  Network out = network;
  DrawDrift(out, normal);
  std::uint64_t counter = 0;
  for (std::size_t i = 0; i < out.stations.size(); ++i) {
    NetworkStation& st = out.stations[i];
    for (TargetReading& reading : st.readings) {
      const int k = instruments.ReadingModel(static_cast<int>(i), reading);  // its air (N-2a)
      const MeasurementModel& model = instruments.models[k];
      const Eigen::VectorXd shared = instruments.Local(k, s_true);
      const auto it = where_is.find(reading.target);
      if (it == where_is.end())
        throw InputError(reading.where + ": no true position of '" + reading.target + "'");
      const StationPoseVector pose =
          st.drift.enabled ? DriftedPose(st.pose, st.drift, reading.time.value_or(st.drift.knots.front()))
                           : st.pose;
      Eigen::Vector3d m = ReadingsAt(model, shared.data(), pose, it->second, reading.face);
      const Eigen::Vector3d sigma = model.reading_uncertainty(m(0));
      for (int c = 0; c < 3; ++c) m(c) += sigma(c) * normal(1, 3 * counter + c);
      ++counter;
      reading.readings = m;
    }
  }
  for (std::size_t r = 0; r < out.references.size(); ++r) {
    NetworkReference& ref = out.references[r];
    const auto it = where_is.find(ref.target);
    if (it == where_is.end()) throw InputError(ref.where + ": no true position of '" + ref.target + "'");
    for (int c = 0; c < 3; ++c) ref.position(c) = it->second(c) + ref.u * normal(2, 3 * r + c);
  }
  // A distance observation: the true distance plus N(0, u^2); a scale bar's calibrated length is the
  // one that gives it at the bar's temperature (the thermal correction of N-4a undone).
  for (std::size_t k = 0; k < out.distances.size(); ++k) {
    NetworkDistance& d = out.distances[k];
    const auto from = where_is.find(d.from), to = where_is.find(d.to);
    if (from == where_is.end() || to == where_is.end())
      throw InputError(d.where + ": no true position of '" + (from == where_is.end() ? d.from : d.to) + "'");
    d.length = (to->second - from->second).norm() + d.u * normal(3, k);
    if (d.scale_bar)
      d.calibrated_length = d.length / (1.0 + d.cte * (d.temperature - d.reference_temperature));
  }
  return out;
}

}  // namespace vlt
