// vlt/network.h — several tracker stations tied together by common targets: the bundle
// adjustment of the station poses and the target coordinates, weighted by each reading's
// uncertainty from the instrument model, with the instrument's error parameters either carried
// as consider parameters (their uncertainty propagated, correlated over every reading) or
// estimated from the network itself (self-calibration). docs/network.md has the equations.
//
// Frames (docs/conventions.md): every station has its own tracker frame; the part frame is the
// network's. A station's pose maps its frame into the part frame, exactly as a job's [station]:
//     x_part = R x_station + t,   R = Rz(rz) Ry(ry) Rx(rx).
// The part frame is fixed by a datum: a station held exactly at its given pose, and/or reference
// targets with known part-frame coordinates and standard uncertainties.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <optional>

#include <Eigen/Core>

#include "vlt/calibration.h"
#include "vlt/conformity.h"
#include "vlt/job.h"
#include "vlt/job_record.h"
#include "vlt/measurement_model.h"
#include "vlt/tasks.h"
#include "vlt/units.h"

namespace vlt {

// Pose of a station: (rx, ry, rz) [rad], (tx, ty, tz) [m], in that order everywhere.
using StationPoseVector = Eigen::Matrix<double, 6, 1>;
inline constexpr std::array<const char*, 6> kPoseNames = {"rx", "ry", "rz", "tx", "ty", "tz"};

// R of a pose: PoseRotationMatrix / PoseRotationDerivatives (vlt/measurement_model.h).

// One instrument: a tracker with its error parameters (estimates = its compensation state, u,
// correlation, or a calibration file), reading noise and air. Its shared inputs (MeasurementModel
// order, without pose or thermal) are common to every station it occupies.
struct NetworkInstrument {
  std::string name;  // "tracker" for the single [tracker] of a file
  MeasurementSetup setup;
};

// A station's drift (docs/network.md N-12): the station moves during its readings (floor, tripod,
// temperature), so its pose is a function of time, piecewise linear between knots t_0 < ... < t_K
// (the first reading, each drift check, the last reading):
//     pose(t) = pose + sum_k b_k(t) D_k,   b_k(t) = clamp((t - t_k) / (t_{k+1} - t_k), 0, 1),
// `pose` the pose at t_0 and D_k the pose change over segment k. The adjustment's unknowns are the
// poses at the knots P_k = pose + sum_{j<k} D_j (a reading combines the two around its time), with
// the prior D_k = P_{k+1} - P_k ~ N(0, (rate Delta t_k)^2) per component: the segment's rate of
// drift is unknown, zero on average, with the stated standard uncertainty. A reading's time is
// then needed (TargetReading::time).
struct NetworkDrift {
  bool enabled = false;
  double translation_rate = 0.0;  // u of each segment's rate of tx, ty, tz [m/s], > 0
  double rotation_rate = 0.0;     // u of each segment's rate of rx, ry, rz [rad/s], > 0
  std::vector<double> knots;      // t_0 < t_1 < ... [s], at least 2
  // The true D_k of a simulation (SimulateNetwork; one per segment); empty: drawn from the prior.
  std::vector<StationPoseVector> increments;
  std::string where;  // "<file>: station[i].drift"
};

// The pose of `drift`'s station at time t: pose + sum_k b_k(t) increments_k (zero increments when
// none are given).
StationPoseVector DriftedPose(const StationPoseVector& pose, const NetworkDrift& drift, double t);

// Air that changes while a station reads (docs/network.md N-2a): from `from` on, the station's
// readings take this air instead of the one before (the readings' times, TargetReading::time), as a
// tracker applies its weather station's latest values to every reading it takes. Its inputs are
// the station's "<station>.air<k>.environment.temperature", ... (k = 2, 3, ... in order of time).
struct NetworkAirChange {
  double from = 0.0;  // [s], the readings' origin (seconds since 1970 for dates)
  TimeKind from_kind = TimeKind::kSeconds;
  Environment environment;
  std::string sensor;  // the NetworkAirSensor that gave it, if any
  std::string where;
};

struct NetworkStation {
  std::string name;
  int instrument = 0;                                  // index into Network::instruments
  StationPoseVector pose = StationPoseVector::Zero();  // estimate (starting value, plan value)
  bool pose_given = false;  // false: computed from already placed targets (Umeyama)
  StationPoseVector pose_u = StationPoseVector::Zero();  // > 0: a prior on that component
  bool datum = false;                                    // held exactly at `pose`: defines the part frame
  std::vector<TargetReading> readings;                   // what the station read (raw readings, both faces)
  // The air at this station ([station.environment], docs/network.md N-2a): when given, its inputs are
  // the station's own ("<station>.environment.temperature", ...) instead of the instrument's, which
  // keeps its error parameters. `air_sensor` names the NetworkAirSensor that gave it, if any.
  std::optional<Environment> environment;
  std::string air_sensor;
  // Later airs, in order of time ([[station.environment]]); `environment` holds until the first.
  std::vector<NetworkAirChange> air_changes;
  NetworkDrift drift;  // [station.drift] (N-12); disabled: one pose for all its readings
  std::string where;   // "<file>: station[i]"
};

// An air sensor (a weather station) whose readings give the air of several stations (N-2a): the
// standard uncertainty of its calibration, common to every station it serves, so that two such
// stations' air inputs have covariance u_sensor^2 (the rest of each station's u is its own: the
// air along the beam against the air at the sensor, the time between them).
struct NetworkAirSensor {
  std::string name;
  double u_temperature = 0.0;  // [K]
  double u_pressure = 0.0;     // [Pa]
  double u_humidity = 0.0;     // relative humidity [%]
  std::string where;
};

// A target with known part-frame coordinates: a pseudo-observation of each coordinate.
struct NetworkReference {
  std::string target;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // [m]
  double u = 0.0;                                      // standard uncertainty of each coordinate [m], > 0
  std::string where;
};

// A measured length between two targets (docs/network.md N-4a): a scale bar (its calibrated length
// corrected for thermal expansion at its own temperature) or a distance measured otherwise (a laser
// interferometer, a calibrated baseline). An observation (|x_to - x_from| - length) / u: what gives
// the network its scale when no reference coordinates do (the range scale of every tracker is then
// determined by the bars).
struct NetworkDistance {
  std::string name;        // "SB1"
  bool scale_bar = false;  // [[scale_bar]] (else [[distance]])
  std::string from, to;    // target names
  double length = 0.0;     // at the conditions of the measurement [m] (a bar: thermally corrected)
  double u = 0.0;          // standard uncertainty of `length` [m], > 0, the thermal terms included
  // A scale bar: L = L_cal (1 + cte (T - T_ref)); u^2 = (1 + cte (T - T_ref))^2 u(L_cal)^2 +
  // (L_cal (T - T_ref))^2 u(cte)^2 + (L_cal cte)^2 u(T)^2 (GUM 5.1.2, the inputs independent).
  double calibrated_length = 0.0, u_calibrated_length = 0.0;  // [m]
  double cte = 0.0, u_cte = 0.0;                              // [1/K]
  double temperature = 20.0, u_temperature = 0.0;             // [degC], [K]
  double reference_temperature = 20.0;                        // [degC]
  std::string where;
};

struct Network {
  std::string where;  // the file, for messages
  std::string name;
  // The instruments (one moved from station to station, or several); at least one.
  std::vector<NetworkInstrument> instruments;
  std::vector<NetworkStation> stations;
  std::vector<NetworkReference> references;
  std::vector<NetworkDistance> distances;  // scale bars and measured distances
  std::vector<NetworkAirSensor> air_sensors;
  // Shared inputs (NetworkSharedInputNames) estimated from the network with their prior as a
  // pseudo-observation; every other shared input is a consider parameter.
  std::vector<std::string> self_calibrate;
  double coverage_probability = 0.95;
  double outlier_limit = 3.29;  // |w| above it flags a reading component (Baarda, alpha 0.001)
  int max_iterations = 100;
  // Robust adjustment by iterative data snooping (docs/network.md N-8a): while the largest |w| of
  // the readings and distances exceeds the rejection limit, the observation with it is removed and
  // the network re-adjusted. The limit keeps the probability of removing any good observation of a
  // network without gross errors at `robust_alpha` (Bonferroni over the w tested).
  bool robust = true;
  double robust_alpha = 0.01;
};

// The shared inputs of every instrument, in order: each instrument's MeasurementModel names
// ("lam", "environment.temperature"), prefixed "<instrument>." when the network has several; then
// the air of each station that has its own ("S2.environment.temperature", ...), each later air of a
// station whose air changes after its first ("S2.air2.environment.temperature", ...).
std::vector<std::string> NetworkSharedInputNames(const Network& network);

// A drifting station at one knot t_k of its drift model (N-12): its pose change since t_0,
// sum_{j<k} D_j, with its covariance (the full covariance of the D_j, consider parameters included).
struct AdjustedDriftEpoch {
  double time = 0.0;  // t_k [s] (the reading times' own origin, or seconds since 1970 for dates)
  StationPoseVector offset = StationPoseVector::Zero();
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();
};

struct AdjustedStation {
  std::string name;
  StationPoseVector pose = StationPoseVector::Zero();  // at t_0 for a drifting station
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();
  int readings = 0;
  bool datum = false;
  std::vector<AdjustedDriftEpoch> drift;  // a drifting station: every knot, the first with offset 0
};

struct AdjustedTarget {
  std::string name;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();    // part frame [m]
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // [m^2]
  int stations = 0;                                      // how many stations read it
  int readings = 0;
  bool reference = false;
};

// One reading component's residual at the solution, in the reading's own terms.
struct NetworkResidual {
  std::string station, target, component;  // component: "range", "azimuth", "elevation"
  Face face = Face::kFront;
  std::string where;
  std::string unit;         // "m" or "rad"
  double residual = 0.0;    // observed - adjusted reading
  double u = 0.0;           // its standard uncertainty (reading noise)
  double normalised = 0.0;  // residual / u
  double redundancy = 0.0;  // r_ii in [0, 1]
  double w = 0.0;           // normalised / sqrt(redundancy) (Baarda)
  bool outlier = false;
};

// A distance observation (scale bar, measured distance) at the solution.
struct AdjustedDistance {
  std::string name, from, to, where;
  bool scale_bar = false;
  double observed = 0.0, u_observed = 0.0;  // the observation [m] and its u
  double adjusted = 0.0, u_adjusted = 0.0;  // |x_to - x_from| of the adjusted targets [m], its u (full C)
  double normalised = 0.0;                  // (observed - adjusted) / u_observed
  double redundancy = 0.0;                  // r in [0, 1]
  double w = 0.0;                           // Baarda's w: normalised / sqrt(redundancy)
  bool outlier = false;
};

// An observation the robust adjustment removed (docs/network.md N-8a), in the order removed.
struct RejectedObservation {
  // A reading (station, target, face) or a distance (station "", target = its name).
  std::string station, target;
  Face face = Face::kFront;
  bool distance = false;
  std::string where;
  std::string component;  // the component with the largest |w| ("range", "azimuth", "elevation", "length")
  double w_before = 0.0;  // its w when it was removed (largest |w| of the network at that round)
  // Its w against the final adjustment, which no longer contains it: e / sqrt(1 + J N^-1 J^T) per
  // component (the largest |w|), the same statistic a kept observation has; NaN-free: 0 with
  // `predicted` false when its target left the network with it.
  double w_after = 0.0;
  bool predicted = false;
};

// A combination of self-calibrated inputs and how well the network alone determines it
// (docs/network.md N-9; the analysis of vlt/calibration.h): u(combination) = ratio x its prior u.
struct NetworkCombination {
  double singular_value = 0.0;  // of the data's information in prior-scaled coordinates
  double ratio = 0.0;           // 1 / singular_value: data-only u / prior u (inf: blind)
  bool determined = false;      // ratio <= 1: the network knows it better than the prior
  std::string description;      // "+1.000 lam -0.412 srr" (coefficients in each input's prior u)
};

struct NetworkResult {
  std::vector<AdjustedStation> stations;
  std::vector<AdjustedTarget> targets;              // sorted by first appearance
  std::vector<CalibratedParameter> parameters;      // the self-calibrated shared inputs
  std::vector<NetworkCombination> identifiability;  // self-calibration: best determined first
  // Full covariance of every unknown [m, rad, SI]: the free station poses (6 each, network
  // order, datum stations left out), the poses at the drift knots (6 each, N-12), then the targets
  // (3 each), then the self-calibrated inputs.
  std::vector<std::string> unknown_names;  // "S2.rx", "S2.knot1.tx", "T1.x", "tmv"
  Eigen::MatrixXd covariance;
  std::vector<int> station_offset;  // per station: first index in covariance, -1 datum
  std::vector<int> target_offset;   // per target
  std::vector<NetworkResidual> residuals;
  std::vector<AdjustedDistance> distances;    // scale bars and measured distances kept
  std::vector<RejectedObservation> rejected;  // removed by the robust adjustment
  double rejection_limit = 0.0;               // |w| above which it removes (0: not robust)
  std::vector<std::string> warnings;  // the fit test failed (FitProblem), the robust rule stopped early
  int observations = 0;               // scalar observations incl. reference coordinates and priors
  int unknowns = 0;
  int dof = 0;
  double chi2 = 0.0, birge_ratio = 0.0, p_value = 0.0;  // weighted by the reading noise alone
  // chi^2 and its p with the consider inputs as random effects (docs/network.md N-8): the fit test's.
  double chi2_random_effects = 0.0, p_value_random_effects = 0.0;
  int outliers = 0;
  int iterations = 0;
  double k = 0.0;  // coverage factor of the expanded values printed (normal)
  // Shares of the targets' variance (sum over targets of trace) from the reading noise and the
  // references (`noise`) and from the consider parameters (`consider`); they add up to 1.
  double share_noise = 0.0, share_consider = 0.0;
};

// The adjustment (docs/network.md): checks the network's structure (datum, connectivity, every
// station placed by >= 3 common targets), finds starting values, solves with Ceres
// (Levenberg-Marquardt, Schur elimination of the targets) and computes the full covariance.
// InputError (structure) naming the file and the station / reference; NumericalError otherwise.
NetworkResult AdjustNetwork(const Network& network);

// Offline: the readings each station would show of the targets it sees (nominal part-frame
// coordinates), at the instrument's estimates — the adjustment of them gives the predicted
// uncertainty of every target before anyone moves a tracker. `sees[i]` lists the targets of
// station i with their face.
struct PlannedSighting {
  std::string target;
  Face face = Face::kFront;
  std::string where;
};
void PlanNetworkReadings(Network& network,
                         const std::vector<std::pair<std::string, Eigen::Vector3d>>& nominal,
                         const std::vector<std::vector<PlannedSighting>>& sees);

// A simulated measurement of `network` (whose stations already hold readings, e.g. planned):
// the true targets are `truth` (part frame), the true poses the stations' poses, the true shared
// inputs drawn from their distributions (normal, with the prior correlation) and returned in
// `shared_true`; each reading is the exact inverse at the truth plus N(0, noise); each reference
// is its true coordinates plus N(0, u^2). Philox keyed by `seed`: reproducible.
Network SimulateNetwork(const Network& network,
                        const std::vector<std::pair<std::string, Eigen::Vector3d>>& truth, std::uint64_t seed,
                        Eigen::VectorXd* shared_true = nullptr);

// Monte Carlo validation of the adjustment's GUM (JCGM 101 applied to the whole estimator): the
// adjusted network is taken as the truth, `trials` measurements of it are simulated
// (SimulateNetwork, seed derived from (seed, trial)) and each is re-adjusted; the spread of the
// re-adjusted targets about the truth is compared with the GUM covariance. Bit-identical for
// any thread count (every trial depends on (seed, trial) only; sums in trial order).
struct NetworkMonteCarlo {
  int trials = 0;
  std::uint64_t seed = 0;
  int ranks = 1;                            // MPI ranks that shared the trials (docs/mpi.md); 1 without MPI
  std::vector<Eigen::Matrix3d> covariance;  // per target (result order): E[(x - x_true)(..)^T]
  std::vector<Eigen::Vector3d> bias;        // per target: mean of x - x_true [m]
  // |u_MCM / u_GUM - 1| within which the two agree at this number of trials: z / sqrt(2 (M - 1))
  // (the standard error of a standard deviation from M values), z the normal quantile that
  // keeps all 3T coordinates inside with 95 % probability (Bonferroni).
  double tolerance = 0.0;
  double worst_ratio = 1.0;  // u_MCM / u_GUM farthest from 1 over all coordinates
  std::string worst;         // "T3.z"
  bool agrees = true;
};
NetworkMonteCarlo ValidateNetworkByMonteCarlo(const Network& network, const NetworkResult& result, int trials,
                                              std::uint64_t seed, int threads = 0);

// Tasks over adjusted targets (distances, planes, circles, spheres, lines, vlt/fits.h), whatever
// station read them: value = FitTask of the adjusted coordinates, covariance G C Gᵀ with C the
// joint covariance of the targets involved (their correlation through the adjustment and the
// consider parameters), G = d value / d coordinates. InputError for an unknown target.
struct NetworkTaskResult {
  std::string name;
  TaskKind kind = TaskKind::kDistance;
  bool weighted = false;  // fitted with the adjustment's covariance as weights (TaskSpec::weighted)
  std::vector<std::string> quantities, units;
  Eigen::VectorXd value, u, U;  // SI; u = U = 0 where not differentiable
  Eigen::MatrixXd covariance;
  std::vector<bool> differentiable;
  std::vector<std::optional<ConformityDecision>> conformity;  // per quantity with a tolerance
  std::vector<std::string> tolerance;                         // DescribeTolerance (SI), "" without one
  std::vector<std::optional<Tolerance>> limits;               // the tolerance itself, SI
};
std::vector<NetworkTaskResult> NetworkTasks(const std::vector<TaskSpec>& tasks, const NetworkResult& result,
                                            const std::string& where);

// The ISO 10360-10 length test from the network (docs/network.md N-13; Wang, Muralikrishnan et
// al., Measurement 165 (2020) 108165): the network, with the instruments' errors it determines,
// gives the reference length L_ref = |x_b - x_a| of every pair of targets; each station measures the
// same length by itself, L = |y_b - y_a| of its own readings through its instrument as it stands
// (the model at the instrument's estimates: its compensation). E = L - L_ref is that station's
// length-measurement error, judged against the MPE A + B L_ref by ISO 14253-1 with the reference's
// expanded uncertainty U = k u(L_ref) (u from the network's full covariance) as the guard band.
struct NetworkLengthTest {
  double mpe_a = 0.0;       // [m]
  double mpe_b = 0.0;       // [1] (m/m)
  double min_length = 1.0;  // pairs with L_ref >= min_length [m]
};

struct NetworkLengthError {
  std::string station, from, to;
  double length = 0.0;          // L_ref [m]
  double error = 0.0;           // E = L_station - L_ref [m]
  double u = 0.0, U = 0.0;      // of L_ref [m]
  double mpe = 0.0;             // A + B L_ref [m]
  ConformityDecision decision;  // E against [-MPE, MPE], guard band U
};

// Every pair of targets (both read by the station, L_ref >= min_length) of every station, in
// station order, then the targets' order of first reading. Readings the robust rule removed are
// left out; a target read several times (both faces) is the mean of its points.
std::vector<NetworkLengthError> NetworkLengthErrors(const Network& network, const NetworkResult& result,
                                                    const NetworkLengthTest& test);

// ---------------------------------------------------------------------------------------------
// The network file (TOML, docs/network.md): [job], [tracker] and [environment] as in a job,
// [network] settings, [datum], [[reference]], [[station]] with its pose and either its readings
// (online) or the targets it sees (offline, with [targets] nominal coordinates), [[task]].

struct NetworkJob {
  std::string file, name, description;
  JobRecord record;  // [job] customer, operator, ... (vlt/job_record.h)
  Network network;
  bool offline = false;                                          // stations `sees` targets of [targets]
  std::vector<std::pair<std::string, Eigen::Vector3d>> nominal;  // offline: [targets], part frame
  std::vector<TaskSpec> tasks;                                   // [[task]] over target names (as in a job)
  // The network file, its CSVs, calibration files (role, path; sha256 when known at reading: a
  // built-in profile's, whose path names no file)
  std::vector<InputFile> input_files;
  std::vector<std::string> warnings;
  std::string output_directory;                  // [output] directory, "" = default
  std::optional<NetworkLengthTest> length_test;  // [network.length_test] (N-13)
  int monte_carlo_trials = 0;                    // [network.monte_carlo] trials (0: no validation)
  std::uint64_t monte_carlo_seed = 20090101;
  std::string text;  // the file's text (for simulated_network.toml)
  // Offline: each [[drift_check]]'s `where`, which its planned readings carry (N-12): the simulated
  // measurement writes them to the check's own readings file.
  std::vector<std::string> drift_check_where;
  std::filesystem::path base_dir;  // relative paths in the file resolve against it
};
NetworkJob LoadNetworkJob(const std::string& path);

}  // namespace vlt

// The files of `vlt network` (docs/network.md "Outputs"), each a (file name, content) pair for an
// all-or-none write (network/outputs.cc).
namespace vlt::network_outputs {

using Files = std::vector<std::pair<std::string, std::string>>;

// targets.csv, stations.csv, residuals.csv, covariance.csv, tasks.csv (with [[task]]: the
// results of NetworkTasks), parameters.csv (with self-calibration), results.json, report.html.
// With a Monte Carlo validation (`mc` not null) also mcm.csv.
Files NetworkFiles(const NetworkJob& job, const NetworkResult& result,
                   const std::vector<NetworkTaskResult>& tasks, const std::string& created,
                   const NetworkMonteCarlo* mc = nullptr);

// An offline network's simulated measurement (SimulateNetwork, truth = [targets] and the
// stations' poses): simulated_<station>.csv per station (the readings, SI: m, rad) and
// simulated_network.toml, the same file made online (stations read their CSVs, references at
// their simulated coordinates): `vlt network simulated_network.toml` adjusts it.
Files SimulatedNetworkFiles(const NetworkJob& job, const Network& simulated, std::uint64_t seed);

// The terminal summary.
std::string NetworkSummary(const NetworkJob& job, const NetworkResult& result,
                           const NetworkMonteCarlo* mc = nullptr);

}  // namespace vlt::network_outputs
