// base/shared_settings.cc — the readers of the settings several capabilities share
// (base/shared_settings.h): one message per mistake, the same wording everywhere.
#include "base/shared_settings.h"

#include <cmath>
#include <optional>

#include <toml++/toml.h>

#include "vlt/error.h"
#include "vlt/units.h"

namespace vlt::base_internal {
namespace {

// The integer at `key`; nullopt when absent.
std::optional<std::int64_t> IntegerAt(Section& s, std::string_view key) {
  const toml::node* n = s.Get(key);
  if (!n) return std::nullopt;
  return AsInteger(*n, s.Where(key));
}

// An integer in minimum .. maximum, refused as "<where>: must be <minimum><zero_means> .. <maximum>".
bool ReadIntegerIn(Section& s, std::string_view key, std::int64_t minimum, std::int64_t maximum,
                   const std::string& zero_means, int& value) {
  const std::optional<std::int64_t> v = IntegerAt(s, key);
  if (!v) return false;
  if (*v < minimum || *v > maximum) {
    throw InputError(s.Where(key) + ": must be " + std::to_string(minimum) + zero_means + " .. " +
                     std::to_string(maximum));
  }
  value = static_cast<int>(*v);
  return true;
}

}  // namespace

bool ReadCoverageProbability(Section& s, std::string_view key, double& value) {
  const toml::node* n = s.Get(key);
  if (!n) return false;
  const double p = AsQuantity(*n, Dimension::kRatio, s.Where(key));
  if (!(p > 0.0 && p < 1.0)) {
    throw InputError(s.Where(key) + ": must be between 0 and 1 (e.g. 0.95 or \"95 %\")");
  }
  value = p;
  return true;
}

bool ReadSeed(Section& s, std::string_view key, std::uint64_t& value) {
  const std::optional<std::int64_t> v = IntegerAt(s, key);
  if (!v) return false;
  if (*v < 0) throw InputError(s.Where(key) + ": must be a non-negative integer");
  value = static_cast<std::uint64_t>(*v);
  return true;
}

bool ReadTrials(Section& s, std::string_view key, std::int64_t minimum, std::int64_t maximum,
                const std::string& why_minimum, std::int64_t& value) {
  const std::optional<std::int64_t> v = IntegerAt(s, key);
  if (!v) return false;
  if (*v < minimum) {
    throw InputError(s.Where(key) + ": at least " + std::to_string(minimum) + " trials" + why_minimum);
  }
  if (*v > maximum) throw InputError(s.Where(key) + ": at most " + std::to_string(maximum) + " trials");
  value = *v;
  return true;
}

bool ReadThreads(Section& s, std::string_view key, int& value) {
  return ReadIntegerIn(s, key, 0, 1024, " (all)", value);
}

bool ReadIterationLimit(Section& s, std::string_view key, int& value) {
  return ReadIntegerIn(s, key, 1, 10000, "", value);
}

bool ReadOutlierLimit(Section& s, std::string_view key, double& value) {
  const toml::node* n = s.Get(key);
  if (!n) return false;
  const double v = AsNumber(*n, s.Where(key));
  if (!(v > 0.0) || !std::isfinite(v)) throw InputError(s.Where(key) + ": must be positive");
  value = v;
  return true;
}

}  // namespace vlt::base_internal
