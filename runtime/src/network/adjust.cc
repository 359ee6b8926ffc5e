// network/adjust.cc — AdjustNetwork (vlt/network.h): structure checks and starting values, the
// Ceres solve, the covariance with consider parameters, residual statistics.
// Equations: docs/network.md (N-1 .. N-9 below refer to it).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <set>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/LU>
#include <ceres/ceres.h>

#include "vlt/error.h"
#include "vlt/gum.h"
#include "network/adjust.h"
#include "network/drift.h"
#include "network/instruments.h"
#include "vlt/network.h"

namespace vlt {

namespace {

// One reading of a target by a station, prepared at the prior estimates s0 of the shared inputs.
struct Observation {
  int station = 0, target = 0, reading = 0;  // reading: index into the station's readings
  int model = 0;  // Instruments::models: the station's instrument, with the station's air if it has its own
  Eigen::Vector3d readings;
  Eigen::Vector3d y0;         // station-frame point at s0 [m]
  Eigen::Vector3d sigma;      // u of range [m], azimuth, elevation [rad]
  Eigen::Matrix3d whitening;  // W = S^-1/2 J_r^-1 (N-2): W^T W = (J_r S J_r^T)^-1
  // The pose of the reading (N-12): (block, weight) of the poses it combines, -1 the station's pose,
  // g >= 0 the pose at the end of drift segment g (DriftSegments); {(-1, 1)} without drift.
  std::vector<std::pair<int, double>> poses = {{-1, 1.0}};
};

// The stacked shared inputs' split: estimated (self-calibration) and consider parameters.
struct SharedSplit {
  std::vector<int> estimated, consider;  // indices into the stacked shared vector
};

// y and d y / d s (3 x stacked size, zero outside the inputs of the reading's model) of one reading
// at the stacked shared values s.
void EvaluateReading(const network_internal::Instruments& instruments, const Observation& obs,
                     const Eigen::VectorXd& s, Eigen::Vector3d& y, Eigen::Matrix3d& dy_dr,
                     Eigen::MatrixXd& dy_ds) {
  const int k = obs.model, n = instruments.Size(k);
  Eigen::Matrix<double, 3, Eigen::Dynamic> local(3, n);
  const Eigen::VectorXd shared = instruments.Local(k, s);
  instruments.models[k].EvaluateWithJacobian(obs.readings.data(), shared.data(), y.data(), dy_dr.data(),
                                             local.data());
  dy_ds.setZero(3, s.size());
  const std::vector<int>& stacked = instruments.inputs[k];
  for (int c = 0; c < n; ++c) dy_ds.col(stacked[c]) = local.col(c);
}

// Residual of one reading (N-3): e = W (y(s) - R^T (x - t)), blocks [target 3 (, s_E) (, one pose
// of 6 per term of obs.poses)], R and t of the reading's pose sum_j w_j P_j (one term, the
// station's pose, without drift; the poses at the knots around the reading's time with drift,
// N-12).
class ReadingCost : public ceres::CostFunction {
 public:
  ReadingCost(const network_internal::Instruments& instruments, const Observation& obs,
              const SharedSplit& split)
      : instruments_(instruments), obs_(obs), split_(split), e_(static_cast<int>(split.estimated.size())) {
    set_num_residuals(3);
    mutable_parameter_block_sizes()->push_back(3);
    if (e_ > 0) mutable_parameter_block_sizes()->push_back(e_);
    for (std::size_t j = 0; j < obs.poses.size(); ++j) mutable_parameter_block_sizes()->push_back(6);
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const int first_pose = e_ > 0 ? 2 : 1;
    StationPoseVector pose = StationPoseVector::Zero();
    for (std::size_t j = 0; j < obs_.poses.size(); ++j)
      pose += obs_.poses[j].second * Eigen::Map<const StationPoseVector>(parameters[first_pose + j]);
    const Eigen::Map<const Eigen::Vector3d> x(parameters[0]);
    Eigen::Vector3d y = obs_.y0;
    Eigen::MatrixXd dy_ds;
    if (e_ > 0) {
      Eigen::VectorXd s = instruments_.s0;
      for (int k = 0; k < e_; ++k) s(split_.estimated[k]) = parameters[1][k];
      Eigen::Matrix3d dy_dr;
      EvaluateReading(instruments_, obs_, s, y, dy_dr, dy_ds);
    }
    const Eigen::Matrix3d rotation = PoseRotationMatrix(pose(0), pose(1), pose(2));
    const Eigen::Vector3d d = x - pose.tail<3>();
    Eigen::Map<Eigen::Vector3d> residual(residuals);
    residual = obs_.whitening * (y - rotation.transpose() * d);
    if (!jacobians) return true;
    const Eigen::Matrix3d w_rt = obs_.whitening * rotation.transpose();
    if (jacobians[0]) {
      Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> j(jacobians[0]);
      j = -w_rt;
    }
    if (e_ > 0 && jacobians[1]) {
      Eigen::Map<Eigen::Matrix<double, 3, Eigen::Dynamic, Eigen::RowMajor>> j(jacobians[1], 3, e_);
      for (int k = 0; k < e_; ++k) j.col(k) = obs_.whitening * dy_ds.col(split_.estimated[k]);
    }
    Eigen::Matrix<double, 3, 6> j_pose;
    Eigen::Matrix3d d_rotation[3];
    PoseRotationDerivatives(pose(0), pose(1), pose(2), d_rotation);
    for (int k = 0; k < 3; ++k) j_pose.col(k) = -obs_.whitening * (d_rotation[k].transpose() * d);
    j_pose.rightCols<3>() = w_rt;
    using PoseJacobian = Eigen::Map<Eigen::Matrix<double, 3, 6, Eigen::RowMajor>>;
    for (std::size_t j = 0; j < obs_.poses.size(); ++j) {
      if (jacobians[first_pose + j]) PoseJacobian{jacobians[first_pose + j]} = obs_.poses[j].second * j_pose;
    }
    return true;
  }

 private:
  const network_internal::Instruments& instruments_;
  const Observation& obs_;
  const SharedSplit& split_;
  int e_;
};

// The drift prior of one segment (N-12): W (P_to - P_from), W = diag(1 / (rate Delta t)), blocks
// [from 6, to 6] (the poses at the segment's two knots).
class DriftPriorCost : public ceres::SizedCostFunction<6, 6, 6> {
 public:
  explicit DriftPriorCost(const StationPoseVector& w) : w_(w) {}
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    Eigen::Map<StationPoseVector> r(residuals);
    r = w_.cwiseProduct(Eigen::Map<const StationPoseVector>(parameters[1]) -
                        Eigen::Map<const StationPoseVector>(parameters[0]));
    for (int block = 0; block < 2; ++block) {
      if (!jacobians || !jacobians[block]) continue;
      Eigen::Map<Eigen::Matrix<double, 6, 6, Eigen::RowMajor>> j(jacobians[block]);
      j = (block == 0 ? -w_ : w_).asDiagonal();
    }
    return true;
  }

 private:
  StationPoseVector w_;
};

// A linear pseudo-observation L^-1 (v - v0) of a block (references, pose priors, self-calibration
// priors): whitening L^-1 with rows only for the components that carry one.
class PriorCost : public ceres::CostFunction {
 public:
  PriorCost(Eigen::VectorXd v0, Eigen::MatrixXd whitening) : v0_(std::move(v0)), w_(std::move(whitening)) {
    set_num_residuals(static_cast<int>(w_.rows()));
    mutable_parameter_block_sizes()->push_back(static_cast<int>(v0_.size()));
  }
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const Eigen::Map<const Eigen::VectorXd> v(parameters[0], v0_.size());
    Eigen::Map<Eigen::VectorXd>(residuals, w_.rows()) = w_ * (v - v0_);
    if (jacobians && jacobians[0]) {
      Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
          jacobians[0], w_.rows(), w_.cols()) = w_;
    }
    return true;
  }
  const Eigen::VectorXd& v0() const { return v0_; }
  const Eigen::MatrixXd& whitening() const { return w_; }

 private:
  Eigen::VectorXd v0_;
  Eigen::MatrixXd w_;
};

// A distance observation (N-4a): e = (|x_to - x_from| - L) / u, blocks [from 3, to 3].
class DistanceCost : public ceres::SizedCostFunction<1, 3, 3> {
 public:
  DistanceCost(double length, double u) : length_(length), u_(u) {}
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const Eigen::Map<const Eigen::Vector3d> from(parameters[0]), to(parameters[1]);
    const Eigen::Vector3d d = to - from;
    const double norm = d.norm();
    residuals[0] = (norm - length_) / u_;
    if (!jacobians) return true;
    const Eigen::Vector3d unit = norm > 0.0 ? Eigen::Vector3d(d / norm) : Eigen::Vector3d::Zero();
    for (int block = 0; block < 2; ++block) {
      if (!jacobians[block]) continue;
      Eigen::Map<Eigen::Vector3d> j(jacobians[block]);
      j = (block == 0 ? -unit : unit) / u_;
    }
    return true;
  }

 private:
  double length_, u_;
};

// Upper tail of chi-square: P(chi2_dof >= x).
double ChiSquareUpperTail(double x, int dof) {
  return dof > 0 ? std::clamp(1.0 - ChiSquareCdf(x, dof), 0.0, 1.0) : 1.0;
}

// Pose (rx, ry, rz, tx, ty, tz) of a rotation R = Rz Ry Rx and translation (inverse of
// PoseRotationMatrix; |ry| < pi/2 for a tracker standing upright or tilted less than 90 deg).
StationPoseVector PoseFromRotation(const Eigen::Matrix3d& r, const Eigen::Vector3d& t) {
  StationPoseVector pose;
  pose(1) = std::asin(std::clamp(-r(2, 0), -1.0, 1.0));
  pose(0) = std::atan2(r(2, 1), r(2, 2));
  pose(2) = std::atan2(r(1, 0), r(0, 0));
  pose.tail<3>() = t;
  return pose;
}

// Rigid transform dst ~ R src + t from >= 3 non-collinear point pairs; false when degenerate.
bool FitRigid(const Eigen::Matrix3Xd& src, const Eigen::Matrix3Xd& dst, Eigen::Matrix4d& transform) {
  if (src.cols() < 3) return false;
  const Eigen::Matrix3Xd centred = src.colwise() - src.rowwise().mean();
  Eigen::JacobiSVD<Eigen::Matrix3Xd> svd(centred);
  if (!(svd.singularValues()(1) > 1e-6 * std::max(1.0, svd.singularValues()(0)))) return false;
  transform = Eigen::umeyama(src, dst, false);
  return true;
}

// --- Shared inputs: estimated (self-calibration) or considered (N-6).
SharedSplit SplitSharedInputs(const Network& network, const network_internal::Instruments& instruments,
                              const Eigen::VectorXd& u_shared) {
  const std::string& file = network.where;
  const int S = instruments.size();
  SharedSplit split;
  std::vector<bool> estimated(S, false);
  for (const std::string& name : network.self_calibrate) {
    int k = 0;
    while (k < S && instruments.names[k] != name) ++k;
    if (k == S) {
      throw InputError(file + ": network.self_calibrate: unknown input '" + name +
                       "' (the instruments' inputs: " + (S > 0 ? instruments.names[0] : std::string("none")) +
                       (S > 1 ? ", ..." : "") + ")");
    }
    if (!(u_shared(k) > 0.0)) {
      throw InputError(file + ": network.self_calibrate: '" + name +
                       "' has u = 0: it is known exactly, nothing to calibrate");
    }
    estimated[k] = true;
  }
  for (int k = 0; k < S; ++k) (estimated[k] ? split.estimated : split.consider).push_back(k);
  for (int a : split.estimated) {
    for (int c : split.consider) {
      if (instruments.correlation(a, c) != 0.0) {
        throw InputError(file + ": network.self_calibrate: '" + instruments.names[a] +
                         "' is correlated with '" + instruments.names[c] +
                         "', which is not self-calibrated: calibrate both or neither");
      }
    }
  }
  return split;
}

// Reading r of station i (read through `model`) prepared at s0 (N-2): its station-frame point y0 and its
// whitening W.
Observation PrepareObservation(const network_internal::Instruments& instruments, const TargetReading& reading,
                               int model, int i, int r, int target) {
  Observation obs;
  obs.station = i;
  obs.target = target;
  obs.reading = r;
  obs.readings = reading.readings;
  obs.model = model;
  Eigen::Matrix3d dy_dr;
  Eigen::MatrixXd dy_ds;
  EvaluateReading(instruments, obs, instruments.s0, obs.y0, dy_dr, dy_ds);
  obs.sigma = instruments.models[obs.model].reading_uncertainty(obs.readings(0));
  Eigen::FullPivLU<Eigen::Matrix3d> lu(dy_dr);
  if (!lu.isInvertible() || !(obs.sigma.minCoeff() > 0.0)) {
    throw InputError(reading.where + ": the reading of '" + reading.target +
                     "' carries no weight (singular reading "
                     "Jacobian or zero reading noise: give [tracker.noise])");
  }
  obs.whitening = obs.sigma.cwiseInverse().asDiagonal() * lu.inverse();
  if (!obs.y0.allFinite() || !obs.whitening.allFinite())
    throw InputError(reading.where + ": reading gives no finite point");
  return obs;
}

// --- Targets, in order of first appearance; observations prepared at s0 (N-2).
struct PreparedReadings {
  std::map<std::string, int> target_index;
  std::vector<std::string> target_names;
  std::vector<std::set<int>> target_stations;
  std::vector<int> target_readings;
  std::vector<Observation> observations;
};

// The poses a reading of station i combines (Observation::poses, N-12); InputError without its time.
std::vector<std::pair<int, double>> ReadingPoses(const Network& network,
                                                 const network_internal::DriftSegments& segments, int i,
                                                 const TargetReading& reading) {
  const NetworkStation& st = network.stations[i];
  if (!st.drift.enabled) return {{-1, 1.0}};
  if (!reading.time) {
    throw InputError(
        reading.where + ": station '" + st.name +
        "' has a drift model: its readings need their time (a time column, docs/network.md N-12)");
  }
  return network_internal::PoseTerms(st.drift, *reading.time, segments.first[i]);
}

PreparedReadings PrepareReadings(const Network& network, const network_internal::Instruments& instruments,
                                 const network_internal::DriftSegments& segments) {
  PreparedReadings prepared;
  std::set<std::string> station_names;
  for (int i = 0; i < static_cast<int>(network.stations.size()); ++i) {
    const NetworkStation& st = network.stations[i];
    if (!station_names.insert(st.name).second)
      throw InputError(st.where + ".name: station '" + st.name + "' defined twice");
    if (st.readings.empty()) throw InputError(st.where + ": station '" + st.name + "' has no readings");
    for (int r = 0; r < static_cast<int>(st.readings.size()); ++r) {
      const TargetReading& reading = st.readings[r];
      auto [it, inserted] =
          prepared.target_index.emplace(reading.target, static_cast<int>(prepared.target_names.size()));
      if (inserted) {
        prepared.target_names.push_back(reading.target);
        prepared.target_stations.emplace_back();
        prepared.target_readings.push_back(0);
      }
      if (!st.air_changes.empty() && !reading.time) {
        throw InputError(
            reading.where + ": station '" + st.name +
            "' has air that changes: its readings need their time (a time column, docs/network.md "
            "N-2a)");
      }
      Observation obs =
          PrepareObservation(instruments, reading, instruments.ReadingModel(i, reading), i, r, it->second);
      obs.poses = ReadingPoses(network, segments, i, reading);
      prepared.target_stations[obs.target].insert(i);
      ++prepared.target_readings[obs.target];
      prepared.observations.push_back(std::move(obs));
    }
  }
  return prepared;
}

// --- Distance observations (N-4a) between targets the stations read.
struct DistanceObservation {
  int from = 0, to = 0;  // target indices
  double length = 0.0, u = 0.0;
  int index = 0;  // into Network::distances
};

std::vector<DistanceObservation> PrepareDistances(const Network& network,
                                                  const std::map<std::string, int>& target_index) {
  std::vector<DistanceObservation> distances;
  for (std::size_t k = 0; k < network.distances.size(); ++k) {
    const NetworkDistance& d = network.distances[k];
    DistanceObservation obs;
    obs.index = static_cast<int>(k);
    auto target = [&](const char* key, const std::string& name) {
      const auto it = target_index.find(name);
      if (it == target_index.end())
        throw InputError(d.where + "." + key + ": no station reads target '" + name + "'");
      return it->second;
    };
    obs.from = target("from", d.from);
    obs.to = target("to", d.to);
    if (obs.from == obs.to) throw InputError(d.where + ".to: the same target as `from`");
    if (!(d.length > 0.0) || !std::isfinite(d.length))
      throw InputError(d.where + ".length: must be positive");
    if (!(d.u > 0.0) || !std::isfinite(d.u)) throw InputError(d.where + ".u: must be positive");
    obs.length = d.length;
    obs.u = d.u;
    distances.push_back(obs);
  }
  return distances;
}

// Targets tied together by distance observations form groups: a group's block of the normal
// matrix is full, the blocks of different groups are independent (N-5). A target without a
// distance is a group of its own (3 x 3). Members in ascending order.
struct TargetGroups {
  std::vector<std::vector<int>> members;
  std::vector<int> group, place;  // per target: its group and its place among the members
};

TargetGroups GroupTargets(int T, const std::vector<DistanceObservation>& distances) {
  std::vector<int> parent(T);
  for (int t = 0; t < T; ++t) parent[t] = t;
  auto root = [&](int t) {
    while (parent[t] != t) t = parent[t] = parent[parent[t]];
    return t;
  };
  for (const DistanceObservation& d : distances) parent[root(d.from)] = root(d.to);
  TargetGroups groups;
  groups.group.assign(T, -1);
  groups.place.assign(T, 0);
  std::map<int, int> group_of_root;
  for (int t = 0; t < T; ++t) {
    const auto [it, inserted] = group_of_root.emplace(root(t), static_cast<int>(groups.members.size()));
    if (inserted) groups.members.emplace_back();
    groups.group[t] = it->second;
    groups.place[t] = static_cast<int>(groups.members[it->second].size());
    groups.members[it->second].push_back(t);
  }
  return groups;
}

// --- Datum and structure (N-1): a held station, or at least 3 references (each read, given once,
// with u > 0). Returns the names of the reference targets.
std::set<std::string> CheckDatum(const Network& network, const std::map<std::string, int>& target_index,
                                 bool any_datum_station) {
  std::set<std::string> reference_names;
  for (const NetworkReference& ref : network.references) {
    if (!target_index.count(ref.target))
      throw InputError(ref.where + ".target: no station reads reference target '" + ref.target + "'");
    if (!reference_names.insert(ref.target).second)
      throw InputError(ref.where + ".target: reference '" + ref.target + "' given twice");
    if (!(ref.u > 0.0))
      throw InputError(ref.where + ".u: must be positive (hold a station as the datum for an exact frame)");
  }
  if (!any_datum_station && network.references.size() < 3) {
    throw InputError(
        network.where +
        ": datum: the part frame is undetermined: hold one station as the datum ([datum] station = "
        "\"<name>\") or give at least 3 [[reference]] targets with known coordinates");
  }
  return reference_names;
}

// --- Structure and starting values (N-1). The stations are chained through common targets:
// from the held stations (or, without one, from the first station as a provisional frame), a
// station is placed by >= 3 non-collinear targets already placed (Umeyama's closed form,
// Eigen::umeyama) and then places the targets it reads. A station never placed is not tied to
// the network. Without a held station, the references (>= 3, not collinear) then carry the
// provisional frame into the part frame.
struct StartingValues {
  const Network& network;
  const std::vector<std::vector<const Observation*>>& by_station;
  const int P;
  std::vector<Eigen::Vector3d> x;
  std::vector<bool> placed_target;
  std::vector<StationPoseVector> pose;
  std::vector<bool> placed_station;

  StartingValues(const Network& network, const std::vector<std::vector<const Observation*>>& by_station,
                 int T)
      : network(network),
        by_station(by_station),
        P(static_cast<int>(network.stations.size())),
        x(T, Eigen::Vector3d::Zero()),
        placed_target(T, false),
        pose(P, StationPoseVector::Zero()),
        placed_station(P, false) {}

  // The targets of station i not placed yet, each at the mean of its readings in the part frame.
  void PlaceTargetsOf(int i) {
    std::map<int, std::pair<Eigen::Vector3d, int>> sum;
    const Eigen::Matrix3d r = PoseRotationMatrix(pose[i](0), pose[i](1), pose[i](2));
    for (const Observation* obs : by_station[i]) {
      if (placed_target[obs->target]) continue;
      auto& [acc, count] = sum[obs->target];
      if (count == 0) acc.setZero();
      acc += r * obs->y0 + pose[i].tail<3>();
      ++count;
    }
    for (auto& [t, acc_count] : sum) {
      x[t] = acc_count.first / acc_count.second;
      placed_target[t] = true;
    }
  }

  void StartFromHeldStations(bool any_datum_station) {
    for (int i = 0; i < P; ++i) {
      if (network.stations[i].datum) {
        pose[i] = network.stations[i].pose;
        placed_station[i] = true;
      }
    }
    if (!any_datum_station) placed_station[0] = true;  // provisional frame: station 0's
    for (int i = 0; i < P; ++i)
      if (placed_station[i]) PlaceTargetsOf(i);
  }

  // Station i from the targets already placed; false while it shares too few of them.
  bool PlaceStation(int i) {
    std::map<int, std::pair<Eigen::Vector3d, int>> local;  // station-frame mean per placed target
    for (const Observation* obs : by_station[i]) {
      if (!placed_target[obs->target]) continue;
      auto& [acc, count] = local[obs->target];
      if (count == 0) acc.setZero();
      acc += obs->y0;
      ++count;
    }
    Eigen::Matrix3Xd src(3, local.size()), dst(3, local.size());
    int c = 0;
    for (auto& [t, acc_count] : local) {
      src.col(c) = acc_count.first / acc_count.second;
      dst.col(c++) = x[t];
    }
    Eigen::Matrix4d transform;
    if (!FitRigid(src, dst, transform)) return false;
    pose[i] = PoseFromRotation(transform.topLeftCorner<3, 3>(), transform.topRightCorner<3, 1>());
    placed_station[i] = true;
    PlaceTargetsOf(i);
    return true;
  }

  void ChainStations() {
    for (bool progress = true; progress;) {
      progress = false;
      for (int i = 0; i < P; ++i) {
        if (placed_station[i]) continue;
        if (PlaceStation(i)) progress = true;
      }
    }
    for (int i = 0; i < P; ++i) {
      if (!placed_station[i]) {
        throw InputError(
            network.stations[i].where + ": station '" + network.stations[i].name +
            "' shares fewer than 3 non-collinear targets with the rest of the network (disconnected "
            "network; give it more common targets)");
      }
    }
  }

  // The provisional frame (station 0's) carried into the part frame by the references.
  void CarryIntoPartFrame(const std::map<std::string, int>& target_index) {
    Eigen::Matrix3Xd src(3, network.references.size()), dst(3, network.references.size());
    for (std::size_t r = 0; r < network.references.size(); ++r) {
      src.col(static_cast<Eigen::Index>(r)) = x[target_index.at(network.references[r].target)];
      dst.col(static_cast<Eigen::Index>(r)) = network.references[r].position;
    }
    Eigen::Matrix4d transform;
    if (!FitRigid(src, dst, transform)) {
      throw InputError(network.where +
                       ": datum: the references do not fix the part frame: they are collinear (give at least "
                       "3 references not on one line, or hold one station as the datum)");
    }
    const Eigen::Matrix3d r = transform.topLeftCorner<3, 3>();
    const Eigen::Vector3d t = transform.topRightCorner<3, 1>();
    for (int i = 0; i < P; ++i) {
      pose[i] = PoseFromRotation(r * PoseRotationMatrix(pose[i](0), pose[i](1), pose[i](2)),
                                 r * pose[i].tail<3>() + t);
    }
  }

  // Starting values: a given pose where the file gives one (the plan's, or the user's better
  // guess), then every target from its readings.
  void FromGivenPoses() {
    for (int i = 0; i < P; ++i)
      if (network.stations[i].pose_given) pose[i] = network.stations[i].pose;
    std::fill(placed_target.begin(), placed_target.end(), false);
    for (int i = 0; i < P; ++i) PlaceTargetsOf(i);
  }
};

// A pseudo-observation (N-4) as the normal matrix sees it.
struct Prior {
  int offset;  // first unknown of the block (internal order)
  const PriorCost* cost;
  const double* block;  // the block's values
};

// One bundle adjustment (docs/network.md), its state from the prepared readings to the result.
struct Adjustment {
  const Network& network;
  const std::string& file;
  const network_internal::Instruments instruments;
  const Eigen::VectorXd& s0;
  const Eigen::MatrixXd& sigma_shared;
  const Eigen::VectorXd u_shared;
  const SharedSplit split;
  const int E, C;
  const network_internal::DriftSegments segments;
  const PreparedReadings readings;
  const std::vector<Observation>& observations;
  const int T, P;
  const std::vector<DistanceObservation> distances;
  const TargetGroups groups;
  bool any_datum_station = false;
  std::set<std::string> reference_names;
  std::vector<std::vector<const Observation*>> by_station;
  std::vector<Eigen::Vector3d> x;
  std::vector<StationPoseVector> pose;
  std::vector<StationPoseVector> knot;  // the pose at the end of every drift segment (N-12)
  // Unknowns, internal order [free poses | poses at the drift knots | s_E | targets].
  std::vector<int> pose_offset, knot_offset;
  int a = 0, e_offset = 0, n = 0;
  Eigen::VectorXd s_est;
  // The solve: the problem owns the costs the priors point to.
  std::unique_ptr<ceres::Problem> problem;
  std::vector<Prior> priors;
  struct DriftPrior {
    int from_offset, to_offset;  // -1: a held pose
    const double *from, *to;
    StationPoseVector w;
  };
  std::vector<DriftPrior> drift_priors;
  Eigen::MatrixXd prior_factor;  // L, Sigma_E = L L^T (self-calibration prior)
  // Normal matrix, blockwise, and what the residuals need of it.
  Eigen::MatrixXd n_aa, n_at, g;
  std::vector<Eigen::MatrixXd> n_gg;  // per target group (3 x 3 without distances)
  Eigen::VectorXd e, e_distance;
  std::vector<Eigen::MatrixXd> j_local;
  std::vector<Eigen::Matrix<double, 3, Eigen::Dynamic>> b_consider;
  double chi2 = 0.0;
  // Inverse by the Schur complement.
  std::vector<Eigen::MatrixXd> n_gg_inv;
  Eigen::MatrixXd h, schur, c_aa;
  // Covariance, internal order, and the result's order.
  Eigen::MatrixXd cov_internal, consider_part, c_ta;
  // The consider gain K = -N^-1 J^T B_c (internal order, n x C), and the shared inputs at the
  // solution. Data snooping with the consider inputs as random effects (N-8): L (Sigma_c = L L^T),
  // M^-1 = (I + L^T (B^T B - G^T N^-1 G) L)^-1, and z_hat, the random effects' estimate (units of L).
  Eigen::MatrixXd consider_gain, consider_factor, effects_inverse;
  Eigen::VectorXd s_hat, effects;
  double chi2_random_effects = 0.0;
  int target_start = 0, e_start = 0;
  NetworkResult result;
  // A Monte Carlo trial (network/adjust.h): solver tolerances and covariance blocks for its needs.
  const bool trial;

  Adjustment(const Network& net, bool for_trial)
      : network(net),
        file(net.where),
        instruments(network_internal::MakeInstruments(net)),
        s0(instruments.s0),
        sigma_shared(instruments.sigma),
        u_shared(sigma_shared.diagonal().cwiseSqrt()),
        split(SplitSharedInputs(net, instruments, u_shared)),
        E(static_cast<int>(split.estimated.size())),
        C(static_cast<int>(split.consider.size())),
        segments(network_internal::NumberDriftSegments(net)),
        readings(PrepareReadings(net, instruments, segments)),
        observations(readings.observations),
        T(static_cast<int>(readings.target_names.size())),
        P(static_cast<int>(net.stations.size())),
        distances(PrepareDistances(net, readings.target_index)),
        groups(GroupTargets(T, distances)),
        trial(for_trial) {}

  // The normal matrix's block of targets t1, t2 (of one group).
  Eigen::Block<Eigen::MatrixXd, 3, 3> TargetBlock(int t1, int t2) {
    return n_gg[groups.group[t1]].block<3, 3>(3 * groups.place[t1], 3 * groups.place[t2]);
  }

  void FindStartingValues() {
    for (const NetworkStation& st : network.stations) any_datum_station |= st.datum;
    reference_names = CheckDatum(network, readings.target_index, any_datum_station);
    by_station.resize(P);
    for (const Observation& obs : observations) by_station[obs.station].push_back(&obs);
    StartingValues start(network, by_station, T);
    start.StartFromHeldStations(any_datum_station);
    start.ChainStations();
    if (!any_datum_station) start.CarryIntoPartFrame(readings.target_index);
    start.FromGivenPoses();
    x = std::move(start.x);
    pose = std::move(start.pose);
    knot.resize(segments.count());
    for (int g = 0; g < segments.count(); ++g) knot[g] = pose[segments.station[g]];
  }

  // --- Unknowns: free poses (6 each), drift segments (6 each, N-12), self-calibrated inputs (E),
  // targets (3 each): the order of the normal matrix (targets last, eliminated by the Schur
  // complement, N-5).
  void NumberUnknowns() {
    pose_offset.assign(P, -1);
    for (int i = 0; i < P; ++i) {
      if (!network.stations[i].datum) {
        pose_offset[i] = a;
        a += 6;
      }
    }
    for (int g = 0; g < segments.count(); ++g) {
      knot_offset.push_back(a);
      a += 6;
    }
    e_offset = a;
    a += E;
    n = a + 3 * T;
    s_est.resize(std::max(E, 1));
    for (int k = 0; k < E; ++k) s_est(k) = s0(split.estimated[k]);
  }

  // Pseudo-observations (N-4): references, pose priors, self-calibration priors.
  void AddPriors() {
    for (const NetworkReference& ref : network.references) {
      const int t = readings.target_index.at(ref.target);
      auto* cost = new PriorCost(ref.position, Eigen::Matrix3d::Identity() / ref.u);
      problem->AddResidualBlock(cost, nullptr, x[t].data());
      priors.push_back({a + 3 * t, cost, x[t].data()});
    }
    for (int i = 0; i < P; ++i) {
      const NetworkStation& st = network.stations[i];
      if (st.datum) continue;
      std::vector<int> rows;
      for (int c = 0; c < 6; ++c)
        if (st.pose_u(c) > 0.0) rows.push_back(c);
      if (rows.empty()) continue;
      Eigen::MatrixXd w = Eigen::MatrixXd::Zero(static_cast<int>(rows.size()), 6);
      for (std::size_t r = 0; r < rows.size(); ++r)
        w(static_cast<int>(r), rows[r]) = 1.0 / st.pose_u(rows[r]);
      auto* cost = new PriorCost(st.pose, w);
      problem->AddResidualBlock(cost, nullptr, pose[i].data());
      priors.push_back({pose_offset[i], cost, pose[i].data()});
    }
    AddDriftPriors();
    if (E > 0) AddSelfCalibrationPrior();
  }

  // N-12: the pose change over segment g, D_g = P_to - P_from ~ N(0, (rate Delta t_g)^2) per
  // component, a pseudo-observation 0 of each segment.
  void AddDriftPriors() {
    for (int g = 0; g < segments.count(); ++g) {
      const int i = segments.station[g];
      const NetworkDrift& drift = network.stations[i].drift;
      const StationPoseVector w = network_internal::DriftPriorU(drift, segments.duration[g]).cwiseInverse();
      const bool first = g == segments.first[i];
      double* from = first ? pose[i].data() : knot[g - 1].data();
      problem->AddResidualBlock(new DriftPriorCost(w), nullptr, from, knot[g].data());
      drift_priors.push_back(
          {first ? pose_offset[i] : knot_offset[g - 1], knot_offset[g], from, knot[g].data(), w});
    }
  }

  void AddSelfCalibrationPrior() {
    Eigen::MatrixXd sigma_e(E, E);
    Eigen::VectorXd v0(E);
    for (int p = 0; p < E; ++p) {
      v0(p) = s0(split.estimated[p]);
      for (int q = 0; q < E; ++q) sigma_e(p, q) = sigma_shared(split.estimated[p], split.estimated[q]);
    }
    Eigen::LLT<Eigen::MatrixXd> llt(sigma_e);
    if (llt.info() != Eigen::Success) {
      throw InputError(
          file + ": network.self_calibrate: the prior covariance of the self-calibrated inputs is singular");
    }
    prior_factor = llt.matrixL();
    const Eigen::MatrixXd w = llt.matrixL().solve(Eigen::MatrixXd::Identity(E, E));
    auto* cost = new PriorCost(v0, w);
    problem->AddResidualBlock(cost, nullptr, s_est.data());
    priors.push_back({e_offset, cost, s_est.data()});
  }

  // --- The solve.
  void Solve() {
    ceres::Problem::Options problem_options;
    problem_options.cost_function_ownership = ceres::TAKE_OWNERSHIP;
    problem = std::make_unique<ceres::Problem>(problem_options);
    for (const Observation& obs : observations) {
      std::vector<double*> blocks = {x[obs.target].data()};
      if (E > 0) blocks.push_back(s_est.data());
      for (const auto& [block, w] : obs.poses) blocks.push_back(PoseBlock(obs.station, block));
      problem->AddResidualBlock(new ReadingCost(instruments, obs, split), nullptr, blocks);
    }
    for (const DistanceObservation& d : distances)
      problem->AddResidualBlock(new DistanceCost(d.length, d.u), nullptr, x[d.from].data(), x[d.to].data());
    AddPriors();
    for (int i = 0; i < P; ++i) {
      if (network.stations[i].datum && problem->HasParameterBlock(pose[i].data()))
        problem->SetParameterBlockConstant(pose[i].data());
    }
    ceres::Solver::Options options;
    // Schur elimination of the targets needs something left to reduce to (free poses or s_E).
    options.linear_solver_type = a > 0 ? ceres::DENSE_SCHUR : ceres::DENSE_QR;
    options.max_num_iterations = network.max_iterations;
    options.function_tolerance = 1e-14;
    options.gradient_tolerance = 1e-14;
    options.parameter_tolerance = 1e-13;
    options.num_threads = 1;
    options.logging_type = ceres::SILENT;
    if (trial) {  // network/adjust.h: from the truth's poses, Gauss-Newton steps to 1e-10
      options.initial_trust_region_radius = 1e8;
      options.function_tolerance = 1e-12;
      options.parameter_tolerance = 1e-10;
    }
    ceres::Solver::Summary summary;
    ceres::Solve(options, problem.get(), &summary);
    result.iterations = summary.num_successful_steps + summary.num_unsuccessful_steps;
    if (summary.termination_type != ceres::CONVERGENCE) {
      throw NumericalError(file + ": the bundle adjustment did not converge: " + summary.message);
    }
  }

  // A pose block of station i: -1 its pose, g >= 0 the pose at the end of drift segment g.
  double* PoseBlock(int i, int block) { return block < 0 ? pose[i].data() : knot[block].data(); }
  const double* PoseBlock(int i, int block) const { return block < 0 ? pose[i].data() : knot[block].data(); }
  int PoseOffset(int i, int block) const { return block < 0 ? pose_offset[i] : knot_offset[block]; }

  // Global index of each column of a reading's local Jacobian [target 3 | s_E | 6 per pose term],
  // -1 absent (a held pose).
  std::vector<int> LocalIndex(const Observation& obs) const {
    std::vector<int> index;
    for (int c = 0; c < 3; ++c) index.push_back(a + 3 * obs.target + c);
    for (int c = 0; c < E; ++c) index.push_back(e_offset + c);
    for (const auto& [block, w] : obs.poses) {
      const int offset = PoseOffset(obs.station, block);
      for (int c = 0; c < 6; ++c) index.push_back(offset >= 0 ? offset + c : -1);
    }
    return index;
  }

  // --- Normal matrix and consider cross terms, blockwise (N-5, N-6): unknown order
  // [poses | s_E | targets]; the target block is 3x3 block-diagonal.
  void AssembleNormals() {
    n_aa = Eigen::MatrixXd::Zero(a, a);
    n_at = Eigen::MatrixXd::Zero(a, 3 * T);
    n_gg.clear();
    for (const std::vector<int>& members : groups.members) {
      const int size = 3 * static_cast<int>(members.size());
      n_gg.push_back(Eigen::MatrixXd::Zero(size, size));
    }
    g = Eigen::MatrixXd::Zero(n, C);  // J^T B_c
    e.resize(3 * observations.size());
    j_local.resize(observations.size());
    b_consider.resize(observations.size());
    s_hat = s0;
    for (int k = 0; k < E; ++k) s_hat(split.estimated[k]) = s_est(k);
    for (std::size_t o = 0; o < observations.size(); ++o) AddReading(o);
    chi2 = e.squaredNorm();
    e_distance.resize(static_cast<int>(distances.size()));
    for (std::size_t k = 0; k < distances.size(); ++k) AddDistance(k);
    for (const Prior& prior : priors) AddPrior(prior);
    for (const DriftPrior& prior : drift_priors) AddDriftPrior(prior);
  }

  // A segment's drift prior (N-12): J = [-W, W] over its two poses (a held one has no column).
  void AddDriftPrior(const DriftPrior& prior) {
    const StationPoseVector r = prior.w.cwiseProduct(Eigen::Map<const StationPoseVector>(prior.to) -
                                                     Eigen::Map<const StationPoseVector>(prior.from));
    chi2 += r.squaredNorm();
    const int offsets[2] = {prior.from_offset, prior.to_offset};
    const double signs[2] = {-1.0, 1.0};
    for (int p = 0; p < 2; ++p) {
      for (int q = 0; q < 2; ++q) {
        if (offsets[p] < 0 || offsets[q] < 0) continue;
        for (int c = 0; c < 6; ++c)
          n_aa(offsets[p] + c, offsets[q] + c) += signs[p] * signs[q] * prior.w(c) * prior.w(c);
      }
    }
  }

  // A distance observation (N-4a): J = [-u^T, u^T] / u_L over [from, to], u the unit vector.
  void AddDistance(std::size_t k) {
    const DistanceObservation& d = distances[k];
    const double* params[2] = {x[d.from].data(), x[d.to].data()};
    Eigen::Vector3d j_from, j_to;
    double* jac[2] = {j_from.data(), j_to.data()};
    DistanceCost(d.length, d.u).Evaluate(params, e_distance.data() + k, jac);
    chi2 += e_distance(static_cast<Eigen::Index>(k)) * e_distance(static_cast<Eigen::Index>(k));
    TargetBlock(d.from, d.from) += j_from * j_from.transpose();
    TargetBlock(d.from, d.to) += j_from * j_to.transpose();
    TargetBlock(d.to, d.from) += j_to * j_from.transpose();
    TargetBlock(d.to, d.to) += j_to * j_to.transpose();
  }

  // A reading's whitened residual (3, into `residual`) and its Jacobian over the local unknowns
  // [target 3 | s_E | 6 per pose term] (LocalIndex) at the current estimates.
  Eigen::MatrixXd ReadingJacobian(const Observation& obs, double* residual) const {
    ReadingCost cost(instruments, obs, split);
    const int m = static_cast<int>(obs.poses.size());
    std::vector<const double*> params = {x[obs.target].data()};
    if (E > 0) params.push_back(s_est.data());
    for (const auto& [block, w] : obs.poses) params.push_back(PoseBlock(obs.station, block));
    Eigen::Matrix<double, 3, 3, Eigen::RowMajor> jx;
    Eigen::Matrix<double, 3, Eigen::Dynamic, Eigen::RowMajor> je(3, std::max(E, 1));
    std::vector<Eigen::Matrix<double, 3, 6, Eigen::RowMajor>> jp(m);
    std::vector<double*> jac = {jx.data()};
    if (E > 0) jac.push_back(je.data());
    for (int k = 0; k < m; ++k) jac.push_back(jp[k].data());
    cost.Evaluate(params.data(), residual, jac.data());
    Eigen::MatrixXd j(3, 3 + E + 6 * m);
    j.leftCols(3) = jx;
    if (E > 0) j.middleCols(3, E) = je.leftCols(E);
    for (int k = 0; k < m; ++k) j.middleCols(3 + E + 6 * k, 6) = jp[k];
    return j;
  }

  // J C J^T of a reading's local Jacobian over the noise part of the covariance (N-8).
  Eigen::Matrix3d ReadingHat(const Observation& obs, const Eigen::MatrixXd& j) const {
    const std::vector<int> index = LocalIndex(obs);
    const int local = static_cast<int>(index.size());
    Eigen::MatrixXd c_local = Eigen::MatrixXd::Zero(local, local);
    for (int r = 0; r < local; ++r)
      for (int c = 0; c < local; ++c)
        if (index[r] >= 0 && index[c] >= 0) c_local(r, c) = cov_internal(index[r], index[c]);
    return j * c_local * j.transpose();
  }

  // --- Data snooping with the consider inputs as random effects (N-8). The adjustment weights the
  // readings by their noise; the consider inputs' errors delta_c = L z (z ~ N(0, I)) move every
  // whitened residual by S L z, S = B_c + J K (its own sensitivity B_c and the estimate's, K the
  // consider gain). A misfit that their stated u explains is no gross error, so the w test runs in
  // the model with z as unknowns of prior N(0, I) — the generalised least squares of the readings
  // with their full covariance (noise + B_c Sigma_c B_c^T). From the solution at hand (J^T e = 0 over
  // every row, pseudo-observations included; those have no B rows):
  //   M = I + L^T (B^T B - G^T N^-1 G) L,   z_hat = -M^-1 L^T B^T e,
  //   e_aug = e + S L z_hat,   r_aug = r - diag(S L M^-1 L^T S^T),
  // and w = e_aug / sqrt(r_aug): Baarda's w of that model (C = 0: Baarda's w of this one).
  void ConsiderAsRandomEffects(const Eigen::MatrixXd& sigma_c) {
    chi2_random_effects = chi2;
    if (C == 0) return;
    // L = D V sqrt(Lambda) from the correlation R = D^-1 Sigma_c D^-1 = V Lambda V^T (D = diag(u)):
    // Sigma_c may be singular (a correlation of +-1), and its variances span 1e4 Pa^2 to 1e-12 m^2,
    // which a decomposition of Sigma_c itself would mix at its rounding.
    const Eigen::VectorXd u = sigma_c.diagonal().cwiseMax(0.0).cwiseSqrt();
    Eigen::MatrixXd r = Eigen::MatrixXd::Identity(C, C);
    for (int i = 0; i < C; ++i)
      for (int j = 0; j < C; ++j)
        if (i != j && u(i) > 0.0 && u(j) > 0.0) r(i, j) = sigma_c(i, j) / (u(i) * u(j));
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(r);
    consider_factor =
        u.asDiagonal() * eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
    Eigen::MatrixXd btb = Eigen::MatrixXd::Zero(C, C);
    Eigen::VectorXd bte = Eigen::VectorXd::Zero(C);
    for (std::size_t o = 0; o < observations.size(); ++o) {
      btb += b_consider[o].transpose() * b_consider[o];
      bte += b_consider[o].transpose() * e.segment<3>(3 * static_cast<Eigen::Index>(o));
    }
    // G^T N^-1 G = -g^T K.
    Eigen::MatrixXd m = Eigen::MatrixXd::Identity(C, C) +
                        consider_factor.transpose() * (btb + g.transpose() * consider_gain) * consider_factor;
    m = 0.5 * (m + m.transpose()).eval();
    const Eigen::LLT<Eigen::MatrixXd> llt(m);
    if (llt.info() != Eigen::Success)
      throw NumericalError(file + ": the consider inputs as random effects: M is not positive definite");
    effects_inverse = llt.solve(Eigen::MatrixXd::Identity(C, C));
    const Eigen::VectorXd b = consider_factor.transpose() * bte;
    effects = -effects_inverse * b;
    // chi^2 of that model: min over z of |e + S L z|^2 + |z|^2 = chi^2 - b^T M^-1 b (the same dof:
    // C unknowns and C pseudo-observations more). The fit test judges it.
    chi2_random_effects = std::max(0.0, chi2 + b.dot(effects));
  }

  // S L of a reading (3 x C): how its whitened residual moves with the random effects z.
  Eigen::MatrixXd ReadingEffects(const Observation& obs, const Eigen::MatrixXd& j,
                                 const Eigen::Matrix<double, 3, Eigen::Dynamic>& b) const {
    const std::vector<int> index = LocalIndex(obs);
    Eigen::MatrixXd s = b;
    for (std::size_t r = 0; r < index.size(); ++r)
      if (index[r] >= 0) s += j.col(static_cast<Eigen::Index>(r)) * consider_gain.row(index[r]);
    return s * consider_factor;
  }

  // S L of a distance's whitened residual (|x_to - x_from| - L) / u (1 x C): no consider input of its
  // own, S = grad K / u over its two targets.
  Eigen::RowVectorXd DistanceEffects(const DistanceObservation& d, const Eigen::Matrix<double, 6, 1>& grad,
                                     double u) const {
    const Eigen::RowVectorXd s = (grad.head<3>().transpose() * consider_gain.middleRows<3>(a + 3 * d.from) +
                                  grad.tail<3>().transpose() * consider_gain.middleRows<3>(a + 3 * d.to)) /
                                 u;
    return s * consider_factor;
  }

  void AddReading(std::size_t o) {
    const Observation& obs = observations[o];
    j_local[o] = ReadingJacobian(obs, e.data() + 3 * o);
    const Eigen::MatrixXd& j = j_local[o];
    // Consider columns: W d y / d s_c at the solution's shared values (N-6).
    Eigen::Vector3d y;
    Eigen::Matrix3d dy_dr;
    Eigen::MatrixXd dy_ds;
    EvaluateReading(instruments, obs, s_hat, y, dy_dr, dy_ds);
    b_consider[o].resize(3, C);
    for (int c = 0; c < C; ++c) b_consider[o].col(c) = obs.whitening * dy_ds.col(split.consider[c]);
    // Scatter into the normal matrix.
    const std::vector<int> index = LocalIndex(obs);
    const int local = static_cast<int>(index.size());
    const Eigen::MatrixXd jtj = j.transpose() * j;
    const Eigen::MatrixXd jtb = j.transpose() * b_consider[o];
    for (int r = 0; r < local; ++r) {
      if (index[r] < 0) continue;
      // No consider parameters (C = 0): g and jtb have no columns and no storage to offset into.
      if (C > 0) g.row(index[r]) += jtb.row(r);
      for (int c = 0; c < local; ++c) {
        if (index[c] < 0) continue;
        if (index[r] < a && index[c] < a)
          n_aa(index[r], index[c]) += jtj(r, c);
        else if (index[r] < a)
          n_at(index[r], index[c] - a) += jtj(r, c);
        else if (index[c] >= a)
          TargetBlock(obs.target, obs.target)(index[r] - a - 3 * obs.target, index[c] - a - 3 * obs.target) +=
              jtj(r, c);
      }
    }
  }

  void AddPrior(const Prior& prior) {
    const Eigen::MatrixXd& w = prior.cost->whitening();
    const int width = static_cast<int>(w.cols());
    const Eigen::Map<const Eigen::VectorXd> v(prior.block, width);
    chi2 += (w * (v - prior.cost->v0())).squaredNorm();
    const Eigen::MatrixXd wtw = w.transpose() * w;
    for (int r = 0; r < width; ++r) {
      for (int c = 0; c < width; ++c) {
        const int gr = prior.offset + r, gc = prior.offset + c;
        if (gr < a && gc < a)
          n_aa(gr, gc) += wtw(r, c);
        else if (gr >= a && gc >= a)
          TargetBlock((gr - a) / 3, (gc - a) / 3)((gr - a) % 3, (gc - a) % 3) += wtw(r, c);
      }
    }
  }

  // --- Inverse by the Schur complement of the targets (N-5).
  void InvertBySchurComplement() {
    const int G = static_cast<int>(groups.members.size());
    n_gg_inv.resize(G);
    for (int group = 0; group < G; ++group) {
      Eigen::LLT<Eigen::MatrixXd> llt(n_gg[group]);
      if (llt.info() != Eigen::Success) {
        throw NumericalError(file + ": target '" + readings.target_names[groups.members[group][0]] +
                             "' is not determined");
      }
      n_gg_inv[group] = llt.solve(Eigen::MatrixXd::Identity(n_gg[group].rows(), n_gg[group].cols()));
    }
    h.resize(3 * T, a);  // N_tt^-1 N_ta, group by group
    // With no station or shared input unknown (a = 0) h has no columns and no storage: a block of it
    // would offset a null pointer (undefined behaviour, Clang's UBSan), and there is nothing to fill.
    if (a > 0) {
      for (int group = 0; group < G; ++group) {
        const std::vector<int>& members = groups.members[group];
        const int m = static_cast<int>(members.size());
        Eigen::MatrixXd n_ga(3 * m, a);
        for (int i = 0; i < m; ++i)
          n_ga.middleRows<3>(3 * i) = n_at.middleCols<3>(3 * members[i]).transpose();
        const Eigen::MatrixXd h_g = n_gg_inv[group] * n_ga;
        for (int i = 0; i < m; ++i) h.middleRows<3>(3 * members[i]) = h_g.middleRows<3>(3 * i);
      }
    }
    schur = n_aa - n_at * h;
    c_aa.resize(a, a);
    if (a > 0) {
      // Scale to unit diagonal before judging the rank: poses mix radians and metres.
      const Eigen::VectorXd scale =
          schur.diagonal().cwiseMax(std::numeric_limits<double>::min()).cwiseSqrt().cwiseInverse();
      const Eigen::MatrixXd scaled = scale.asDiagonal() * schur * scale.asDiagonal();
      Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(scaled);
      if (!(eig.eigenvalues()(0) > 1e-10 * eig.eigenvalues()(a - 1)))
        ThrowUndetermined(eig.eigenvectors().col(0));
      c_aa = scale.asDiagonal() * eig.eigenvectors() * eig.eigenvalues().cwiseInverse().asDiagonal() *
             eig.eigenvectors().transpose() * scale.asDiagonal();
    }
  }

  // The weakest direction names the station that floats.
  [[noreturn]] void ThrowUndetermined(const Eigen::VectorXd& v) const {
    Eigen::Index worst = 0;
    v.cwiseAbs().maxCoeff(&worst);
    std::string what = "the self-calibrated inputs";
    for (int i = 0; i < P; ++i) {
      if (pose_offset[i] >= 0 && worst >= pose_offset[i] && worst < pose_offset[i] + 6)
        what = "station '" + network.stations[i].name + "'";
    }
    for (int g = 0; g < segments.count(); ++g) {  // a drifting station floats with its knots' poses
      if (worst >= knot_offset[g] && worst < knot_offset[g] + 6)
        what = "station '" + network.stations[segments.station[g]].name + "'";
    }
    throw InputError(file + ": datum: the network does not determine " + what +
                     " (collinear references or common targets, or a datum that leaves a rotation free)");
  }

  // Identifiability of the self-calibrated inputs (N-9), as `vlt calibrate` reports it: the
  // information the data alone give on s_E (readings, references, pose priors — not its own
  // prior), the targets and poses eliminated, in prior-scaled coordinates z = L^-1 (s_E - s0_E):
  // M = S_EE - S_EP S_PP^-1 S_PE - Sigma_E^-1, M_z = L^T M L = V diag(s^2) V^T. A combination
  // v_i is determined by the network with u(v_i^T z) = 1 / s_i (prior units).
  std::vector<NetworkCombination> Identifiability() const {
    std::vector<NetworkCombination> identifiability;
    const Eigen::MatrixXd w =
        prior_factor.triangularView<Eigen::Lower>().solve(Eigen::MatrixXd::Identity(E, E));
    Eigen::MatrixXd m = schur.block(e_offset, e_offset, E, E) - w.transpose() * w;
    if (e_offset > 0) {
      const Eigen::MatrixXd s_pe = schur.block(0, e_offset, e_offset, E);
      m -= s_pe.transpose() * schur.topLeftCorner(e_offset, e_offset).ldlt().solve(s_pe);
    }
    const Eigen::MatrixXd m_z = prior_factor.transpose() * m * prior_factor;
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(0.5 * (m_z + m_z.transpose()));
    const double s_max = std::sqrt(std::max(0.0, eig.eigenvalues()(E - 1)));
    for (int i = E - 1; i >= 0; --i) {
      NetworkCombination c;
      c.singular_value = std::sqrt(std::max(0.0, eig.eigenvalues()(i)));
      const bool blind = !(c.singular_value > 1e-9 * s_max) || c.singular_value == 0.0;
      c.ratio = blind ? std::numeric_limits<double>::infinity() : 1.0 / c.singular_value;
      c.determined = c.ratio <= 1.0;
      c.description = DescribeCombination(eig.eigenvectors().col(i));
      identifiability.push_back(std::move(c));
    }
    return identifiability;
  }

  // In each input's prior u: the shift of s_E per unit of the combination, D^-1 L v.
  std::string DescribeCombination(const Eigen::VectorXd& v) const {
    std::string description;
    Eigen::VectorXd coefficients = prior_factor * v;
    for (int k = 0; k < E; ++k)
      coefficients(k) /= std::sqrt(sigma_shared(split.estimated[k], split.estimated[k]));
    Eigen::Index big = 0;
    const double largest = coefficients.cwiseAbs().maxCoeff(&big);
    if (coefficients(big) < 0.0) coefficients = -coefficients;
    for (int k = 0; k < E; ++k) {
      if (std::abs(coefficients(k)) < 0.05 * largest) continue;
      char term[96];
      std::snprintf(term, sizeof term, "%s%+.3f %s", description.empty() ? "" : " ",
                    coefficients(k) / largest, instruments.names[split.estimated[k]].c_str());
      description += term;
    }
    return description;
  }

  void Covariance() {
    target_start = e_offset;  // after the poses
    e_start = e_offset + 3 * T;
    cov_internal.resize(n, n);  // internal order [poses | s_E | targets]
    cov_internal.topLeftCorner(a, a) = c_aa;
    c_ta = -h * c_aa;
    cov_internal.bottomLeftCorner(3 * T, a) = c_ta;
    cov_internal.topRightCorner(a, 3 * T) = c_ta.transpose();
    // A trial needs the target blocks within a group only (network/adjust.h): h_i C_aa h_j^T there.
    if (trial)
      cov_internal.bottomRightCorner(3 * T, 3 * T).setZero();
    else
      cov_internal.bottomRightCorner(3 * T, 3 * T) = h * c_aa * h.transpose();
    for (std::size_t group = 0; group < groups.members.size(); ++group) {
      const std::vector<int>& members = groups.members[group];
      for (std::size_t i = 0; i < members.size(); ++i) {
        for (std::size_t j = 0; j < members.size(); ++j) {
          auto block = cov_internal.block<3, 3>(a + 3 * members[i], a + 3 * members[j]);
          block += n_gg_inv[group].block<3, 3>(3 * static_cast<int>(i), 3 * static_cast<int>(j));
          if (trial && a > 0)
            block -= c_ta.middleRows<3>(3 * members[i]) * h.middleRows<3>(3 * members[j]).transpose();
        }
      }
    }
    // Consider parameters: K = -N^-1 J^T B_c moves the estimate by K delta_c (N-7).
    const Eigen::MatrixXd gain =
        trial ? Eigen::MatrixXd(-SolveNormals(g)) : Eigen::MatrixXd(-cov_internal * g);
    Eigen::MatrixXd sigma_c(C, C);
    for (int p = 0; p < C; ++p)
      for (int q = 0; q < C; ++q) sigma_c(p, q) = sigma_shared(split.consider[p], split.consider[q]);
    if (C > 0) consider_part = gain * sigma_c * gain.transpose();
    consider_gain = gain;
    ConsiderAsRandomEffects(sigma_c);
    // The result's order [poses | targets | s_E] from the internal [poses | s_E | targets], block by
    // block.
    const int in_start[3] = {0, a, e_offset}, out_start[3] = {0, target_start, e_start},
              length[3] = {e_offset, 3 * T, E};
    result.covariance.resize(n, n);
    for (int p = 0; p < 3; ++p) {
      for (int q = 0; q < 3; ++q) {
        if (length[p] == 0 || length[q] == 0) continue;
        auto out = result.covariance.block(out_start[p], out_start[q], length[p], length[q]);
        out = cov_internal.block(in_start[p], in_start[q], length[p], length[q]);
        if (C > 0) out += consider_part.block(in_start[p], in_start[q], length[p], length[q]);
      }
    }
  }

  // N^-1 b by the Schur complement (N-5), for a trial's consider gain without the full inverse:
  // y_a = C_aa (b_a - h^T b_t), y_t = N_tt^-1 b_t - h y_a.
  Eigen::MatrixXd SolveNormals(const Eigen::MatrixXd& b) const {
    const int m = static_cast<int>(b.cols());
    Eigen::MatrixXd y(n, m);
    // No consider input (C = 0): b has no storage, and a block of it would offset a null pointer.
    if (m == 0) return y;
    const Eigen::MatrixXd b_t = b.bottomRows(3 * T);
    Eigen::MatrixXd y_t(3 * T, m);
    for (std::size_t group = 0; group < groups.members.size(); ++group) {
      const std::vector<int>& members = groups.members[group];
      const int size = 3 * static_cast<int>(members.size());
      Eigen::MatrixXd b_g(size, m);
      for (int i = 0; i < size / 3; ++i) b_g.middleRows<3>(3 * i) = b_t.middleRows<3>(3 * members[i]);
      const Eigen::MatrixXd y_g = n_gg_inv[group] * b_g;
      for (int i = 0; i < size / 3; ++i) y_t.middleRows<3>(3 * members[i]) = y_g.middleRows<3>(3 * i);
    }
    if (a > 0) {
      const Eigen::MatrixXd y_a = c_aa * (b.topRows(a) - h.transpose() * b_t);
      y.topRows(a) = y_a;
      y_t -= h * y_a;
    }
    y.bottomRows(3 * T) = y_t;
    return y;
  }

  void NameUnknowns() {
    result.unknown_names.assign(n, "");
    result.station_offset = pose_offset;
    for (int i = 0; i < P; ++i) {
      if (pose_offset[i] < 0) continue;
      for (int c = 0; c < 6; ++c)
        result.unknown_names[pose_offset[i] + c] = network.stations[i].name + "." + kPoseNames[c];
    }
    for (int g = 0; g < segments.count(); ++g) {
      const int i = segments.station[g];
      const std::string at = network.stations[i].name + ".knot" + std::to_string(g - segments.first[i] + 1);
      for (int c = 0; c < 6; ++c) result.unknown_names[knot_offset[g] + c] = at + "." + kPoseNames[c];
    }
    static const char* kAxis[3] = {"x", "y", "z"};
    for (int t = 0; t < T; ++t) {
      result.target_offset.push_back(target_start + 3 * t);
      for (int c = 0; c < 3; ++c)
        result.unknown_names[target_start + 3 * t + c] = readings.target_names[t] + "." + kAxis[c];
    }
    for (int k = 0; k < E; ++k) result.unknown_names[e_start + k] = instruments.names[split.estimated[k]];
  }

  void Targets() {
    double trace_noise = 0.0, trace_consider = 0.0;
    for (int t = 0; t < T; ++t) {
      AdjustedTarget at;
      at.name = readings.target_names[t];
      at.position = x[t];
      at.covariance = result.covariance.block<3, 3>(target_start + 3 * t, target_start + 3 * t);
      at.stations = static_cast<int>(readings.target_stations[t].size());
      at.readings = readings.target_readings[t];
      at.reference = reference_names.count(at.name) > 0;
      trace_noise += cov_internal.block<3, 3>(a + 3 * t, a + 3 * t).trace();
      if (C > 0) trace_consider += consider_part.block<3, 3>(a + 3 * t, a + 3 * t).trace();
      if (!at.position.allFinite() || !at.covariance.allFinite())
        throw NumericalError(file + ": target '" + at.name + "' came out non-finite");
      result.targets.push_back(at);
    }
    const double total = trace_noise + trace_consider;
    result.share_noise = total > 0.0 ? trace_noise / total : 0.0;
    result.share_consider = total > 0.0 ? trace_consider / total : 0.0;
  }

  void Stations() {
    for (int i = 0; i < P; ++i) {
      AdjustedStation as;
      as.name = network.stations[i].name;
      as.pose = pose[i];
      as.datum = network.stations[i].datum;
      as.readings = static_cast<int>(by_station[i].size());
      if (pose_offset[i] >= 0) as.covariance = result.covariance.block<6, 6>(pose_offset[i], pose_offset[i]);
      if (segments.first[i] >= 0) as.drift = DriftEpochs(i);
      for (const AdjustedDriftEpoch& e : as.drift) {
        if (!e.offset.allFinite() || !e.covariance.allFinite())
          throw NumericalError(file + ": the drift of station '" + as.name + "' came out non-finite");
      }
      result.stations.push_back(as);
    }
  }

  // Station i's pose change at each knot since t_0, P_k - P_0, and its covariance (result order:
  // the knots' poses sit where NumberUnknowns put them, before the targets; a held P_0 has none).
  std::vector<AdjustedDriftEpoch> DriftEpochs(int i) const {
    const NetworkDrift& drift = network.stations[i].drift;
    std::vector<AdjustedDriftEpoch> epochs(drift.knots.size());
    const int o0 = pose_offset[i];
    for (std::size_t k = 0; k < epochs.size(); ++k) {
      epochs[k].time = drift.knots[k];
      if (k == 0) continue;
      const int g = segments.first[i] + static_cast<int>(k) - 1, ok = knot_offset[g];
      epochs[k].offset = knot[g] - pose[i];
      Eigen::Matrix<double, 6, 6> c = result.covariance.block<6, 6>(ok, ok);
      if (o0 >= 0) {
        c += result.covariance.block<6, 6>(o0, o0) - result.covariance.block<6, 6>(ok, o0) -
             result.covariance.block<6, 6>(o0, ok);
      }
      epochs[k].covariance = 0.5 * (c + c.transpose());
    }
    return epochs;
  }

  void SelfCalibratedParameters() {
    for (int k = 0; k < E; ++k) {
      const int s = split.estimated[k];
      const UncertainInput& in = instruments.stacked[s];
      CalibratedParameter cp;
      cp.name = instruments.names[s];
      cp.unit = in.unit;
      cp.prior_estimate = in.estimate;
      cp.prior_u = in.u;
      cp.estimate = s_est(k);
      cp.u = std::sqrt(std::max(0.0, result.covariance(e_start + k, e_start + k)));
      cp.u_data = cp.u;
      cp.status = ParameterStatus::kIdentified;
      cp.quantity = instruments.quantities[s];
      result.parameters.push_back(cp);
    }
  }

  // --- Residuals: redundancy numbers r_ii = 1 - (J N^-1 J^T)_ii and data snooping (N-8).
  void Residuals() {
    int observations_count = static_cast<int>(e.size() + e_distance.size());
    for (const Prior& prior : priors) observations_count += static_cast<int>(prior.cost->whitening().rows());
    observations_count += 6 * static_cast<int>(drift_priors.size());
    result.observations = observations_count;
    result.unknowns = n;
    result.dof = observations_count - n;
    result.chi2 = chi2;
    result.chi2_random_effects = chi2_random_effects;
    result.p_value_random_effects = ChiSquareUpperTail(chi2_random_effects, result.dof);
    result.birge_ratio = result.dof > 0 ? std::sqrt(chi2 / result.dof) : 0.0;
    result.p_value = ChiSquareUpperTail(chi2, result.dof);
    for (std::size_t o = 0; o < observations.size(); ++o) ReadingResiduals(o);
    for (std::size_t k = 0; k < distances.size(); ++k) DistanceResidual(k);
  }

  // The gradient of |x_to - x_from| over [from, to] at the solution, and the 6 x 6 block of a
  // covariance (internal order, or the result's) over the two targets.
  Eigen::Matrix<double, 6, 1> DistanceGradient(const DistanceObservation& d) const {
    const Eigen::Vector3d v = x[d.to] - x[d.from];
    const Eigen::Vector3d unit = v.norm() > 0.0 ? Eigen::Vector3d(v / v.norm()) : Eigen::Vector3d::Zero();
    Eigen::Matrix<double, 6, 1> grad;
    grad << -unit, unit;
    return grad;
  }
  static Eigen::Matrix<double, 6, 6> PairBlock(const Eigen::MatrixXd& c, int from, int to) {
    Eigen::Matrix<double, 6, 6> block;
    const int at[2] = {from, to};
    for (int i = 0; i < 2; ++i)
      for (int j = 0; j < 2; ++j) block.block<3, 3>(3 * i, 3 * j) = c.block<3, 3>(at[i], at[j]);
    return block;
  }

  // A distance at the solution (N-8): its redundancy from the noise part of the covariance (as a
  // reading's), the adjusted length's u from the full covariance (consider parameters included).
  void DistanceResidual(std::size_t k) {
    const DistanceObservation& d = distances[k];
    const NetworkDistance& source = network.distances[d.index];
    const Eigen::Matrix<double, 6, 1> grad = DistanceGradient(d);
    const double hat = grad.dot(PairBlock(cov_internal, a + 3 * d.from, a + 3 * d.to) * grad) / (d.u * d.u);
    AdjustedDistance out;
    out.name = source.name;
    out.from = source.from;
    out.to = source.to;
    out.where = source.where;
    out.scale_bar = source.scale_bar;
    out.observed = d.length;
    out.u_observed = d.u;
    out.adjusted = (x[d.to] - x[d.from]).norm();
    out.u_adjusted = std::sqrt(std::max(
        0.0,
        grad.dot(PairBlock(result.covariance, target_start + 3 * d.from, target_start + 3 * d.to) * grad)));
    out.normalised = -e_distance(static_cast<Eigen::Index>(k));
    out.redundancy = std::clamp(1.0 - hat, 0.0, 1.0);
    // The w test with the consider inputs as random effects (N-8), in the sign of `normalised`.
    double e_test = out.normalised, r_test = out.redundancy;
    if (C > 0) {
      const Eigen::RowVectorXd sl = DistanceEffects(d, grad, d.u);
      e_test -= sl.dot(effects);
      r_test -= sl.dot(effects_inverse * sl.transpose());
    }
    out.w = r_test > 1e-9 ? e_test / std::sqrt(r_test) : 0.0;
    out.outlier = std::abs(out.w) > network.outlier_limit;
    result.outliers += out.outlier ? 1 : 0;
    result.distances.push_back(std::move(out));
  }

  // --- The w of an observation this adjustment does not contain (one the robust rule removed,
  // N-8a): its residual at the solution over sqrt(1 + J N^-1 J^T), the variance of an
  // observation's misfit to an estimate it did not take part in. The largest |w| of its
  // components; false when its target is not in the network any more.
  bool PredictReadingW(int station, const TargetReading& reading, RejectedObservation& out) const {
    static const char* kReading[3] = {"range", "azimuth", "elevation"};
    const auto it = readings.target_index.find(reading.target);
    if (it == readings.target_index.end()) return false;
    Observation obs = PrepareObservation(instruments, reading, instruments.ReadingModel(station, reading),
                                         station, 0, it->second);
    obs.poses = ReadingPoses(network, segments, station, reading);
    Eigen::Vector3d residual;
    const Eigen::MatrixXd j = ReadingJacobian(obs, residual.data());
    const Eigen::Matrix3d hat = ReadingHat(obs, j);
    Eigen::Vector3d y;
    Eigen::Matrix3d dy_dr;
    Eigen::MatrixXd dy_ds;
    EvaluateReading(instruments, obs, s_hat, y, dy_dr, dy_ds);
    Eigen::Matrix<double, 3, Eigen::Dynamic> b(3, C);
    for (int c = 0; c < C; ++c) b.col(c) = obs.whitening * dy_ds.col(split.consider[c]);
    // Its misfit to the estimate with the consider inputs as random effects (N-8): the residual
    // moves by S L z_hat, its variance grows by S L M^-1 L^T S^T.
    Eigen::Vector3d variance = Eigen::Vector3d::Ones() + hat.diagonal().cwiseMax(0.0);
    if (C > 0) {
      const Eigen::MatrixXd sl = ReadingEffects(obs, j, b);
      residual += sl * effects;
      variance += (sl * effects_inverse * sl.transpose()).diagonal();
    }
    out.w_after = 0.0;
    for (int c = 0; c < 3; ++c) {
      const double w = residual(c) / std::sqrt(variance(c));
      if (std::abs(w) >= std::abs(out.w_after)) {
        out.w_after = w;
        out.component = kReading[c];
      }
    }
    return true;
  }

  bool PredictDistanceW(const NetworkDistance& distance, RejectedObservation& out) const {
    const auto from = readings.target_index.find(distance.from), to = readings.target_index.find(distance.to);
    if (from == readings.target_index.end() || to == readings.target_index.end()) return false;
    DistanceObservation d;
    d.from = from->second;
    d.to = to->second;
    const Eigen::Matrix<double, 6, 1> grad = DistanceGradient(d);
    const double hat =
        grad.dot(PairBlock(cov_internal, a + 3 * d.from, a + 3 * d.to) * grad) / (distance.u * distance.u);
    double residual = (distance.length - (x[d.to] - x[d.from]).norm()) / distance.u,
           variance = 1.0 + std::max(0.0, hat);
    if (C > 0) {
      const Eigen::RowVectorXd sl = DistanceEffects(d, grad, distance.u);
      residual -= sl.dot(effects);
      variance += sl.dot(effects_inverse * sl.transpose());
    }
    out.w_after = residual / std::sqrt(variance);
    out.component = "length";
    return true;
  }

  void ReadingResiduals(std::size_t o) {
    static const char* kReading[3] = {"range", "azimuth", "elevation"};
    const Observation& obs = observations[o];
    const Eigen::Matrix3d hat = ReadingHat(obs, j_local[o]);
    // The w test's residual and redundancy, with the consider inputs as random effects (N-8).
    Eigen::Vector3d e_test = e.segment<3>(3 * static_cast<Eigen::Index>(o));
    Eigen::Vector3d r_test = (Eigen::Vector3d::Ones() - hat.diagonal()).cwiseMax(0.0).cwiseMin(1.0);
    if (C > 0) {
      const Eigen::MatrixXd sl = ReadingEffects(obs, j_local[o], b_consider[o]);
      e_test += sl * effects;
      r_test -= (sl * effects_inverse * sl.transpose()).diagonal();
    }
    const TargetReading& src = network.stations[obs.station].readings[obs.reading];
    for (int c = 0; c < 3; ++c) {
      NetworkResidual res;
      res.station = network.stations[obs.station].name;
      res.target = readings.target_names[obs.target];
      res.component = kReading[c];
      res.face = src.face;
      res.where = src.where;
      res.unit = c == 0 ? "m" : "rad";
      res.u = obs.sigma(c);
      res.normalised = e(3 * o + c);
      res.residual = res.normalised * res.u;
      res.redundancy = std::clamp(1.0 - hat(c, c), 0.0, 1.0);
      res.w = r_test(c) > 1e-9 ? e_test(c) / std::sqrt(r_test(c)) : 0.0;
      res.outlier = std::abs(res.w) > network.outlier_limit;
      result.outliers += res.outlier ? 1 : 0;
      result.residuals.push_back(std::move(res));
    }
  }
};

}  // namespace

namespace {

// One adjustment of `network` from its readings to its residuals. The network is owned with it:
// the adjustment refers to it.
struct Solved {
  std::unique_ptr<Network> network;
  std::unique_ptr<Adjustment> adjustment;
};

Solved AdjustOnce(Network network, bool trial) {
  Solved solved;
  solved.network = std::make_unique<Network>(std::move(network));
  solved.adjustment = std::make_unique<Adjustment>(*solved.network, trial);
  Adjustment& adjustment = *solved.adjustment;
  adjustment.FindStartingValues();
  adjustment.NumberUnknowns();
  adjustment.Solve();
  adjustment.AssembleNormals();
  adjustment.InvertBySchurComplement();
  std::vector<NetworkCombination> identifiability;
  if (adjustment.E > 0 && !trial) identifiability = adjustment.Identifiability();
  adjustment.Covariance();
  adjustment.NameUnknowns();
  NetworkResult& result = adjustment.result;
  result.identifiability = std::move(identifiability);
  result.k = NormalCoverageFactor(solved.network->coverage_probability);
  adjustment.Targets();
  adjustment.Stations();
  adjustment.SelfCalibratedParameters();
  adjustment.Residuals();
  return solved;
}

// The observation with the largest |w| of an adjustment: a reading (its largest component) or a
// distance.
struct Suspect {
  double w = 0.0;
  bool distance = false;
  int index = -1;  // the observation (reading) or the distance
  std::string component;
};

Suspect LargestW(const Adjustment& adjustment) {
  Suspect worst;
  const NetworkResult& result = adjustment.result;
  for (std::size_t i = 0; i < result.residuals.size(); ++i) {
    if (std::abs(result.residuals[i].w) <= std::abs(worst.w)) continue;
    worst = {result.residuals[i].w, false, static_cast<int>(i / 3), result.residuals[i].component};
  }
  for (std::size_t k = 0; k < result.distances.size(); ++k) {
    if (std::abs(result.distances[k].w) <= std::abs(worst.w)) continue;
    worst = {result.distances[k].w, true, static_cast<int>(k), "length"};
  }
  return worst;
}

// The rejection limit (N-8a): w is N(0, 1) for a good observation (N-8); over the n values
// tested, z_(1 - alpha / (2 n)) keeps the probability of removing any good one of a network without
// gross errors at or below alpha (Bonferroni). Never below the flagging limit.
double RejectionLimit(const NetworkResult& result, const Network& network) {
  const double tested = static_cast<double>(result.residuals.size() + result.distances.size());
  return std::max(network.outlier_limit,
                  NormalCoverageFactor(1.0 - network.robust_alpha / std::max(1.0, tested)));
}

// The fit test of the final adjustment (FitProblem, vlt/gum.h) as a warning of the result.
void AddFitProblem(NetworkResult& result) {
  double largest_w = 0.0;
  for (const NetworkResidual& r : result.residuals) largest_w = std::max(largest_w, std::abs(r.w));
  for (const AdjustedDistance& d : result.distances) largest_w = std::max(largest_w, std::abs(d.w));
  // chi^2 with the consider inputs as random effects (N-8): their stated errors are no misfit.
  const std::string problem = FitProblem(result.chi2_random_effects, result.dof, largest_w,
                                         static_cast<int>(result.residuals.size() + result.distances.size()));
  if (!problem.empty()) {
    result.warnings.push_back(
        problem + (result.parameters.empty() ? " (the instruments' real errors? self-calibrate)" : ""));
  }
}

std::string FormatW(double w) {
  char text[32];
  std::snprintf(text, sizeof text, "%.2f", std::abs(w));
  return text;
}

// `network` without the suspect (a copy), and the record of what was removed.
Network WithoutSuspect(const Network& network, const Adjustment& adjustment, const Suspect& suspect,
                       RejectedObservation& rejected, std::pair<int, TargetReading>& reading,
                       NetworkDistance& distance) {
  Network reduced = network;
  rejected.w_before = suspect.w;
  rejected.component = suspect.component;
  if (suspect.distance) {
    const int k = adjustment.distances[suspect.index].index;
    distance = network.distances[k];
    rejected.distance = true;
    rejected.target = distance.name;
    rejected.where = distance.where;
    reduced.distances.erase(reduced.distances.begin() + k);
  } else {
    const Observation& obs = adjustment.observations[suspect.index];
    const TargetReading& source = network.stations[obs.station].readings[obs.reading];
    reading = {obs.station, source};
    rejected.station = network.stations[obs.station].name;
    rejected.target = source.target;
    rejected.face = source.face;
    rejected.where = source.where;
    std::vector<TargetReading>& kept = reduced.stations[obs.station].readings;
    kept.erase(kept.begin() + obs.reading);
  }
  return reduced;
}

// Iterative data snooping (Baarda 1968; Teunissen, Testing theory, 2006, ch. 4; docs/network.md
// N-8a): adjust, remove the observation with the largest |w| above the rejection limit, re-adjust,
// until none exceeds it. At most a fifth of the observations go, and never one whose removal leaves
// the network undetermined: beyond that the data need a look, not a rule.
NetworkResult AdjustRobustly(const Network& network, bool trial) {
  if (network.stations.empty()) throw InputError(network.where + ": station: the network has no station");
  Solved solved = AdjustOnce(network, trial);
  if (!network.robust) {
    AddFitProblem(solved.adjustment->result);
    return std::move(solved.adjustment->result);
  }
  const double limit = RejectionLimit(solved.adjustment->result, network);
  const std::size_t observations =
      solved.adjustment->observations.size() + solved.adjustment->distances.size();
  std::vector<RejectedObservation> rejected;
  std::vector<std::pair<int, TargetReading>> rejected_readings;  // (station, reading); distance: -1
  std::vector<NetworkDistance> rejected_distances;
  std::vector<std::string> warnings;
  for (;;) {
    const Suspect suspect = LargestW(*solved.adjustment);
    if (!(std::abs(suspect.w) > limit)) break;
    if (5 * (rejected.size() + 1) > observations) {
      warnings.push_back("the robust adjustment stopped after removing " + std::to_string(rejected.size()) +
                         " observations (a fifth of them): |w| = " + FormatW(suspect.w) +
                         " remains; look at the data and the instrument model");
      break;
    }
    RejectedObservation record;
    std::pair<int, TargetReading> reading{-1, {}};
    NetworkDistance distance;
    Network reduced = WithoutSuspect(*solved.network, *solved.adjustment, suspect, record, reading, distance);
    try {
      solved = AdjustOnce(std::move(reduced), trial);
    } catch (const std::runtime_error&) {  // InputError, NumericalError: the structure broke
      warnings.push_back(record.where + ": |w| = " + FormatW(suspect.w) +
                         " above the rejection limit, kept: without it the network is not determined");
      break;
    }
    rejected.push_back(std::move(record));
    rejected_readings.push_back(std::move(reading));
    rejected_distances.push_back(std::move(distance));
  }
  NetworkResult result = std::move(solved.adjustment->result);
  AddFitProblem(result);
  for (std::size_t r = 0; r < rejected.size() && !trial; ++r) {
    rejected[r].predicted = rejected[r].distance
                                ? solved.adjustment->PredictDistanceW(rejected_distances[r], rejected[r])
                                : solved.adjustment->PredictReadingW(
                                      rejected_readings[r].first, rejected_readings[r].second, rejected[r]);
  }
  result.rejected = std::move(rejected);
  result.rejection_limit = limit;
  for (std::string& w : warnings) result.warnings.push_back(std::move(w));
  return result;
}

}  // namespace

NetworkResult AdjustNetwork(const Network& network) { return AdjustRobustly(network, false); }

NetworkResult network_internal::AdjustNetworkTrial(const Network& network) {
  return AdjustRobustly(network, true);
}

}  // namespace vlt
