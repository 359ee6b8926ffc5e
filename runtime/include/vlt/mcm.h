// vlt/mcm.h — the Monte Carlo method (JCGM 101, and JCGM 102 for the points), the reference that
// validates every GUM result (vlt/validation.h). docs/monte-carlo.md documents every choice.
//
// Two entry points:
//  - RunMcm(McmJob): a laser tracker measurement. Per trial the shared inputs (error parameters,
//    environment, station pose, part thermal) are drawn ONCE and are common to every point — the
//    source of correlation between points; the 3 readings of every point are drawn around their
//    estimates with the reading noise (normal, u(range) = a + b*range); every point is evaluated
//    with MeasurementModel::Evaluate (exact, no linearisation); then every task quantity is
//    computed from the drawn points by the task's own function (the fits of vlt/fits.h), so the
//    fitting algorithm is part of what is propagated and validated.
//    Outputs, in order: x, y, z of point 0 ("<point>.x", ...), x, y, z of point 1, ..., then
//    the outputs of the fit tasks, then those of McmJob::tasks.
//  - RunMcmCustom(ModelInfo of kind "custom", inputs): Y = f(X) of a generated custom model (the
//    JCGM 101 §9 examples), outputs in the model's order.
//
// Reproducibility: every draw depends only on (seed, trial, input) (Philox4x64 counter-based
// generator, runtime/src/mcm/random.h); trials are processed in chunks of fixed size and partial sums
// are merged in chunk order, so results are bit-identical for any number of threads.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "vlt/fits.h"
#include "vlt/measurement_model.h"
#include "vlt/model_info.h"
#include "vlt/tasks.h"

namespace vlt {

// Where the trials of a job's Monte Carlo run (docs/gpu.md, [monte_carlo] device): kAuto on a GPU
// when one works here and the GPU kernel covers the job, else on the CPU (McmResult::device_note
// says why); kCpu always on the CPU; kGpu on a GPU or not at all (InputError saying why). The
// trials' values, so every result, are the same bits on both.
enum class McmDevice { kAuto, kCpu, kGpu };

struct McmSettings {
  std::uint64_t seed = 1;
  McmDevice device = McmDevice::kAuto;
  std::string device_where = "monte_carlo.device";  // where `device` was given, for messages
  // Number of trials M. 0 = adaptive procedure (JCGM 101 7.9.4): batches of
  // max(ceil(100 / (1 - p)), 10^4) trials until twice the standard deviation of the batch values of
  // the mean, u, y_low and y_high of EVERY output is within the numerical tolerance delta (7.9.2).
  std::int64_t trials = 0;
  double coverage_probability = 0.95;    // p, in (0, 1)
  int significant_digits = 2;            // n_dig of 7.9.2 (1 or 2) for the adaptive procedure
  std::int64_t max_trials = 50'000'000;  // adaptive: stop (converged = false) at this many trials
  int num_threads = 0;                   // 0 = std::thread::hardware_concurrency()
  bool quiet = false;                    // no progress bar (it only shows on a terminal anyway)
  // Memory for keeping every model value (stored as float deviations from the value at the
  // estimates, 4 bytes each: relative error 2^-24 of the deviation, see docs/monte-carlo.md).
  // Beyond the budget the coverage intervals and k_p are the averages of the batch values
  // (interval_method says so).
  std::size_t memory_budget_bytes = std::size_t{1} << 30;
  // Tolerances whose probability of conformity is counted over the trials (JCGM 106 7.2.1, the
  // MCM distribution function): McmOutputResult::conformity_probability of `output` is the
  // fraction of all trials with lower <= value <= upper (limits may be infinite).
  struct ToleranceCount {
    int output = 0;
    double lower = 0.0;
    double upper = 0.0;
  };
  std::vector<ToleranceCount> tolerances;
};

// A coverage interval [low, high] for coverage probability p (JCGM 101 7.7).
struct CoverageInterval {
  double low = 0.0;
  double high = 0.0;
};

// Numerical accuracy of one output from the batch values (JCGM 101 7.9.4): standard deviation
// of the batch means of the mean, u, y_low, y_high, s = sqrt(sum (v - vbar)^2 / (h (h - 1))).
// Only full batches count (the shorter last batch of a fixed-M run is left out); zero when fewer
// than 2 full batches were run.
struct McmNumericalAccuracy {
  double s_mean = 0.0;
  double s_u = 0.0;
  double s_low = 0.0;
  double s_high = 0.0;
  double delta = 0.0;  // numerical tolerance of u (7.9.2, n_dig significant digits)
};

struct McmOutputResult {
  std::string name;                 // "P1.x", "distance(P1,P2)", or the custom model's output name
  std::string unit;                 // SI unit
  double value_at_estimates = 0.0;  // f(x) at the input estimates (what GUM reports as y)
  double mean = 0.0;                // estimate y of JCGM 101 7.6
  double u = 0.0;                   // standard uncertainty u(y) (7.6), divisor M - 1
  CoverageInterval symmetric;       // probabilistically symmetric (7.7.1)
  CoverageInterval shortest;        // shortest (7.7.2)
  McmNumericalAccuracy accuracy;
  // Fraction of trials within McmSettings::tolerances of this output (absent when none given).
  std::optional<double> conformity_probability;
  // Whether the output's distribution has a finite variance (docs/monte-carlo.md "Outputs without
  // a finite variance"): Hill's estimate of the tail index alpha, P(|Y| > y) ~ y^-alpha, from the
  // kTailIndexFraction largest and smallest values (the smaller of the two tails' estimates);
  // absent when not every value was kept or M is too small (fewer than kTailIndexMinimumCount
  // values in the fraction). infinite_variance: the estimates at that fraction, a fifth and a
  // twenty-fifth of it all below 2 by two of their standard errors alpha / sqrt(k) (decided from
  // M = 2.5 10^5; mcm/engine.h EstimateTailIndex): the variance, u and the GUM comparison then do
  // not exist (the coverage intervals, quantiles, do).
  std::optional<double> tail_index;
  bool infinite_variance = false;
  // The distribution of the M values (the JCGM 101 figures: histogram with the GUM Gaussian and
  // the coverage intervals): kHistogramBins bins of equal width from mean - 5 u to mean + 5 u,
  // values outside counted in below / above. Empty (no counts) when not every value was kept
  // (the averaged-endpoint method) or u = 0.
  struct Histogram {
    double low = 0.0;    // left edge of the first bin (SI)
    double width = 0.0;  // bin width (SI)
    std::vector<std::int64_t> counts;
    std::int64_t below = 0, above = 0;
  } histogram;
};
inline constexpr int kHistogramBins = 60;
inline constexpr double kTailIndexFraction = 0.005;
inline constexpr std::int64_t kTailIndexMinimumCount = 50;

// JCGM 102 for one measured point (3 coordinates, part frame, m).
struct McmPointResult {
  std::string name;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // m^2, divisor M - 1 (JCGM 102 7.6)
  Eigen::Matrix3d correlation = Eigen::Matrix3d::Identity();
  // Coverage region {eta : |L^-1 (eta - mean)| <= k_p}, covariance = L L^T (JCGM 102 7.7.3):
  // k_p is the p-quantile of |L^-1 (y_r - mean)| over the trials. GUM (normal) gives
  // sqrt(chi2_3(p)) = sqrt(7.8147) = 2.7955 at p = 0.95. has_region = false when the covariance is singular.
  bool has_region = false;
  double coverage_factor = 0.0;
};

// JCGM 102 for the output vector of a custom model with two or more outputs (same meaning as
// McmPointResult, any dimension m; GUM region k = sqrt(chi2_m(p))).
struct McmVectorResult {
  std::string name;
  Eigen::VectorXd mean;
  Eigen::MatrixXd covariance;  // divisor M - 1
  Eigen::MatrixXd correlation;
  bool has_region = false;
  double coverage_factor = 0.0;  // k_p: p-quantile of |L^-1 (y_r - mean)|
};

struct McmResult {
  std::uint64_t seed = 0;
  double coverage_probability = 0.95;
  std::int64_t trials = 0;  // M actually used
  bool adaptive = false;
  bool converged = true;        // adaptive: false when max_trials stopped it first
  std::int64_t batch_size = 0;  // trials per batch (7.9.4 a)
  std::int64_t batches = 0;     // h
  // Adaptive runs (7.9.4): after each batch from the second on, the trials so far and the
  // stopping criterion's worst ratio 2 s / delta over the outputs and their four statistics
  // (the run stops at <= 1): the convergence plot of the report. Empty for a fixed M.
  std::vector<std::int64_t> convergence_trials;
  std::vector<double> convergence_ratio;
  int threads = 1;       // per rank
  int ranks = 1;         // MPI ranks that shared the trials (docs/mpi.md); 1 without MPI
  double seconds = 0.0;  // wall time of the trials
  // Where the trials ran: "cpu", or "gpu: <device> (compute x.y; CUDA driver a.b, NVRTC c.d)";
  // device_note: under McmDevice::kAuto, why not on a GPU ("" when on one or when kCpu was asked).
  std::string device = "cpu";
  std::string device_note;
  // "order statistics of all M values" or
  // "average of the batch endpoints (memory budget exceeded)".
  std::string interval_method;
  std::vector<McmOutputResult> outputs;
  std::vector<McmPointResult> points;    // empty for custom models
  std::vector<McmVectorResult> vectors;  // custom models with >= 2 outputs: the output vector
};

// One measured point of a job: its name and the estimates of its readings
// (range [m], azimuth [rad], elevation [rad], tracker frame conventions of docs/conventions.md).
struct McmPoint {
  std::string name;
  Eigen::Vector3d readings = Eigen::Vector3d::Zero();
};

// One task (a fit or a derived quantity) computed from some of the points in every trial.
// `evaluate` receives the drawn coordinates of `points` (in that order, part frame, m) and
// writes output_names.size() values. It is called from several threads at once and must not
// keep state between calls; it should not allocate (it runs once per trial).
struct McmTask {
  std::string name;                       // e.g. "distance P1-P2", "plane A"
  std::vector<int> points;                // indices into McmJob::points
  std::vector<std::string> output_names;  // full output names, e.g. "plane A.flatness"
  std::vector<std::string> output_units;  // SI units, same size
  std::function<void(std::span<const Eigen::Vector3d> points, std::span<double> outputs)> evaluate;
};

struct McmJob {
  const MeasurementModel* model = nullptr;
  std::vector<McmPoint> points;
  // The tasks of the job file (vlt/tasks.h), recomputed in every trial by vlt/fits.h FitTask
  // (the same code the GUM engine differentiates), with the orientation of plane/circle normals
  // and line directions fixed by the fit to the points at the estimates so that no trial flips
  // sign. Outputs "<task name>.<output name>" in the order of TaskOutputs(kind), units from it.
  std::vector<TaskSpec> fit_tasks;
  std::vector<std::vector<int>> fit_task_points;  // indices into points, one list per fit task
  // A weighted fit task (TaskSpec::weighted) needs its points' covariance (vlt/gum.h
  // TaskPointCovariance): one entry per fit task, null for an ordinary one; may be empty when no
  // task is weighted.
  std::vector<std::shared_ptr<const PointCovariance>> fit_task_covariance;
  // Further quantities from the points (after the fit tasks), e.g. for tests.
  std::vector<McmTask> tasks;
};

// Throws InputError for bad settings (p outside (0,1), M too small for p, n_dig not 1 or 2),
// a correlation matrix that is not a positive definite correlation matrix (message names its
// inputs), a distribution with an invalid shape; NumericalError when a trial produces a
// non-finite value (e.g. a drawn point on the tracker axis).
McmResult RunMcm(const McmJob& job, const McmSettings& settings);

// Inputs estimated from the same n simultaneous observations (Type A, JCGM 100 5.2.3 / H.2):
// jointly a multivariate t distribution t_nu(xbar, S / n) with nu = n - 1 (JCGM 102 6.5.3). The
// members' UncertainInput must be normal with u = s / sqrt(n) (the scale, not the standard
// deviation, which is larger by sqrt(nu / (nu - 2))) and their correlation the sample one.
struct MultivariateTGroup {
  std::vector<int> inputs;  // indices into the model's inputs
  double dof = 0.0;         // nu = n - 1
};

// Custom model entry point: `inputs` one per model.params (same order); `correlation` empty
// (independent) or num_params x num_params. Uses model.forward_batch when present. A model with
// two or more outputs also gets the JCGM 102 covariance and region of its output vector
// (McmResult::vectors[0], named after the model).
McmResult RunMcmCustom(const ModelInfo& model, std::span<const UncertainInput> inputs,
                       const Eigen::MatrixXd& correlation, const McmSettings& settings,
                       std::span<const MultivariateTGroup> t_groups = {});

// Coverage intervals from the sorted values v (ascending, 0-based: v[k - 1] = y_(k)) for
// coverage probability p: q = pM if integer, else floor(pM + 1/2) (JCGM 101 7.7.1);
// symmetric: r = (M - q)/2 if integer else (M - q + 1)/2, interval [y_(r), y_(r+q)];
// shortest: the r in 1..M-q minimising y_(r+q) - y_(r), the smallest such r on ties (7.7.2).
// Throws InputError when M - q < 1 (too few values for p).
std::int64_t CoverageCount(std::int64_t m, double p);  // q
CoverageInterval SymmetricCoverageInterval(std::span<const double> sorted, double p);
CoverageInterval ShortestCoverageInterval(std::span<const double> sorted, double p);

// Numerical tolerance of JCGM 101 7.9.2: u written as c x 10^l with c an n_dig-digit integer
// (after rounding u to n_dig significant digits); delta = 10^l / 2. delta = 0 for u = 0.
double NumericalTolerance(double u, int significant_digits);

}  // namespace vlt
