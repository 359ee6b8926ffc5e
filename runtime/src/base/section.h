// base/section.h — reading TOML tables strictly, for every reader of vlt's input files (job,
// custom-model job, calibration and network files): one Section per table, every key looked up
// remembered and the rest rejected; values with units; uncertain inputs; tables of tables.
#pragma once

#include <cstdint>
#include <filesystem>
#include <set>
#include <string>
#include <string_view>

#include <toml++/toml.h>

#include "vlt/error.h"
#include "vlt/job.h"
#include "vlt/units.h"

namespace vlt::base_internal {

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
  void Finish() const;                               // unknown keys -> InputError

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

// A name of the job's (a point, a task, a station, a target, ...): InputError "<where>: empty
// <what> name" when empty, and when it holds a control or layout character (a line break, a tab,
// an escape sequence, a bidirectional override: base/section.cc HasControlCharacter), which would
// break a summary's line or a CSV row, or forge what a reader sees.
void CheckName(std::string_view name, const std::string& where, std::string_view what);

// A TOML document; InputError "<file>: line L, column C: TOML syntax error: ..." (base/section.cc).
toml::table ParseToml(std::string_view text, const std::string& file);
// The bytes of a file; InputError "<path>: cannot read <what>".
std::string ReadTextFile(const std::string& path, const std::string& what);
// The directory relative paths inside the file at `path` resolve against ("." for a bare name).
std::filesystem::path BaseDirectory(const std::string& path);

// Largest |estimate| and u of an uncertain input in SI units: beyond it squares and sums of
// sensitivities overflow long before a result is meaningful.
inline constexpr double kMaxMagnitude = 1e12;

// Uncertain inputs (base/section.cc).
void CheckUncertainty(double u, const std::string& where);  // finite and >= 0
// Canonical distribution name; rejects a shape parameter the distribution does not have.
void CheckDistribution(UncertainInput& input, const std::string& where_distribution,
                       const std::string& where_shape);
// An uncertain input: either a table {estimate, u, distribution, shape} (omitted keys keep the
// defaults in `input`) or a bare quantity (the estimate; u keeps its default).
void ReadUncertain(Section& parent, std::string_view key, Dimension value_dim, Dimension u_dim,
                   UncertainInput& input);
UncertainInput MakeInput(std::string name, std::string group, Dimension dim, double estimate, double u);

// A one-line text (a record item, a source's citation): a string without control, line-break or
// bidirectional-override characters; "" when the key is absent.
std::string RecordText(Section& s, std::string_view key);

// [job] name, description (optional; the name defaults to `default_name`); base/section.cc.
// record: the job's administrative items ([job] customer, operator, place, conditions and
// [job.instrument] make, model, serial; vlt/job_record.h), one-line texts; nullptr: a job kind
// that has none (those keys are then unknown keys).
void ReadJobMeta(Section& top, std::string& name, std::string* description, const std::string& default_name,
                 JobRecord* record = nullptr);

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

}  // namespace vlt::base_internal
