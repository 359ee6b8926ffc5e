// job/job_detail.h — internal to runtime/src/job/: reading TOML tables strictly (section.cc) and one
// reader per group of job-file sections, called in order by ParseJob (job.cc).
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include <toml++/toml.h>

#include "vlt/error.h"
#include "vlt/job.h"
#include "vlt/units.h"

namespace vlt::job_detail {

// One TOML table being read. Every key looked up is remembered; Finish() rejects the rest as
// unknown keys, so that a misspelt key cannot be silently ignored. Messages name
// "<file>: <dotted.key.path>".
class Section {
 public:
  Section(std::string file, std::string path) : file_(std::move(file)), path_(std::move(path)) {}
  Section(const toml::table& table, std::string file, std::string path)
      : table_(&table), file_(std::move(file)), path_(std::move(path)) {}

  bool exists() const { return table_ != nullptr; }
  const toml::table& table() const { return *table_; }
  const std::string& path() const { return path_; }
  void set_hint(std::string hint) { allowed_hint_ = std::move(hint); }

  std::string Where(std::string_view key) const;  // "<file>: <path>.<key>"
  std::string WhereSelf() const;                  // "<file>: <path>"
  const toml::node* Get(std::string_view key);    // nullptr when absent
  const toml::node& Require(std::string_view key);
  Section Sub(std::string_view key, bool required);  // a nested table
  void Finish() const;                            // unknown keys -> InputError

 private:
  const toml::table* table_ = nullptr;
  std::string file_;
  std::string path_;
  std::string allowed_hint_;
  std::set<std::string> used_;
};

std::string AsString(const toml::node& node, const std::string& where);
bool AsBool(const toml::node& node, const std::string& where);
std::int64_t AsInteger(const toml::node& node, const std::string& where);
double AsNumber(const toml::node& node, const std::string& where);
// A string with a unit ("12 um") or a number already in the SI representation.
double AsQuantity(const toml::node& node, Dimension dimension, const std::string& where);
// QuantityInfo::quantity ("length", "angle", ...) -> Dimension.
Dimension DimensionOfQuantity(std::string_view quantity, const std::string& where);

// A TOML document; InputError "<file>: line L, column C: TOML syntax error: ..." (section.cc).
toml::table ParseToml(std::string_view text, const std::string& file);
// The bytes of a file; InputError "<path>: cannot read <what>".
std::string ReadTextFile(const std::string& path, const std::string& what);
// The directory relative paths inside the file at `path` resolve against ("." for a bare name).
std::filesystem::path BaseDirectory(const std::string& path);
// A CSV field: a bare decimal number (in the column's unit: value * unit_scale + unit_offset; no
// hex floats, inf or nan) or, when `dim` is given, a quantity with its own unit (points.cc).
double CsvQuantity(const std::string& field, std::optional<Dimension> dim, double unit_scale,
                   double unit_offset, const std::string& where);
// "5 um + 0.5 um/m" -> (a [m], b [m/m]); either term may be absent (instrument.cc).
void ParseLengthPlusRatio(const std::string& text, const std::string& where, double& a, double& b);

// Largest |estimate| and u of an uncertain input in SI units: beyond it squares and sums of
// sensitivities overflow long before a result is meaningful.
inline constexpr double kMaxMagnitude = 1e12;

// Uncertain inputs (section.cc).
void CheckUncertainty(double u, const std::string& where);  // finite and >= 0
// Canonical distribution name; rejects a shape parameter the distribution does not have.
void CheckDistribution(UncertainInput& input, const std::string& where_distribution,
                       const std::string& where_shape);
// An uncertain input: either a table {estimate, u, distribution, shape} (omitted keys keep the
// defaults in `input`) or a bare quantity (the estimate; u keeps its default).
void ReadUncertain(Section& parent, std::string_view key, Dimension value_dim, Dimension u_dim,
                   UncertainInput& input);
UncertainInput MakeInput(std::string name, std::string group, Dimension dim, double estimate, double u);

// One [<...>.correlations.<name>] table: `<inputs_key>` = [names] and matrix = [[...]]; the
// meaning is checked by SharedCorrelation (vlt/measurement_model.h) with the other groups.
CorrelationGroup ReadCorrelationGroup(Section& parent, const std::string& name, const std::string& inputs_key);

// [job] name, description (optional; the name defaults to `default_name`); job.cc.
void ReadJobMeta(Section& top, std::string& name, std::string* description, const std::string& default_name);

// Array of tables `key` of `top` (absent: empty), each visited as a Section "<key>[i]" and
// finished after `fn` (unknown keys are errors).
template <typename Fn>
void ForEachTable(Section& top, const std::string& file, std::string_view key, Fn&& fn) {
  const toml::node* n = top.Get(key);
  if (!n) return;
  if (!n->is_array()) throw InputError(top.Where(key) + ": expected [[" + std::string(key) + "]] tables");
  int index = 0;
  for (const toml::node& e : *n->as_array()) {
    const std::string path = std::string(key) + "[" + std::to_string(index++) + "]";
    if (!e.is_table()) throw InputError(file + ": " + path + ": expected a table");
    Section s(*e.as_table(), file, path);
    fn(s);
    s.Finish();
  }
}

// The readers of the job file's sections, one file per group.
void ReadTracker(Section& top, Job& job);      // instrument.cc: [tracker]
void ReadEnvironment(Section& top, Job& job);  // instrument.cc: [environment]
void ReadStation(Section& top, Job& job);      // instrument.cc: [station]
void ReadPart(Section& top, Job& job);         // instrument.cc: [part]
void ReadCorrelations(Section& top, Job& job); // instrument.cc: [correlations] (after the above)
// points.cc: [plan]; check_reach: every point within range of the job's station and off its
// vertical axis (a network's [targets] are checked per station instead).
void ReadPlan(Section& plan, Job& job, bool check_reach = true);
void ReadReadings(Section& readings, Job& job);  // points.cc: [readings]
void ReadTasks(Section& top, Job& job);        // tasks.cc: [[task]]
void ReadMonteCarlo(Section& top, MonteCarloSettings& settings);  // settings.cc: [monte_carlo]
// "a,b,c,d" or an array of numbers / quantity strings, as one comma-separated text (settings.cc).
std::string ExtentString(const toml::node& node, const std::string& where);
// Exactly `count` lengths [m] from such a text or array (bare numbers are metres).
std::vector<double> LengthList(const toml::node& node, std::size_t count, const std::string& where);
void ReadMap(Section& top, Job& job);          // settings.cc: [map]
void ReadOptimize(Section& top, Job& job);     // optimize.cc: [optimize] (after the tasks)
void ReadOutput(Section& top, OutputSettings& output);  // settings.cc: [output]

}  // namespace vlt::job_detail
