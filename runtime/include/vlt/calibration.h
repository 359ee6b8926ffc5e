// vlt/calibration.h — identifying a tracker's error parameters from measured test data, and the
// calibration file that carries the result into jobs (docs/calibration.md).
//
// The data: readings (range, azimuth, elevation, face) of targets, calibrated reference lengths
// (scale bars measured in several positions) and reference distances (e.g. a reference
// interferometer along the line of sight: the ranging test of ASME B89.4.19). The unknowns: the
// active error parameters of the tracker model and the nuisance unknowns — the coordinates of
// every target in the tracker frame and the length of every bar.
//
// The method (docs/calibration.md, "Identification"):
//  1. Weighted least squares: each reading is an observation of its target through the
//     generated tracker model, x_target = f(readings; params); its residual is expressed in the
//     readings and whitened by the reading noise, e = S^-1/2 J_r^-1 (f(m; params) - x_target)
//     (J_r = d f / d readings at the prior estimates, S = diag(u_range^2, u_az^2, u_el^2)).
//     Bars: (|x_a - x_b| - L_bar) / u_position per position and (L_bar - L_cal) / u_cal once.
//     Reference distances: (|x_a - x_b| - D) / u_D.
//  2. Identifiability: the parameters are scaled by their prior uncertainties, z = (p - p0) / u0,
//     the nuisance unknowns are eliminated (projection onto the orthogonal complement of their
//     Jacobian), and the singular value decomposition of what remains, J~ = U diag(s) V^T, says
//     how well the data alone determine each combination v_i of parameters: u(v_i^T z) = 1 / s_i
//     in units of the prior. A combination with 1 / s_i > hold_ratio * (its prior u) is NOT
//     determined by the data: it is held at its prior (estimate and uncertainty) instead of being
//     fitted to noise, and reported by name.
//  3. The determined combinations are estimated from the data alone (Ceres Solver,
//     Levenberg-Marquardt with the target coordinates eliminated by the Schur complement).
//  4. Covariance: (J^T J)^-1 at the solution for the determined combinations and the nuisance
//     unknowns (reading noise and reference standards both enter J), plus the propagation of the
//     held combinations' prior covariance through the estimator (their uncertainty is not lost).
//     Residuals: chi-square, Birge ratio, redundancy numbers and normalised residuals
//     w = e / sqrt(redundancy) (Baarda's data snooping) with outliers flagged.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "vlt/inverse.h"
#include "vlt/measurement_model.h"
#include "vlt/model_info.h"
#include "vlt/units.h"

namespace vlt {

// One reading of a target: what the tracker showed (raw readings; back face: elevation beyond
// pi/2, as in docs/conventions.md). A target is usually read several times: both faces, repeats.
struct TargetReading {
  std::string target;
  Face face = Face::kFront;
  Eigen::Vector3d readings = Eigen::Vector3d::Zero();  // range [m], azimuth [rad], elevation [rad]
  std::string where;                                   // "<file>: line N" for messages
  // When it was read [s] (a readings file's time column; a drift check's time), if known, of the
  // kind time_kind (its origin). A station's drift model (vlt/network.h) needs it.
  std::optional<double> time;
  TimeKind time_kind = TimeKind::kSeconds;
};

// A calibrated reference length (scale bar) measured in several positions; each position names
// the targets (nests) at its two ends. Its calibrated length enters once, so its calibration
// uncertainty is common to all positions (as it physically is).
struct ReferenceBar {
  std::string name;
  double length = 0.0;      // calibrated length L_cal [m]
  double u = 0.0;           // standard uncertainty of L_cal [m]
  double u_position = 0.0;  // reproducibility of the length between positions (nest seating,
                            // sag, temperature) [m]; > 0
  std::vector<std::pair<std::string, std::string>> positions;  // (end a, end b) targets
  std::string where;
};

// A reference distance between two targets, e.g. a reference interferometer's displacement in a
// ranging test. Independent between entries (document correlated references as a bar instead).
struct ReferenceDistance {
  std::string from, to;
  double length = 0.0;  // [m]
  double u = 0.0;       // [m], > 0
  std::string where;
};

struct CalibrationData {
  const ModelInfo* model = nullptr;  // a tracker model
  // Prior of every model parameter (model order): estimate and standard uncertainty (spec
  // defaults or the job's [tracker.parameters]). u = 0: held exactly at its estimate.
  std::vector<UncertainInput> priors;
  Eigen::MatrixXd prior_correlation;  // empty = independent, else num_params^2
  std::vector<bool> fit;              // per parameter: may the data determine it (default all)
  ReadingNoise noise;                 // of every reading
  std::vector<TargetReading> readings;
  std::vector<ReferenceBar> bars;
  std::vector<ReferenceDistance> distances;
  std::string where;  // the file, for messages
};

struct CalibrationOptions {
  // A combination of parameters is held at its prior when the data alone determine it with a
  // standard uncertainty larger than hold_ratio times its prior standard uncertainty.
  double hold_ratio = 1.0;
  // |w| above this flags an observation as an outlier (Baarda: 3.29 = two-sided alpha 0.001).
  double outlier_limit = 3.29;
  double coverage_probability = 0.95;  // k for the expanded uncertainties printed
  int max_iterations = 100;
};

enum class ParameterStatus {
  kIdentified,  // determined by the data (alone)
  kPartly,      // lies partly in a held combination: its u mixes data and prior
  kHeld,        // not determined by the data: held at its prior
  kFixed,       // prior u = 0, or excluded from the fit by the user: prior kept
};
const char* ParameterStatusName(ParameterStatus status);  // "identified", "partly", "held", "fixed"

struct CalibratedParameter {
  std::string name, unit, quantity;
  double prior_estimate = 0.0, prior_u = 0.0;  // SI
  double estimate = 0.0, u = 0.0;              // SI; u includes held combinations' priors
  double u_data = 0.0;  // standard uncertainty from the data alone (identified part); 0 if none
  ParameterStatus status = ParameterStatus::kFixed;
};

// A combination of parameters the data do not determine: sum_k coefficient_k * (p_k / u0_k),
// unit vector in prior-scaled coordinates. ratio = (data-only u) / (prior u) along it
// (infinity: the data are blind to it).
struct HeldCombination {
  std::vector<std::pair<std::string, double>> terms;  // parameters with |coefficient| >= 0.05 max
  double ratio = 0.0;
  std::string description;  // "lam + srr (ratio inf)"
};

struct CalibratedTarget {
  std::string name;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // tracker frame [m]
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  int readings = 0;
};

struct CalibratedBar {
  std::string name;
  double length = 0.0, u = 0.0;  // adjusted length [m]
};

// One scalar observation's residual at the solution.
struct CalibrationResidual {
  std::string observation;  // "T3 front range", "bar1 position 2", "distance R0-R4"
  std::string where;        // file and line / key
  std::string unit;         // "m" or "rad"
  double residual = 0.0;    // observed - adjusted, in `unit`
  double u = 0.0;           // standard uncertainty of the observation, in `unit`
  double normalised = 0.0;  // residual / u
  double redundancy = 0.0;  // r_ii = 1 - h_ii, 0..1 (the observation's share of the dof)
  double w = 0.0;           // normalised / sqrt(redundancy): ~N(0,1) without gross errors
  bool outlier = false;     // |w| > outlier_limit
};

struct CalibrationResult {
  std::string model;
  std::vector<CalibratedParameter> parameters;  // every model parameter, model order
  Eigen::MatrixXd covariance;                   // num_params^2, SI
  Eigen::MatrixXd correlation;                  // num_params^2 (1 on the diagonal)
  // Identifiability of the parameters the fit could move (prior-scaled): singular values of the
  // reduced, whitened Jacobian (descending) and the condition number s_max / s_min.
  std::vector<std::string> free_parameters;
  Eigen::VectorXd singular_values;
  Eigen::MatrixXd singular_vectors;  // columns: v_i over free_parameters
  double condition_number = 0.0;
  std::vector<HeldCombination> held;
  std::vector<CalibratedTarget> targets;
  std::vector<CalibratedBar> bars;
  std::vector<CalibrationResidual> residuals;
  int observations = 0;  // scalar observations (incl. bar calibrations)
  int unknowns = 0;      // fitted: determined combinations + nuisance
  int dof = 0;
  double chi2 = 0.0;
  double birge_ratio = 0.0;  // sqrt(chi2 / dof)
  double p_value = 0.0;      // P(chi2_dof >= chi2)
  int outliers = 0;
  int iterations = 0;
  double k = 0.0;  // coverage factor of the expanded values printed
};

// Checks the data (unknown targets, too few observations) and identifies the parameters.
// Throws InputError (naming data.where or an entry's where) and NumericalError (no convergence,
// a singular nuisance block).
CalibrationResult Calibrate(const CalibrationData& data, const CalibrationOptions& options = {});

// ---------------------------------------------------------------------------------------------
// Standard tests on a virtual tracker (`vlt test`, docs/calibration.md "Standard tests"): ASME
// B89.4.19 length (system) tests with a scale bar, ranging tests against a reference
// interferometer, two-face tests. The tracker has a true error state p (its [tracker] parameter
// estimates) and reports coordinates with its own compensation p_c (the model's default
// estimates): it reads m = f^-1(x; p) at a true point x and reports f(m; p_c).

enum class TestKind { kLength, kRanging, kTwoFace };
const char* TestKindName(TestKind kind);  // "length", "ranging", "two_face"

struct StandardTest {
  std::string name;
  TestKind kind = TestKind::kLength;
  // Tracker frame, true positions [m]: length and ranging: the two ends (ranging: a = the
  // interferometer's home position); two-face: the target a (b unused).
  Eigen::Vector3d a = Eigen::Vector3d::Zero(), b = Eigen::Vector3d::Zero();
  Face face = Face::kFront;  // length and ranging tests
  std::string bar;           // length tests: the bar (TestLayout::bars) that realises it
  double reference_u = 0.0;  // ranging: u of the interferometer's distance [m]
  std::string where;
};

struct TestLayout {
  std::string name, source, where;
  std::vector<ReferenceBar> bars;  // length, u, u_position (positions are filled by the tests)
  std::vector<StandardTest> tests;
};

// Maximum permissible error a + b R, R = the largest range from the tracker to the test's
// targets (the form of manufacturers' data sheets, e.g. 15 um + 6 um/m). set = false: no verdict.
struct Mpe {
  bool set = false;
  double a = 0.0;  // m
  double b = 0.0;  // m/m
};

struct TestSettings {
  Mpe length, ranging, two_face;
  double coverage_probability = 0.95;
};

struct TestResult {
  std::string name;
  TestKind kind = TestKind::kLength;
  double reference = 0.0;  // reference length [m] (0 for two-face)
  double range_max = 0.0;  // largest range to the test's targets [m]
  // Length and ranging: the length error E = |p_b - p_a| - L (reported minus reference) [m].
  // Two-face: the two-face error |p_back - p_front| [m], with its components along the line of
  // sight (radial) and perpendicular to it (transverse).
  double error = 0.0;
  Eigen::Vector3d two_face = Eigen::Vector3d::Zero();  // p_back - p_front, tracker frame [m]
  double two_face_radial = 0.0, two_face_transverse = 0.0;
  // Uncertainty of the test itself: the reading noise and the reference standard (JCGM 100,
  // linear propagation; two-face: along (p_back - p_front)/|...|, or the largest axis at 0).
  double u = 0.0, U = 0.0, k = 0.0;
  // The reading noise's part of u alone (without the reference standard): the tracker's own
  // random error in this test, which a datasheet's MPE covers (DerivePrior).
  double u_noise = 0.0;
  // Two-face tests: the covariance of p_back - p_front from the reading noise (tracker frame,
  // m^2) and d (p_back - p_front) / d p_k (3 x P): the whole vector, not only its magnitude.
  Eigen::Matrix3d two_face_noise = Eigen::Matrix3d::Zero();
  Eigen::MatrixXd two_face_sensitivity;
  // Spread of the error that the parameters' standard uncertainties imply (what a tracker known
  // to those uncertainties could show).
  double u_parameters = 0.0;
  double mpe = 0.0;     // 0 when no MPE is set for the kind
  std::string verdict;  // "pass", "fail", "" (no MPE)
  // d E / d p_k per model parameter (SI: m/m, m/rad, m/1); two-face: |d (p_back - p_front) / d p_k|.
  Eigen::VectorXd sensitivity;
};

// Simulates every test for `tracker` (model, error state = parameter estimates, their u, noise).
// NumericalError naming the test for a position on the standing axis.
std::vector<TestResult> SimulateTests(const MeasurementSetup& tracker, const TestLayout& layout,
                                      const TestSettings& settings);

// Simulated measured data of the layout's tests for `tracker` (its error state = parameter
// estimates): noisy readings of every target (length and ranging ends in their face, two-face
// targets in both), each bar with the positions of its tests, each ranging test as a reference
// distance. Truths drawn with Philox keyed by `seed` (docs/calibration.md): readings + N(0, noise),
// bar lengths L_cal = L_true + N(0, u), per position + N(0, u_position), references likewise.
// The returned priors are the model's defaults (what a user knows before calibrating).
CalibrationData SimulateCalibrationData(const MeasurementSetup& tracker, const TestLayout& layout,
                                        std::uint64_t seed);

// ---------------------------------------------------------------------------------------------
// Files (runtime/src/calibration/reader.cc; every key in docs/calibration.md). Errors: InputError
// "<file>: <key or line>: <problem>".

// A test layout (e.g. examples/layouts/b89_4_19_2006.toml): [layout], [[bar]], [[length]],
// [[ranging]], [[two_face]] with positions given by distance, azimuth, height, orientation.
TestLayout LoadTestLayout(const std::string& path);

// Input of `vlt test`: the tracker ([tracker] as in a job: its parameter estimates are its true
// error state), the layout, the MPEs, and optionally the seed of simulated measured data.
struct TestJob {
  std::string file, name;
  MeasurementSetup tracker;
  TestLayout layout;
  TestSettings settings;
  bool simulate = false;  // [tests.simulate] present: write simulated calibration data
  std::uint64_t seed = 1;
  std::vector<std::string> warnings;  // implausible but legal values (vlt/job.h Job::warnings)
};
TestJob LoadTestJob(const std::string& path);

// Input of `vlt calibrate`: [tracker] (model, priors, noise), [readings] (a CSV as in online
// jobs; the name column names the target), [[bar]], [[reference]], [calibration] settings.
struct CalibrationJob {
  std::string file, name, instrument;
  CalibrationData data;
  CalibrationOptions options;
  std::vector<std::string> data_files;  // the job file and every CSV it read (provenance)
  std::string output_directory;         // [output] directory, "" = default
  std::vector<std::string> warnings;    // implausible but legal values (vlt/job.h Job::warnings)
};
CalibrationJob LoadCalibrationJob(const std::string& path);

// ---------------------------------------------------------------------------------------------
// Priors from a datasheet (`vlt prior`, docs/profiles.md): the error parameters' standard
// uncertainties under which the simulated standard tests of a layout meet a manufacturer's MPE
// statements with a stated conformance probability p.
//
// For a tracker known only to independent parameter uncertainties u_k (estimates at the model's
// compensation), the error of test t is E_t ~ N(0, sum_k s_tk^2 u_k^2 + u_noise,t^2) (s: the
// sensitivity of SimulateTests; length and ranging tests). The datasheet holds when
// P(|E_t| <= MPE_t) >= p, i.e. z^2 (sum_k s_tk^2 v_k + u_noise,t^2) <= MPE_t^2 with v_k = u_k^2 and
// z = NormalCoverageFactor(p). Two-face tests: E = |Delta|, Delta ~ N(0, C); the constraint is
// c_t^2 tr C <= MPE^2 with c_t the p-quantile of |Delta| / sqrt(tr C) for C's shape at the
// solution (ProbabilityWithinSphere), found by re-solving until it holds: the conformance of every
// test is then at least p exactly, not by a bound. Among all v meeting every test, the solution maximises
// sum_k log v_k (the entropy of the independent normal prior: the widest prior the statement
// allows, and the same whatever units the parameters have), with v_k <= (bound u0_k)^2, u0 the
// model's generic value; a two-face test's factor c_t is held at its value at the solution (the
// maximum of the trace-form problem, not of P(|Delta| <= MPE) >= p itself). At the optimum every
// binding test's budget is shared among the parameters it sees in proportions set by the KKT
// multipliers (equally when one test binds). A parameter that would take less than 1e-6 of every
// test's budget even at its bound is one the datasheet does not constrain: it keeps its generic u0
// (status "not_constrained").
struct PriorSettings {
  double conformance_probability = 0.95;  // p: P(|E| <= MPE) per test
  double bound = 10.0;                     // largest u as a multiple of the generic u0
};
struct PriorJob {
  std::string file, name;
  std::string instrument;  // the instrument the statement is about (make and model)
  MeasurementSetup tracker;  // model, noise; parameter estimates = compensation, u = u0
  TestLayout layout;         // where the standard's tests are simulated
  TestSettings mpe;          // the datasheet's MPE statements (at least one kind)
  PriorSettings settings;
  // Where each number comes from: ("length", "Leica AT500 user manual, 2.8, p. 39: ..."), one
  // per statement and for the noise; written into the prior file.
  std::vector<std::pair<std::string, std::string>> sources;
  std::vector<std::string> warnings;
};
enum class PriorStatus { kFromMpe, kAtBound, kNotConstrained, kFixed };
const char* PriorStatusName(PriorStatus status);  // "from_mpe", "at_bound", "not_constrained", "fixed"
struct PriorParameter {
  std::string name, unit, quantity;
  double estimate = 0.0;  // the compensation (model default) [SI]
  double u0 = 0.0;        // the generic u (model default or the file's) [SI]
  double bound = 0.0;     // bound * u0 [SI]
  double u = 0.0;         // derived [SI]
  PriorStatus status = PriorStatus::kFixed;
};
struct PriorTest {
  std::string name;
  TestKind kind = TestKind::kLength;
  double range_max = 0.0;     // m
  double mpe = 0.0;           // m
  double u_noise = 0.0;       // the reading noise's part [m] (two-face: sqrt of the trace)
  double u_parameters = 0.0;  // the derived priors' part [m] (two-face: sqrt of the trace)
  double u = 0.0;             // in quadrature [m]
  double conformance = 0.0;   // P(|E| <= MPE) under the derived priors (exact for the Gaussian)
  bool binding = false;       // z u reaches MPE (within 1e-6 relative)
  Eigen::VectorXd share;      // per parameter: its share of u^2 (the noise's is 1 - sum)
};
struct PriorResult {
  std::string model;
  std::vector<PriorParameter> parameters;  // every model parameter, model order
  std::vector<PriorTest> tests;            // the tests with an MPE
  double z = 0.0;                          // NormalCoverageFactor(p)
  int evaluations = 0;                     // of the optimiser
};
// Input of `vlt prior`: a test file ([tracker], [tests] layout and mpe, docs/calibration.md) whose
// MPEs are the datasheet's, with [prior] (conformance_probability, bound, [prior.source]).
PriorJob LoadPriorJob(const std::string& path);
// The derivation above. InputError when the reading noise alone breaks a test's MPE at p, when no
// MPE is given, or when no parameter can be solved for; NumericalError if the optimiser fails.
PriorResult DerivePrior(const PriorJob& job);
// P(|x| <= r) for x ~ N(0, C) in 3-D, C with the eigenvalues `variances` (>= 0): the integral of
// the chi-square(3) cdf of r^2 / (w^T C w) over the unit sphere (Gauss-Legendre x trapezoid).
double ProbabilityWithinSphere(const Eigen::Vector3d& variances, double r);

// ---------------------------------------------------------------------------------------------
// The calibration file (TOML, docs/calibration.md): written by `vlt calibrate`, loaded by a job's
// `[tracker] calibration = "<file>"`.

struct CalibrationProvenance {
  std::string instrument;  // free text: make, model, serial number
  std::string created;     // ISO 8601 UTC time of the calibration run
  std::string vlt_version;
  std::vector<std::pair<std::string, std::string>> data_files;  // (file, SHA-256 hex)
};

// Whether a calibration fits its data (FitProblem of vlt/gum.h over its chi-square and the w of
// its residuals): "" when it does, else why not. `vlt calibrate` warns (an error under --strict)
// and the calibration file says so ([calibration] fits = false, fit_problem).
std::string CalibrationFitProblem(const CalibrationResult& result);

// The calibration file's text: model, provenance, every parameter (estimate, u, status, unit),
// the correlation matrix, the fit statistics.
std::string CalibrationFileToml(const CalibrationResult& result, const CalibrationProvenance& provenance);

// Inserts the [calibration] content_sha256 line: the SHA-256 of the text without it (the text must
// contain a "[calibration]" line). Written by vlt calibrate and vlt prior, checked on load.
std::string SealCalibrationText(std::string text);
struct LoadedCalibration {
  std::string model;
  // [calibration] kind: "identified" (vlt calibrate; files without the key) or "prior from MPE"
  // (vlt prior: uncertainties derived from a datasheet, no data about this instrument).
  std::string kind = "identified";
  std::string instrument;
  std::string created;
  std::vector<std::string> names;    // parameters, model order
  std::vector<double> estimates, u;  // SI
  std::vector<std::string> status;
  Eigen::MatrixXd correlation;  // names.size()^2
  // [calibration] fits / fit_problem: false when the calibration did not fit its data
  // (CalibrationFitProblem); a job that loads it warns. Files without the key fit.
  bool fits = true;
  std::string fit_problem;
  // [calibration] content_sha256: the SHA-256 vlt wrote of the file's own text without that line
  // (CalibrationFileToml). `edited` when the text no longer matches it: a job that loads the file
  // warns (an error under --strict). A file without the key (older, or written by hand) is not
  // checked: content_checked false.
  bool content_checked = false;
  bool edited = false;
};
// Reads a calibration file; InputError "<file>: <key>: <problem>" when it is not one.
LoadedCalibration LoadCalibrationFile(const std::string& path);
// The same from text in memory (a built-in profile's prior); `path` names it in messages.
LoadedCalibration LoadCalibrationText(const std::string& text, const std::string& path);
// The built-in instrument profiles' priors (profiles/priors/*.toml, written by vlt prior from
// profiles/*.toml and compiled in): (name, text of the prior file), sorted by name.
const std::vector<std::pair<std::string, std::string>>& BuiltInProfiles();

// SHA-256 of a file's bytes, lower-case hex (for provenance). InputError if it cannot be read.
std::string Sha256File(const std::string& path);
// SHA-256 of bytes in memory, lower-case hex.
std::string Sha256Bytes(std::string_view bytes);

}  // namespace vlt

// The files of `vlt test` and `vlt calibrate` (docs/calibration.md "Outputs"), each a (file name,
// content) pair for an all-or-none write (calibration/outputs.cc).
namespace vlt::calibration_outputs {

using Files = std::vector<std::pair<std::string, std::string>>;

// tests.csv, sensitivity.csv, results.json, report.html; with simulated data also
// simulated_readings.csv and simulated_calibration.toml (a `vlt calibrate` input).
Files TestFiles(const TestJob& job, const std::vector<TestResult>& results, const CalibrationData* simulated);

// calibration.toml (the calibration file), parameters.csv, correlation.csv,
// identifiability.csv, targets.csv, residuals.csv, results.json, report.html.
Files CalibrationFiles(const CalibrationJob& job, const CalibrationResult& result,
                       const CalibrationProvenance& provenance);

// The parameter's display unit and the factor from SI: length -> um (1e6), angle -> arcsec,
// ratio -> ppm (1e6); anything else keeps its SI unit.
std::pair<std::string, double> DisplayUnit(const std::string& quantity, const std::string& si_unit);

// prior.toml (a calibration file of kind "prior from MPE": jobs load it as [tracker] calibration),
// parameters.csv, tests.csv (per test: MPE, u, conformance, binding), shares.csv (each
// parameter's share of each test's u^2), results.json, report.html (sources, parameters, tests,
// the shares as a heat map).
Files PriorFiles(const PriorJob& job, const PriorResult& result, const CalibrationProvenance& provenance);
// One-line terminal summaries.
std::string PriorSummary(const PriorJob& job, const PriorResult& result);
std::string TestSummary(const TestJob& job, const std::vector<TestResult>& results);
std::string CalibrationSummary(const CalibrationJob& job, const CalibrationResult& result);

}  // namespace vlt::calibration_outputs
