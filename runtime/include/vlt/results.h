// vlt/results.h — a job run through the GUM engine, the Monte Carlo engine and the validation
// into one Results struct, and the files written from it (docs/results.md):
//   points.csv, points.jsonl, budget.csv, tasks.csv, results.json, report.html (+ map.csv,
//   map.html for maps).
//
// Output files are written by their writers (OutputFile) into a staging directory that replaces
// the output directory only when all of them were written: on any error no output file of the run
// remains. The per-point files are streamed; budgets are recomputed when written, not held.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "vlt/conformity.h"
#include "vlt/custom_job.h"
#include "vlt/gum.h"
#include "vlt/job.h"
#include "vlt/mcm.h"
#include "vlt/measurement_model.h"
#include "vlt/validation.h"

namespace vlt {

// Command-line overrides of the job's [monte_carlo] settings.
struct RunOptions {
  bool monte_carlo = true;             // false: --no-mcm
  std::optional<std::int64_t> trials;  // --trials (0 = adaptive)
  std::optional<std::uint64_t> seed;   // --seed
  std::optional<int> threads;          // --threads
  std::optional<McmDevice> device;     // --device
  bool compute_map = true;             // compute the job's [map] when it has one
  bool progress = false;               // MCM progress bar on a terminal
};

// The Monte Carlo results of one point and their comparison with the GUM.
struct PointMcm {
  McmPointResult mcm;                               // JCGM 102: mean, covariance, region factor
  std::array<McmOutputResult, 3> axes;              // JCGM 101 per coordinate x, y, z
  std::array<ScalarValidation, 3> axis_validation;  // JCGM 101 8 per coordinate
  PointValidation region_validation;                // coverage ellipsoids (vlt/validation.h)
};

// What a run keeps of each point's GUM result (vlt/gum.h PointUncertainty): the readings it was
// propagated from, the part-frame estimate and covariance, and the second-order check (the one
// part that is costly to compute). The rest (tracker frame, line-of-sight splits, coverage
// ellipsoid, budget) follows from these readings and the run's model and is recomputed, bit for
// bit, where a file or a caller needs it (PointDetails): a scan of 10^6 points keeps 184 bytes of
// GUM result a point instead of 736 (issue 33: a 10^6-point scan in 1 GiB).
struct PointGum {
  // Range [m], azimuth [rad], elevation [rad] propagated (plan: computed from the nominal point).
  Eigen::Vector3d readings = Eigen::Vector3d::Zero();
  Eigen::Vector3d part = Eigen::Vector3d::Zero();      // estimate, part frame [m]
  Eigen::Matrix3d cov_part = Eigen::Matrix3d::Zero();  // its covariance [m^2]
  double k = 0.0;                                      // NormalCoverageFactor(p)
  // CheckSecondOrder's (vlt/gum.h PointUncertainty has their meaning).
  Eigen::Vector3d second_order_variance = Eigen::Vector3d::Zero();
  Eigen::Vector3d second_order_ratio = Eigen::Vector3d::Zero();
  bool gum_reliable = true;
  bool second_order_decided = true;

  // The standard and expanded uncertainty per axis, by the expressions of PropagatePoints (the
  // same bits as PointUncertainty::u_part and U_part).
  Eigen::Vector3d u_part() const { return cov_part.diagonal().cwiseMax(0.0).cwiseSqrt(); }
  Eigen::Vector3d U_part() const { return k * u_part(); }
};
PointGum KeptOf(const PointUncertainty& point);

struct PointResult {
  JobPoint input;  // name, face, nominal (plan), readings as given
  PointGum gum;    // the full PointUncertainty: PointDetails
  bool has_mcm = false;
  bool validated = false;  // all of the Monte Carlo validations below passed
  // Set when has_mcm (held apart: a GUM-only scan of 10^6 points does not carry 1.6 kB of empty
  // Monte Carlo fields per point).
  std::shared_ptr<const PointMcm> monte_carlo;
  std::string outcome;  // CombinedOutcome of the validations (vlt/validation.h)
};

struct TaskResult {
  TaskSpec spec;
  std::vector<int> point_indices;
  TaskUncertainty gum;
  bool has_mcm = false;
  std::vector<McmOutputResult> mcm;  // one per gum.quantities
  std::vector<ScalarValidation> validation;
  bool validated = false;  // every applicable quantity validated
  std::string outcome;     // CombinedOutcome (vlt/validation.h)
  // Per quantity with a tolerance (TaskSpec::tolerances): the ISO 14253-1 decision from the GUM
  // (y, U), or, for a quantity without a GUM value (a form quantity at exact nominal points), from
  // the Monte Carlo shortest coverage interval; probability of conformity (JCGM 106).
  std::vector<std::optional<ConformityDecision>> conformity;  // one per gum.quantities
};

// Expanded uncertainty over a grid (`vlt map`, [map]). At every node the GUM expanded uncertainty
// per axis U = k u (part frame, k = NormalCoverageFactor(p)) and the map value
//   U_norm = sqrt(U_x^2 + U_y^2 + U_z^2) = k sqrt(trace U_y),
// the radius of the sphere through the tips of the per-axis expanded uncertainties.
// Nodes within kMapAxisClearance of the tracker's vertical axis or of the gimbal point (tracker
// frame), or more than kMaxRange (10 km) from the tracker, are skipped and counted, never NaN.
inline constexpr double kMapAxisClearance = 1e-3;  // m
struct MapResult {
  MapSettings settings;
  double coverage_probability = 0.95;
  double k = 0.0;
  std::vector<Eigen::Vector3d> nodes;  // every grid node (part frame, m), x fastest
  std::vector<char> computed;          // 0 = skipped
  std::vector<Eigen::Vector3d> U;      // per axis, m (zero where skipped)
  std::vector<double> U_norm;          // m (zero where skipped)
  std::vector<std::string> skipped;    // "x,y,z: reason" for each skipped node
  std::string quantity = "U_norm = sqrt(U_x^2 + U_y^2 + U_z^2), U_i = k u_i, part frame";
  std::string value_name = "|U|";  // what U_norm holds, for plots ("objective" for a
                                   // station map of `vlt plan`)

  // Per source (ExpandedUncertaintyBySource): what each source and each group of sources
  // contributes, U_s = k sqrt(trace of the source's part of U_y); sum_s U_s^2 = U_norm^2 and
  // sum_g U_g^2 = U_norm^2 at every computed node (zero where skipped).
  struct Layer {
    std::string name;       // a source ("tmv", "correlations.thermometer") or group
    std::string group;      // its group ("reading", "parameter", ...)
    std::vector<double> U;  // m, one per node
  };
  std::vector<Layer> sources;  // UncertaintySources order (empty for objective maps)
  std::vector<Layer> groups;   // reading, parameter, environment, pose, thermal,
                               // correlation: those present
  std::vector<int> dominant;   // per node: index into sources of the largest U_s (-1
                               // where skipped)

  // Monte Carlo at the nodes ([map] monte_carlo = true, `vlt map --mcm`): each node run as a
  // plan point through the job's Monte Carlo engine and validated as points are (JCGM 101 8,
  // JCGM 102 regions): U_norm_mcm = k sqrt(trace U_mcm) with the same k as U_norm.
  bool has_mcm = false;
  std::int64_t mcm_trials = 0;
  std::uint64_t mcm_seed = 0;
  std::vector<double> U_norm_mcm;    // m, one per node (0 where skipped)
  std::vector<std::string> verdict;  // "validated", "not validated", "inconclusive"; "" skipped

  // Named positions drawn on the map (`vlt plan`: the recommended and the job's station).
  struct Marker {
    std::string name;
    Eigen::Vector3d position = Eigen::Vector3d::Zero();
    bool point = false;  // a measured point (small dot) rather than a station
  };
  std::vector<Marker> markers;
};

struct Results {
  std::string vlt_version;
  std::string vlt_commit;              // VltCommit()
  std::string created;                 // when the run was made, ISO 8601 UTC (RunCreatedTime)
  std::vector<InputFile> input_files;  // Job::input_files
  std::string job_file;
  std::string job_name;
  std::string job_description;
  JobRecord record;  // Job::record
  JobMode mode = JobMode::kPlan;
  std::string model_name;
  std::optional<CalibrationSource> calibration;  // [tracker] calibration: where the parameters came from
  MeasurementSetup setup;
  std::vector<UncertainInput> shared_inputs;  // MeasurementModel::shared_inputs()
  double coverage_probability = 0.95;
  double k_axis = 0.0;    // NormalCoverageFactor(p)
  double k_region = 0.0;  // ChiSquareCoverageFactor(p, 3)
  int n_dig = 2;
  std::vector<PointResult> points;
  std::string correlation_handling;  // how correlated inputs enter every point's budget
  std::vector<TaskResult> tasks;
  bool has_mcm = false;
  McmResult mcm;  // run information (outputs/points moved into results)
  std::optional<MapResult> map;
  double gum_seconds = 0.0;
  double mcm_seconds = 0.0;
  int threads = 0;               // of the run (the budgets are recomputed with them)
  double ellipsoid_scale = 0.0;  // report: exaggeration of the ellipsoids
  // The per-point files written (docs/results.md "Detail of the per-point files"): [output]
  // detail resolved for the job's size (kFull or kCompact), and [output] arrays (points.npy).
  PointDetail detail = PointDetail::kFull;
  bool arrays = false;
  int validated_points = 0;
  int validated_tasks = 0;
  int inconclusive_points = 0;
};

// The commit vlt was built from (`git describe --always --dirty` at configure time; "unknown"
// outside a git checkout) and its build type.
const char* VltCommit();
const char* VltBuildType();
// Now as ISO 8601 UTC ("2026-11-24T22:19:30Z"); with SOURCE_DATE_EPOCH set (reproducible builds'
// convention) that time instead, so that two runs can be compared byte for byte.
std::string RunCreatedTime();

// Runs the whole job. Throws InputError / NumericalError (nothing is written here). Refuses
// (InputError, before computing) a job whose estimated memory exceeds what is available.
Results RunJob(const Job& job, const RunOptions& options = {});

// The full GUM result of points of `results` (indices into results.points, in that order; every
// point when empty): PropagatePoints of the readings the run propagated, through the run's model,
// so the same bits as the run's (the estimate, covariance, u and U equal PointResult::gum's), with
// the run's second-order check, the point's name and Results::correlation_handling; with its
// budget when `budgets`. On `threads` threads (0: all); the result does not depend on the count.
std::vector<PointUncertainty> PointDetails(const Results& results, std::span<const std::size_t> indices = {},
                                           bool budgets = false, int threads = 0);

// Memory a run of `job` needs, bytes (docs/performance.md "Memory of a job", measured):
//   kJobBaseBytes
//   + per point: kBytesPerPoint + kBytesPerPointInput per input of the point (3 readings + the
//     shared inputs: the points' sensitivities a task propagates)
//   + with Monte Carlo: kBytesPerPointMcm per point, one batch of float values of every output
//     (JCGM 101 7.9.4: up to 10^4 trials) and the stored values for the coverage intervals
//     (at most McmSettings::memory_budget_bytes).
// Per-point files are streamed and budgets recomputed when written: they add nothing. Measured
// (docs/performance.md §4.2, 2026-11-27): a scan of 10^6 points of a mirror tracker, 23 inputs a
// point, one plane, peaked at 995 MB (920 bytes a point above 75 MB); this estimate says 1.6 GB.
inline constexpr std::uint64_t kJobBaseBytes = std::uint64_t{64} << 20;
inline constexpr std::uint64_t kBytesPerPoint = 1000;
inline constexpr std::uint64_t kBytesPerPointInput = 24;
// (measured 1800, plus the histograms of the three coordinates, McmOutputResult::histogram)
inline constexpr std::uint64_t kBytesPerPointMcm = 1800 + 3 * (kHistogramBins * 8 + 32);
std::uint64_t EstimateJobMemory(const Job& job, const RunOptions& options = {});
// Bytes available to the job: the least of MemAvailable of /proc/meminfo (else the physical
// memory), what is left of the address-space limit (ulimit -v) and of the cgroup v2 memory.max.
std::uint64_t AvailableMemory();
// InputError "<file>: plan: this job needs about X GiB of memory (...) and Y GiB are available;
// split it into jobs of at most N points" when EstimateJobMemory(job, options) > available_bytes.
void CheckJobMemory(const Job& job, std::uint64_t available_bytes, const RunOptions& options = {});

// ---------------------------------------------------------------------------------------------
// A custom-model job (vlt/custom_job.h, docs/custom-models.md): files outputs.csv, budget.csv,
// results.json ("schema": "vlt-custom-results/1"), report.html.
struct CustomOutputResult {
  CustomOutput gum;  // estimate, u, nu_eff, k = t_p(nu_eff), U, budget
  bool has_mcm = false;
  McmOutputResult mcm;          // JCGM 101 7.6, 7.7
  ScalarValidation validation;  // JCGM 101 8 (the GUM interval y +- k u)
  std::optional<Tolerance> tolerance;
  std::optional<ConformityDecision> conformity;  // ISO 14253-1 / JCGM 106
};

// JCGM 102 for the output vector (two or more outputs): the GUM region k = sqrt(chi2_m(p)) and
// the Monte Carlo one, compared by their coverage factors and covariances.
struct CustomRegionResult {
  double gum_k = 0.0;
  bool has_mcm = false;
  McmVectorResult mcm;
  double coverage_factor_ratio = 0.0;  // k_mcm / k_gum
  double covariance_difference = 0.0;  // |U_mcm - U_gum|_F / |U_gum|_F
};

struct CustomResults {
  std::string vlt_version;
  std::string job_file;
  std::string job_name;
  std::string job_description;
  JobRecord record;  // CustomJob::record
  const ModelInfo* model = nullptr;
  std::vector<UncertainInput> inputs;      // the GUM's (CustomJob::inputs)
  std::vector<UncertainInput> mcm_inputs;  // what Monte Carlo sampled
  std::vector<CustomInputSource> sources;
  std::vector<double> dof;
  Eigen::MatrixXd correlation;
  std::vector<std::vector<int>> simultaneous;
  std::vector<double> simultaneous_mcm_dof;
  double coverage_probability = 0.95;
  int n_dig = 2;
  CustomUncertainty gum;
  std::vector<CustomOutputResult> outputs;
  std::optional<CustomRegionResult> region;
  bool has_mcm = false;
  McmResult mcm;        // run information
  std::string outcome;  // CombinedOutcome of the validations
  double gum_seconds = 0.0;
  double mcm_seconds = 0.0;
};

CustomResults RunCustomJob(const CustomJob& job, const RunOptions& options = {});
std::vector<std::pair<std::string, std::string>> ResultFiles(const CustomResults& results);
std::string SummaryText(const CustomResults& results);

// The map of `settings` for a job's model (nodes in the part frame), with its per-source layers.
MapResult ComputeMap(const MeasurementModel& model, const MapSettings& settings, double coverage_probability,
                     int threads);
// Marks the job's tracker (its origin, part frame, at the estimates) and its points (plan: nominal;
// readings: the part-frame estimates; at most kMaxMapPointMarkers) on the map.
inline constexpr std::size_t kMaxMapPointMarkers = 500;
void MarkJobOnMap(const Job& job, const MeasurementModel& model, MapResult& map);
// Adds the Monte Carlo map (MapResult::has_mcm ...): the computed nodes of `map` as plan points
// of `job` (its setup and [monte_carlo] settings, overridden by `options`; no tasks) through
// RunJob. The same seed gives the same map for any thread count. Refuses (InputError) what
// CheckJobMemory refuses.
void AddMonteCarloToMap(const Job& job, const RunOptions& options, MapResult& map);

// The readings of every point of a job (plan: computed from the nominal points), on `threads`
// threads (0: all); the same for any count.
std::vector<PointReadings> JobReadings(const Job& job, const MeasurementModel& model, int threads = 1);

class OutputText;
// File contents (docs/results.md). The per-point files are written as they are formatted.
void WritePointsCsv(const Results& results, OutputText& out);
void WriteBudgetCsv(const Results& results, OutputText& out);
void WritePointsJsonl(const Results& results, OutputText& out);
// The compact points.csv (one row per point, PointDetail::kCompact) and points.npy (every point's
// full detail as a NumPy structured array; layout in docs/results.md "points.npy").
void WriteCompactPointsCsv(const Results& results, OutputText& out);
void WritePointsNpy(const Results& results, OutputText& out);
std::string PointsCsv(const Results& results);
std::string BudgetCsv(const Results& results);
std::string PointsJsonl(const Results& results);
std::string TasksCsv(const Results& results);
std::string MapCsv(const MapResult& map);
std::string ResultsJson(const Results& results, int indent = 1);
std::string ReportHtml(const Results& results);
std::string MapHtml(const MapResult& map, const std::string& title);
// The map alone as JSON: the "map" object of results.json (docs/results.md), for `vlt map --json`.
std::string MapJson(const MapResult& map, int indent = 1);

// Where an output file's text goes while it is written: the staging file of an OutputDirectory
// (buffered) or a string (tests, --json on stdout).
class OutputText {
 public:
  virtual ~OutputText() = default;
  virtual void Write(std::string_view text) = 0;
};
class StringText final : public OutputText {
 public:
  void Write(std::string_view text) override { text_.append(text); }
  std::string& text() { return text_; }

 private:
  std::string text_;
};

// One file of an output set: its plain name and what writes its text. The per-point files of a
// scan are written point by point into the staging directory, never held whole in memory.
struct OutputFile {
  std::string name;
  std::function<void(OutputText&)> write;
  OutputFile(std::string file_name, std::string content);
  OutputFile(std::string file_name, std::function<void(OutputText&)> writer);
};

// Files whose text is already complete (name, content).
std::vector<OutputFile> AsOutputFiles(const std::vector<std::pair<std::string, std::string>>& files);

// The files of a `vlt run`: points.csv, points.jsonl and budget.csv (full detail; compact: the
// compact points.csv only), points.npy ([output] arrays), tasks.csv, results.json, report.html
// and, with a map, map.csv and map.html. The writers refer to `results`, which must
// outlive the Commit.
std::vector<OutputFile> ResultFiles(const Results& results);

// The output directory of a command, replaced as one transaction (docs/cli.md "Outputs"):
// construct it BEFORE computing (it checks the location: not a file, not a directory holding
// files vlt did not write, a writable parent — else InputError), then Commit the complete set of
// files: they are written into a staging directory beside the target and swapped in atomically,
// so a reader sees the old set or the new set, never a mixture, and no file of an earlier run
// survives. An uncommitted or failed transaction leaves the old set untouched and removes its
// staging directory (also on SIGINT/SIGTERM once InstallOutputSignalHandlers ran).
class OutputDirectory {
 public:
  explicit OutputDirectory(const std::filesystem::path& target);
  ~OutputDirectory();
  OutputDirectory(const OutputDirectory&) = delete;
  OutputDirectory& operator=(const OutputDirectory&) = delete;

  const std::filesystem::path& path() const { return target_; }
  // Writes `files` (plain names) plus the marker file and swaps them in.
  void Commit(const std::vector<OutputFile>& files);

 private:
  std::filesystem::path target_;
  std::filesystem::path parent_;
  std::filesystem::path staging_;
};

// The marker file vlt puts into every output directory it writes.
inline constexpr const char* kOutputMarker = ".vlt-output";

// SIGINT / SIGTERM remove a staging directory being written, then end the process as the signal
// would (main() installs them once).
void InstallOutputSignalHandlers();

// A short human summary of the results (units in the headers) for the terminal.
std::string SummaryText(const Results& results);

// A name safe as a file or directory name: [A-Za-z0-9._-] kept, anything else '_' ("job" for an
// empty name, "." or ".."). A job's default output directory is vlt-out/<SafeFileName(name)>.
std::string SafeFileName(const std::string& name);

}  // namespace vlt
