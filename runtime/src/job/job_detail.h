// job_detail.h — reading TOML tables strictly (internal to job*.cc).
#pragma once

#include <cstdint>
#include <set>
#include <string>
#include <string_view>

#include <toml++/toml.h>

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

}  // namespace vlt::job_detail
