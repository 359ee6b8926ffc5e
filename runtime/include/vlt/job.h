// vlt/job.h — a job file (TOML, docs/job-file.md) read into what the engines need.
//
// A job says which tracker and how uncertain its error parameters are (MeasurementSetup), where
// it measures (offline: nominal points of a plan; online: the tracker's readings from a CSV), what
// is derived from the points (tasks: distances and fitted features), how the Monte Carlo method
// runs, and optionally a map of the expanded uncertainty over a plane or a box.
//
// Every value is converted to SI on reading (vlt/units.h). Every problem is an InputError with one
// line "<file>: <key or line>: <problem>"; unknown keys are errors.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "vlt/inverse.h"
#include "vlt/job_record.h"
#include "vlt/mcm.h"
#include "vlt/measurement_model.h"
#include "vlt/tasks.h"
#include "vlt/units.h"

namespace vlt {

enum class JobMode {
  kPlan,      // offline: nominal points, readings computed from them ([plan])
  kReadings,  // online: the tracker's readings ([readings])
};

// Face (front / back) and FaceName: vlt/inverse.h.

struct JobPoint {
  std::string name;
  Face face = Face::kFront;
  // kPlan: nominal coordinates in the part frame at the reference temperature [m].
  Eigen::Vector3d nominal = Eigen::Vector3d::Zero();
  // kReadings: the tracker's readings as measured (range [m], azimuth [rad], elevation [rad]);
  // back-face readings are the raw ones (elevation in (pi/2, 3pi/2)).
  Eigen::Vector3d readings = Eigen::Vector3d::Zero();
  std::string where;  // where it was defined, for messages: "job.toml: plan.point[2]", "r.csv: line 7"
  // kReadings with a time column: when it was read [s] (docs/job-file.md "Readings"), of the kind
  // time_kind (its origin).
  std::optional<double> time;
  TimeKind time_kind = TimeKind::kSeconds;
};

// JCGM 101 7.2 / 7.9: fixed number of trials or the adaptive procedure.
// [monte_carlo] device and --device: "auto", "cpu", "gpu" (docs/gpu.md); InputError
// "<where>: '<name>': expected ..." for another word.
McmDevice McmDeviceNamed(std::string_view name, const std::string& where);

struct MonteCarloSettings {
  bool enabled = true;
  std::int64_t trials = 200000;   // fixed M (ignored when adaptive)
  bool adaptive = false;          // JCGM 101 7.9.4
  int n_dig = 2;                  // significant digits of the numerical tolerance (7.9.2)
  std::uint64_t seed = 20090101;  // Philox key: same seed, same result for any thread count
  double coverage_probability = 0.95;
  int threads = 0;  // 0: all hardware threads
  McmDevice device = McmDevice::kAuto;  // where the trials run (docs/gpu.md)
};

// Largest range [m] vlt accepts from a reading or a planned point: beyond any laser tracker (the
// longest reach 160 m), and a guard against values that overflow the computation (1e300 m).
inline constexpr double kMaxRange = 1e4;

// The checks every tracker reading passes, from a job's readings CSV, a network's or a calibration's,
// and the Python module (one rule for every source, issue 32): finite, range in (0, kMaxRange] m,
// azimuth and elevation within +-720 deg [rad]. Throws InputError "<where>: <name>: <problem>" with
// names[k] the reading's name in the caller's words (a CSV column, "range [m]").
void CheckReadings(const std::array<double, 3>& readings, const std::string& where,
                   const std::array<std::string, 3>& names = {"range", "azimuth", "elevation"});

// The checks every true point given to the inverse model passes (`vlt simulate --point`, Python
// simulate(), a plan's points): finite, at most kMaxRange from the tracker. Throws InputError
// "<where>: <problem>".
void CheckTrackerPoint(const std::array<double, 3>& point, const std::string& where);

// The cap on every value vlt computes with, from any source (job file, calibration file, command
// line, Python): |value| <= 1e12 in SI units and finite. Throws InputError "<where>: <problem>".
void CheckValueMagnitude(double value, const std::string& where);

// Largest number of nodes of a map grid (ParseMapPlane / ParseMapBox refuse more).
inline constexpr double kMaxMapNodes = 1e6;

// A grid for `vlt map` / [map]: a plane (two axes vary, one fixed) or a box (all three vary).
struct MapSettings {
  enum class Kind { kPlane, kBox };
  Kind kind = Kind::kPlane;
  int fixed_axis = 2;                             // kPlane: 0 = x, 1 = y, 2 = z
  double level = 0.0;                             // kPlane: value of the fixed coordinate [m]
  Eigen::Vector3d min = Eigen::Vector3d::Zero();  // [m], the fixed axis has min = max = level
  Eigen::Vector3d max = Eigen::Vector3d::Zero();
  double step = 0.25;          // grid spacing [m]
  std::string frame = "part";  // coordinates of the grid: "part" (like plan points)
  std::string description;     // e.g. "plane z = 0 m, x 0..4 m, y -1..1 m, step 0.25 m"
  bool monte_carlo = false;    // also the Monte Carlo map (AddMonteCarloToMap, vlt/results.h)

  // Number of grid nodes along each axis (1 along the fixed axis of a plane).
  Eigen::Vector3i counts() const;
  // Grid node coordinates in row-major order (x fastest, then y, then z): min + i step per axis,
  // snapped to 1 nm so that a node is the decimal the grid means (-0.1, not -0.09999999999999998).
  std::vector<Eigen::Vector3d> Nodes() const;
  double Node(double from, int index) const;
};

// Parses the command-line / job-file spellings: plane "z=0" or "z = 1.5 m"; extent
// "xmin,xmax,ymin,ymax" (the two free axes of the plane, in axis order); box
// "xmin,xmax,ymin,ymax,zmin,zmax"; step "0.25m". Numbers without a unit are metres.
MapSettings ParseMapPlane(std::string_view plane, std::string_view extent, std::string_view step,
                          std::string_view where);
MapSettings ParseMapBox(std::string_view box, std::string_view step, std::string_view where);

// [optimize]: where `vlt plan` may put the station and what it minimises (docs/planning.md).
// Positions are the tracker's origin (the pose translation t of [station]) in the part frame.
struct KeepOutBox {
  std::string name;  // for messages and the report, e.g. "keep_out[0]" or its name
  Eigen::Vector3d min = Eigen::Vector3d::Zero();  // [m]
  Eigen::Vector3d max = Eigen::Vector3d::Zero();
};
struct ObjectiveTerm {
  // "points": the largest |U| = sqrt(U_x^2 + U_y^2 + U_z^2) of the job's points; or
  // "<task>.<quantity>": the expanded uncertainty U of a task quantity with unit m.
  std::string quantity = "points";
  double weight = 1.0;  // objective = sum of weight * term [m]
  int task = -1;        // index into Job::tasks, -1 for "points"
  int output = -1;      // index into TaskOutputs(kind)
};
struct OptimizeSettings {
  std::vector<Eigen::Vector2d> floor;  // polygon of allowed (x, y) [m], >= 3 vertices
  double z_min = 0.0, z_max = 0.0;     // allowed heights of the origin [m] (equal: fixed)
  double min_range = 0.0;              // every point at least this far from the station [m]
  double max_range = kMaxRange;        // and at most this far
  double acceptance_angle = 0.0;       // half-angle [rad]; 0: not checked
  Eigen::Vector3d target_normal = Eigen::Vector3d::Zero();  // default normal of every point (unit; 0: none)
  std::vector<std::pair<std::string, Eigen::Vector3d>> normals;  // per point (unit)
  std::vector<KeepOutBox> keep_out;      // may not hold the station nor lie under it, nor cross a
                                         // line of sight
  std::vector<ObjectiveTerm> objective;  // at least one
  double step = 0.0;                     // station map spacing [m]
  std::int64_t evaluations = 2000;       // of the global search
  std::uint64_t seed = 20090101;         // of the global search (NLopt's generator)
  std::string where;                     // "<file>: optimize"
};

// How much of every point the files hold (docs/results.md "Detail of the per-point files"): the
// full detail (points.csv with every column, points.jsonl, budget.csv: about 10 kB per point) or
// one compact row per point (points.csv: name, estimate, U per axis, |U|, the dominant input and
// its share; about 80 bytes per point). kAuto: full up to kFullDetailMaxPoints points, compact
// above (a scan of 10^6 points would write about 10 GB in full).
enum class PointDetail { kAuto, kFull, kCompact };
inline constexpr std::size_t kFullDetailMaxPoints = 10000;
// PointDetail's resolution for a job of n points.
inline PointDetail ResolvedDetail(PointDetail detail, std::size_t n) {
  if (detail != PointDetail::kAuto) return detail;
  return n <= kFullDetailMaxPoints ? PointDetail::kFull : PointDetail::kCompact;
}

struct OutputSettings {
  std::string directory;                    // [output] directory (relative to the job file); "" = default
  double ellipsoid_scale = 0.0;             // report: ellipsoid exaggeration; 0 = automatic
  PointDetail detail = PointDetail::kAuto;  // [output] detail
  bool arrays = false;  // [output] arrays: every point's full detail in points.npy as well
};

// Where the tracker's error parameters came from when a calibration file gave them
// ([tracker] calibration = "<file>", docs/calibration.md).
struct CalibrationSource {
  std::string file;        // as resolved against the job file's directory
  std::string sha256;      // of the file's bytes
  std::string instrument;  // [calibration] instrument of the file
  std::string created;     // [calibration] created of the file (ISO 8601 UTC)
  std::string kind = "identified";  // [calibration] kind: "identified" or "prior from MPE" (vlt prior)
};

// A file a job was read from, for provenance (results.json "job.input_files", the report header).
struct InputFile {
  std::string role;    // "job", "plan csv", "readings csv", "calibration"
  std::string path;    // as named in messages (resolved against the job file's directory)
  std::string sha256;  // of the file's bytes, lower-case hex
};

struct Job {
  std::string file;                // the job file as named in messages
  std::filesystem::path base_dir;  // relative paths in the job are relative to this
  std::string name;                // [job] name (default: the file's stem)
  std::string description;
  JobRecord record;  // [job] customer, operator, place, conditions, instrument
  MeasurementSetup setup;
  JobMode mode = JobMode::kPlan;
  std::vector<JobPoint> points;
  std::string readings_file;                     // kReadings: the CSV as resolved (provenance)
  std::optional<CalibrationSource> calibration;  // parameters from a calibration file
  std::vector<InputFile> input_files;  // the job file (from its text), its CSVs, its calibration file
  // Implausible but legal values, one line each "<file>: <key>: <why>" (the command prints them
  // as "vlt: warning: ..."; --strict makes the first one an error).
  std::vector<std::string> warnings;
  std::vector<TaskSpec> tasks;
  std::vector<std::vector<int>> task_points;  // resolved indices into points, per task
  MonteCarloSettings monte_carlo;
  std::optional<MapSettings> map;
  std::optional<OptimizeSettings> optimize;  // [optimize] (vlt plan)
  OutputSettings output;

  // Every point's name in the job's order, copied on `threads` threads (0: all; a scan's task over
  // "all": 10^6 names).
  std::vector<std::string> point_names(int threads = 1) const;
};

// What the command line changes in a job as it is read (`vlt run`, docs/cli.md).
struct JobOverrides {
  // A calibration file in place of [tracker] calibration (`--calibration FILE`; FILE relative to the
  // working directory, not to the job file): the calibration `vlt calibrate` just wrote, used
  // without editing the job.
  std::optional<std::string> calibration;
  // The threads that read the job's files (`--threads`), in place of [monte_carlo] threads: a
  // scan's plan of 10^6 points is read side by side. The job read is the same for any count.
  std::optional<int> threads;
};

// Reads and checks the job file at `path` (relative paths inside resolve against its directory).
Job LoadJob(const std::string& path, const JobOverrides& overrides = {});

// Same from text: `file` names it in messages, `base_dir` resolves relative CSV paths.
Job ParseJob(std::string_view text, const std::string& file, const std::filesystem::path& base_dir,
             const JobOverrides& overrides = {});

// The embedded default job run by `vlt demo` and bare `vlt` (runtime/src/job/default_job.cc).
std::string_view DefaultJobToml();
inline constexpr const char* kDefaultJobName = "vlt-demo.toml";

// Horizontal distance [m] below which a point is "on the tracker's vertical axis": its azimuth is
// undefined, so no readings can be planned for it.
inline constexpr double kVerticalAxisTolerance = 1e-6;

// A nominal part-frame point expressed in the tracker frame at the job's estimates (inverse of the
// station pose and part thermal expansion of vlt/measurement_model.h).
Eigen::Vector3d PartToTrackerNominal(const MeasurementSetup& setup, const Eigen::Vector3d& part);

}  // namespace vlt
