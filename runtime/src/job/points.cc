// job/points.cc — the points of a job file: [plan] (nominal part coordinates, inline or CSV: offline)
// and [readings] (range, azimuth, elevation/zenith, face from a CSV: online). Keys: docs/job-file.md.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <numbers>
#include <charconv>
#include <cstdlib>
#include <optional>
#include <string>
#include <vector>

#include <functional>

#include "base/csv.h"
#include "base/time.h"
#include <toml++/toml.h>

#include "job/job_detail.h"
#include "parallel/memory.h"
#include "parallel/pool.h"
#include "vlt/calibration.h"
#include "vlt/error.h"
#include "vlt/input_file.h"
#include "vlt/inverse.h"
#include "vlt/job.h"
#include "vlt/units.h"

namespace vlt::job_internal {

namespace {

constexpr double kPi = 3.14159265358979323846;

Face ParseFaceField(std::string text, const std::string& where) {
  std::transform(text.begin(), text.end(), text.begin(), [](unsigned char c) { return std::tolower(c); });
  if (text == "front" || text == "1" || text == "f" || text == "fs") return Face::kFront;
  if (text == "back" || text == "2" || text == "b" || text == "bs") return Face::kBack;
  throw InputError(where + ": face '" + text + "' (expected front or back, or 1 or 2)");
}

// A coordinate of a plan point: a number in the plan's unit or a string with its own unit.
double PlanCoordinate(const toml::node& node, double unit_scale, const std::string& where) {
  if (node.is_number()) return AsNumber(node, where) * unit_scale;
  return AsQuantity(node, Dimension::kLength, where);
}

// [plan] header = false with columns = [...]: a file without a header line (a `name x y z` list as
// tracker and CAD software export it), whose columns the job names. Returns the columns, or
// nothing for a file with its header line.
std::optional<std::vector<std::string>> PlanColumns(Section& s) {
  const toml::node* header = s.Get("header");
  const toml::node* columns = s.Get("columns");
  const bool has_header = header ? AsBool(*header, s.Where("header")) : true;
  if (has_header) {
    if (columns)
      throw InputError(s.Where("columns") + ": the columns of a file without a header line (header = false)");
    return std::nullopt;
  }
  if (!columns)
    throw InputError(s.Where("columns") +
                     ": required key is missing (header = false: name the file's columns)");
  if (!columns->is_array())
    throw InputError(s.Where("columns") + ": expected an array such as [\"name\", \"x\", \"y\", \"z\"]");
  std::vector<std::string> names;
  for (const toml::node& e : *columns->as_array()) {
    const std::string name = AsString(e, s.Where("columns"));
    if (name != "name" && name != "x" && name != "y" && name != "z" && name != "face")
      throw InputError(s.Where("columns") + ": unknown column '" + name +
                       "' (plan columns: name, x, y, z [, face])");
    if (std::find(names.begin(), names.end(), name) != names.end())
      throw InputError(s.Where("columns") + ": column '" + name + "' appears twice");
    names.push_back(name);
  }
  for (const char* required : {"name", "x", "y", "z"}) {
    if (std::find(names.begin(), names.end(), required) == names.end())
      throw InputError(s.Where("columns") + ": missing column '" + required +
                       "' (plan columns: name, x, y, z [, face])");
  }
  return names;
}

}  // namespace

double UnitScale(const std::string& unit, Dimension dim, const std::string& where) {
  double one = ParseQuantity("1 " + unit, dim, where);
  double zero = ParseQuantity("0 " + unit, dim, where);
  return one - zero;
}

namespace {

// A planned point must have a defined azimuth: not on the tracker's vertical axis, and within a
// tracker's range.
void CheckReach(const Job& job, const JobPoint& p) {
    Eigen::Vector3d t = PartToTrackerNominal(job.setup, p.nominal);
    if (!(t.stableNorm() <= kMaxRange)) {
      throw InputError(p.where + ": point '" + p.name + "' is " +
                       FormatQuantity(t.stableNorm(), Dimension::kLength, "m", 6) +
                       " from the tracker: beyond any laser tracker (at most " +
                       FormatQuantity(kMaxRange, Dimension::kLength, "km", 3) + ")");
    }
    if (std::hypot(t.x(), t.y()) < kVerticalAxisTolerance) {
      throw InputError(
          p.where + ": point '" + p.name +
          "' lies on the tracker's vertical axis (azimuth undefined; move the point or the station)");
    }
}

// The points of a plan CSV's rows, appended to job.points in the rows' order: the CSV's pieces
// side by side, each row made a point where it is parsed (no table of 10^6 rows of strings; a
// thread frees what it allocated). The first error in the file is the one said.
void ReadPlanRows(CsvPieces pieces, double scale, int threads, Job& job) {
  const CsvTable& head = pieces.head();
  const std::string& rel = head.file;
  auto run = [&](std::size_t count, const std::function<void(std::size_t)>& task) {
    parallel_internal::ForEach(count, threads, [&](std::size_t k, int) { task(k); });
  };
  pieces.Count(run);
  pieces.CheckHasRows();
  for (const char* col : {"name", "x", "y", "z"}) {
    if (head.Column(col) < 0) {
      throw InputError(rel + ": line " + std::to_string(head.header_line) + ": missing column '" + col +
                       "' (plan CSV columns: name, x, y, z [, face]; a file without a header line: "
                       "header = false and columns = [\"name\", \"x\", \"y\", \"z\"])");
    }
  }
  for (const std::string& col : head.header) {
    if (col != "name" && col != "x" && col != "y" && col != "z" && col != "face") {
      throw InputError(rel + ": line " + std::to_string(head.header_line) + ": unknown column '" + col +
                       "' (plan CSV columns: name, x, y, z [, face])");
    }
  }
  const int cn = head.Column("name"), cx = head.Column("x"), cy = head.Column("y"), cz = head.Column("z"),
            cf = head.Column("face");
  std::vector<std::size_t> first(pieces.size() + 1, job.points.size());
  for (std::size_t k = 0; k < pieces.size(); ++k) first[k + 1] = first[k] + pieces.RowsIn(k);
  // A scan's 10^6 points: no growth slack, the pages mapped side by side (parallel/memory.h).
  parallel_internal::ReserveMapped(job.points, first.back(), threads);
  job.points.resize(first.back());
  run(pieces.size(), [&](std::size_t k) {
    std::size_t i = first[k];
    pieces.Read(k, [&](CsvRow& row) {
      JobPoint& p = job.points[i++];
      p.where = head.Where(row);
      p.name = std::move(row.fields[cn]);
      CheckName(p.name, p.where, "point");
      p.nominal = {CsvQuantity(row.fields[cx], Dimension::kLength, scale, 0, p.where, ": x"),
                   CsvQuantity(row.fields[cy], Dimension::kLength, scale, 0, p.where, ": y"),
                   CsvQuantity(row.fields[cz], Dimension::kLength, scale, 0, p.where, ": z")};
      if (cf >= 0 && !row.fields[cf].empty()) p.face = ParseFaceField(row.fields[cf], p.where);
    });
  });
}

}  // namespace

void ReadPlan(Section& s, Job& job, bool check_reach, int threads) {
  s.set_hint("unit, csv, header, columns, point");
  std::string unit = "m";
  if (const toml::node* n = s.Get("unit")) unit = AsString(*n, s.Where("unit"));
  double scale = UnitScale(unit, Dimension::kLength, s.Where("unit"));

  if (const toml::node* n = s.Get("csv")) {
    std::string rel = AsString(*n, s.Where("csv"));
    std::filesystem::path path = job.base_dir / rel;
    if (const std::string problem = InputFileProblem(path.string()); !problem.empty()) {
      throw InputError(s.Where("csv") + ": cannot read '" + path.string() + "': " + problem);
    }
    const std::optional<std::vector<std::string>> columns = PlanColumns(s);
    rel = path.string();
    // A scan's plan of 10^6 rows is parsed and converted side by side (issue 33); the first error
    // in the file is the one said, whatever the thread count (parallel/pool.h).
    const std::string text = ReadInputFile(rel, rel, "cannot read CSV file '" + rel + "'");
    ReadPlanRows(CsvPieces(text, rel, columns ? &*columns : nullptr), scale, threads, job);
    job.input_files.push_back({"plan csv", rel, Sha256Bytes(text)});
  }
  if (const toml::node* n = s.Get("point")) {
    if (!n->is_array()) throw InputError(s.Where("point") + ": expected [[plan.point]] tables");
    job.points.reserve(job.points.size() + n->as_array()->size());
    int index = 0;
    for (const toml::node& e : *n->as_array()) {
      std::string path = s.path() + ".point[" + std::to_string(index++) + "]";
      if (!e.is_table()) throw InputError(job.file + ": " + path + ": expected a table");
      Section pt(*e.as_table(), job.file, path);
      pt.set_hint("name, x, y, z, face");
      JobPoint p;
      p.where = job.file + ": " + path;
      p.name = AsString(pt.Require("name"), pt.Where("name"));
      CheckName(p.name, pt.Where("name"), "point");
      p.nominal = {PlanCoordinate(pt.Require("x"), scale, pt.Where("x")),
                   PlanCoordinate(pt.Require("y"), scale, pt.Where("y")),
                   PlanCoordinate(pt.Require("z"), scale, pt.Where("z"))};
      if (const toml::node* f = pt.Get("face"))
        p.face = ParseFaceField(AsString(*f, pt.Where("face")), pt.Where("face"));
      pt.Finish();
      job.points.push_back(std::move(p));
    }
  }
  s.Finish();
  if (job.points.empty())
    throw InputError(s.WhereSelf() + ": the plan has no points (give csv or [[plan.point]])");

  // A planned point must have a defined azimuth: not on the tracker's vertical axis.
  if (!check_reach) return;
  // In chunks side by side; the first point out of reach in the plan's order is the one said.
  parallel_internal::ForEachChunk(job.points.size(), 4096, threads, [&](std::size_t, std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i) CheckReach(job, job.points[i]);
  });
}

// A reading's time (the time column), of the same kind as the file's first.
void ReadReadingTime(const std::string& field, double scale, const std::string& column, const Job& job,
                     JobPoint& p) {
  const TimeValue t = ParseTime(field, scale, p.where + ": " + column);
  if (!job.points.empty() && job.points.front().time_kind != t.kind) {
    throw InputError(p.where + ": " + column + ": " + std::string(TimeKindName(t.kind)) + " after " +
                     std::string(TimeKindName(job.points.front().time_kind)) +
                     " (one kind of time per file)");
  }
  p.time = t.seconds;
  p.time_kind = t.kind;
}

}  // namespace vlt::job_internal

namespace vlt {

// Tracker software writes angles in 0 .. 360 deg or -180 .. 180 deg; beyond two turns an angle is a
// unit or column mistake, and at 1e20 deg a double has no digits left below a turn (issue 32).
void CheckReadings(const std::array<double, 3>& r, const std::string& where,
                   const std::array<std::string, 3>& names) {
  for (int k = 0; k < 3; ++k) {
    if (!std::isfinite(r[static_cast<std::size_t>(k)]))
      throw InputError(where + ": " + names[static_cast<std::size_t>(k)] + ": not a finite number");
  }
  if (!(r[0] > 0.0)) throw InputError(where + ": range must be positive");
  if (r[0] > kMaxRange) {
    throw InputError(where + ": " + names[0] + ": " + FormatQuantity(r[0], Dimension::kLength, "m", 6) +
                     " is beyond any laser tracker (at most " +
                     FormatQuantity(kMaxRange, Dimension::kLength, "km", 3) + ")");
  }
  for (int k = 1; k < 3; ++k) {
    const double angle = r[static_cast<std::size_t>(k)];
    if (std::abs(angle) > 4.0 * std::numbers::pi) {
      throw InputError(where + ": " + names[static_cast<std::size_t>(k)] + ": " +
                       FormatQuantity(angle, Dimension::kAngle, "deg", 6) +
                       " is not a plausible angle (at most 720 deg either way)");
    }
  }
}

void CheckTrackerPoint(const std::array<double, 3>& p, const std::string& where) {
  const Eigen::Vector3d v(p[0], p[1], p[2]);
  if (!v.allFinite()) throw InputError(where + ": not a finite point");
  if (!(v.stableNorm() <= kMaxRange)) {
    throw InputError(where + ": " + FormatQuantity(v.stableNorm(), Dimension::kLength, "m", 6) +
                     " from the tracker is beyond any laser tracker (at most " +
                     FormatQuantity(kMaxRange, Dimension::kLength, "km", 3) + ")");
  }
}

void CheckValueMagnitude(double value, const std::string& where) {
  if (!std::isfinite(value) || std::abs(value) > base_internal::kMaxMagnitude) {
    throw InputError(where + ": beyond what vlt computes with (at most 1e12 in SI units)");
  }
}

}  // namespace vlt

namespace vlt::job_internal {

void ReadReadings(Section& s, Job& job, bool times_by_default) {
  s.set_hint("csv, coordinates, columns, units, vertical_angle");
  std::string rel = AsString(s.Require("csv"), s.Where("csv"));
  // Spherical readings (range, azimuth, elevation) as the tracker measured them, or Cartesian
  // coordinates (x, y, z) in the tracker (station) frame as tracker software exports them: those
  // are the tracker's readings through the ideal spherical-to-Cartesian conversion, so they are
  // converted back exactly (docs/job-file.md); the reading noise applies to the spherical readings.
  bool cartesian = false;
  if (const toml::node* n = s.Get("coordinates")) {
    const std::string v = AsString(*n, s.Where("coordinates"));
    if (v == "cartesian")
      cartesian = true;
    else if (v != "spherical")
      throw InputError(s.Where("coordinates") + ": expected \"spherical\" or \"cartesian\"");
  }
  static const char* const kSpherical[5] = {"name", "range", "azimuth", "elevation", "face"};
  static const char* const kCartesian[5] = {"name", "x", "y", "z", "face"};
  const char* const* keys = cartesian ? kCartesian : kSpherical;
  std::vector<std::string> names(keys, keys + 5);
  // An optional time column (docs/job-file.md): when each reading was taken, for a station's drift
  // model in a network. A job reads it only when columns.time names it (a "time" column of
  // another format in an existing export stays ignored).
  std::string time_name = "time", time_unit = "s";
  bool time_declared = false, face_declared = false;
  Section cols = s.Sub("columns", false);
  if (cols.exists()) {
    cols.set_hint(cartesian ? "name, x, y, z, face, time" : "name, range, azimuth, elevation, face, time");
    for (int k = 0; k < 5; ++k) {
      if (const toml::node* n = cols.Get(keys[k])) names[k] = AsString(*n, cols.Where(keys[k]));
    }
    face_declared = cols.Get("face") != nullptr;
    if (const toml::node* n = cols.Get("time")) {
      time_name = AsString(*n, cols.Where("time"));
      time_declared = true;
    }
    cols.Finish();
  }
  std::string units[3] = {"m", "rad", "rad"};
  Dimension dims[3] = {Dimension::kLength, Dimension::kAngle, Dimension::kAngle};
  if (cartesian) {
    units[1] = units[2] = "m";
    dims[1] = dims[2] = Dimension::kLength;
  }
  Section us = s.Sub("units", false);
  double scales[3];
  if (us.exists()) {
    us.set_hint(cartesian ? "x, y, z, time" : "range, azimuth, elevation, time");
    for (int k = 0; k < 3; ++k) {
      const toml::node* n = us.Get(keys[k + 1]);
      if (n == nullptr) continue;
      units[k] = AsString(*n, us.Where(keys[k + 1]));
      // An empty unit would be the bare SI unit (rad for an angle): a slip, not a choice.
      if (units[k].find_first_not_of(" \t") == std::string::npos) {
        throw InputError(us.Where(keys[k + 1]) + ": empty unit (e.g. \"" + (dims[k] == Dimension::kAngle ? "deg" : "mm") +
                         "\"; leave the key out for " + (dims[k] == Dimension::kAngle ? "rad" : "m") + ")");
      }
    }
    if (const toml::node* n = us.Get("time")) time_unit = AsString(*n, us.Where("time"));
    us.Finish();
  }
  const double time_scale = UnitScale(time_unit, Dimension::kTime, s.Where("units.time"));
  for (int k = 0; k < 3; ++k)
    scales[k] = UnitScale(units[k], dims[k], s.Where(std::string("units.") + keys[k + 1]));
  bool zenith = false;
  if (const toml::node* n = s.Get("vertical_angle"); n != nullptr && cartesian) {
    throw InputError(s.Where("vertical_angle") +
                     ": only for spherical readings (coordinates = \"cartesian\")");
  } else if (n != nullptr) {
    std::string v = AsString(*n, s.Where("vertical_angle"));
    if (v == "zenith")
      zenith = true;
    else if (v != "elevation")
      throw InputError(s.Where("vertical_angle") + ": expected \"elevation\" or \"zenith\"");
  }
  s.Finish();

  std::filesystem::path path = job.base_dir / rel;
  if (const std::string problem = InputFileProblem(path.string()); !problem.empty()) {
    throw InputError(s.Where("csv") + ": cannot read '" + path.string() + "': " + problem);
  }
  CsvTable table = ReadCsvFile(path.string(), path.string());
  rel = path.string();
  job.readings_file = rel;
  job.input_files.push_back({"readings csv", rel, Sha256File(rel)});
  int col[5];
  for (int k = 0; k < 5; ++k) {
    col[k] = table.Column(names[k]);
    // The face column is optional unless readings.columns.face names one.
    if (col[k] < 0 && (k < 4 || face_declared)) {
      throw InputError(rel + ": line " + std::to_string(table.header_line) + ": missing column '" + names[k] +
                       "' (declared by readings.columns." + keys[k] + ")");
    }
  }
  const int time_col = times_by_default || time_declared ? table.Column(time_name) : -1;
  if (time_col < 0 && time_declared) {
    throw InputError(rel + ": line " + std::to_string(table.header_line) + ": missing column '" + time_name +
                     "' (declared by readings.columns.time)");
  }
  job.points.reserve(job.points.size() + table.rows.size());  // no growth slack (a scan's 10^6 readings)
  for (const CsvRow& row : table.rows) {
    JobPoint p;
    p.where = table.Where(row);
    p.name = row.fields[col[0]];
    CheckName(p.name, p.where, "point");
    if (time_col >= 0) ReadReadingTime(row.fields[time_col], time_scale, time_name, job, p);
    double r[3];
    for (int k = 0; k < 3; ++k) {
      r[k] = CsvQuantity(row.fields[col[k + 1]], dims[k], scales[k], 0, p.where + ": " + names[k + 1]);
    }
    if (cartesian) {
      // The ideal tracker's readings of the point (vlt/inverse.h IdealReadings), in the face the
      // face column gives (front by default).
      const Face face = col[4] >= 0 && !row.fields[col[4]].empty()
                            ? ParseFaceField(row.fields[col[4]], p.where)
                            : Face::kFront;
      try {
        const std::array<double, 3> ideal = IdealReadings({r[0], r[1], r[2]}, face);
        r[0] = ideal[0];
        r[1] = ideal[1];
        r[2] = ideal[2];
      } catch (const NumericalError& e) {
        throw InputError(p.where + ": " + e.what());
      }
    }
    CheckReadings({r[0], r[1], r[2]}, p.where, {names[1], names[2], names[3]});
    double elevation = zenith ? kPi / 2 - r[2] : r[2];
    // Normalise the elevation into [-pi/2, 3pi/2): front face up to pi/2, back face beyond.
    elevation = std::fmod(elevation + kPi / 2, 2 * kPi);
    if (elevation < 0) elevation += 2 * kPi;
    elevation -= kPi / 2;
    Face face = elevation <= kPi / 2 + 1e-12 ? Face::kFront : Face::kBack;
    if (col[4] >= 0 && !row.fields[col[4]].empty()) {
      Face declared = ParseFaceField(row.fields[col[4]], p.where);
      if (declared != face) {
        throw InputError(p.where + ": face column says " + std::string(FaceName(declared)) +
                         " but the vertical angle is a " + std::string(FaceName(face)) + "-face reading");
      }
    }
    if (r[0] * std::abs(std::cos(elevation)) < kVerticalAxisTolerance) {
      throw InputError(p.where + ": " + names[3] +
                       ": the reading points along the tracker's standing axis "
                       "(elevation +-90 deg, zenith 0 or 180 deg): its azimuth is undefined");
    }
    p.face = face;
    p.readings = {r[0], r[1], elevation};
    job.points.push_back(std::move(p));
  }
  if (job.points.empty()) throw InputError(rel + ": no readings (only a header)");
}

}  // namespace vlt::job_internal
