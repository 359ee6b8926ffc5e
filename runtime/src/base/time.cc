// base/time.cc — ParseTime (base/time.h).
#include "base/time.h"

#include <cctype>
#include <chrono>
#include <cmath>
#include <optional>

#include "base/csv.h"
#include "vlt/error.h"
#include "vlt/units.h"

namespace vlt::base_internal {

namespace {

// A run of exactly `digits` decimal digits at `at`, advancing it.
std::optional<int> Digits(std::string_view text, std::size_t& at, std::size_t digits) {
  if (at + digits > text.size()) return std::nullopt;
  int value = 0;
  for (std::size_t k = 0; k < digits; ++k) {
    const char c = text[at + k];
    if (!std::isdigit(static_cast<unsigned char>(c))) return std::nullopt;
    value = 10 * value + (c - '0');
  }
  at += digits;
  return value;
}

bool Take(std::string_view text, std::size_t& at, char c) {
  if (at < text.size() && text[at] == c) {
    ++at;
    return true;
  }
  return false;
}

// "HH:MM[:SS[.fff]]" from `at`: seconds since midnight; nullopt when it is not one.
std::optional<double> ClockTime(std::string_view text, std::size_t& at) {
  const auto hours = Digits(text, at, 2);
  if (!hours || !Take(text, at, ':')) return std::nullopt;
  const auto minutes = Digits(text, at, 2);
  if (!minutes || *hours > 23 || *minutes > 59) return std::nullopt;
  double seconds = 0.0;
  if (Take(text, at, ':')) {
    const auto whole = Digits(text, at, 2);
    if (!whole || *whole > 60) return std::nullopt;  // 60: a leap second
    seconds = *whole;
    if (Take(text, at, '.')) {
      double scale = 0.1;
      const std::size_t start = at;
      while (at < text.size() && std::isdigit(static_cast<unsigned char>(text[at]))) {
        seconds += scale * (text[at++] - '0');
        scale *= 0.1;
      }
      if (at == start) return std::nullopt;
    }
  }
  return 3600.0 * *hours + 60.0 * *minutes + seconds;
}

// "Z" or "+HH:MM" / "-HH:MM" / "+HHMM": the offset from UTC in seconds; 0 at the end of the text.
std::optional<double> ZoneOffset(std::string_view text, std::size_t& at) {
  if (at == text.size() || Take(text, at, 'Z') || Take(text, at, 'z')) return 0.0;
  const char sign = text[at];
  if (sign != '+' && sign != '-') return std::nullopt;
  ++at;
  const auto hours = Digits(text, at, 2);
  Take(text, at, ':');
  const auto minutes = Digits(text, at, 2);
  if (!hours || !minutes || *hours > 23 || *minutes > 59) return std::nullopt;
  const double offset = 3600.0 * *hours + 60.0 * *minutes;
  return sign == '+' ? offset : -offset;
}

// "YYYY-MM-DD[T ]HH:MM[:SS[.fff]][zone]": seconds since 1970-01-01 (UTC with a zone).
std::optional<double> DateTime(std::string_view text) {
  std::size_t at = 0;
  const auto year = Digits(text, at, 4);
  if (!year || !Take(text, at, '-')) return std::nullopt;
  const auto month = Digits(text, at, 2);
  if (!month || !Take(text, at, '-')) return std::nullopt;
  const auto day = Digits(text, at, 2);
  if (!day) return std::nullopt;
  const std::chrono::year_month_day date{std::chrono::year{*year},
                                         std::chrono::month{static_cast<unsigned>(*month)},
                                         std::chrono::day{static_cast<unsigned>(*day)}};
  if (!date.ok()) return std::nullopt;
  if (!Take(text, at, 'T') && !Take(text, at, 't') && !Take(text, at, ' ')) return std::nullopt;
  const auto clock = ClockTime(text, at);
  if (!clock) return std::nullopt;
  const auto zone = ZoneOffset(text, at);
  if (!zone || at != text.size()) return std::nullopt;
  const double days = static_cast<double>(std::chrono::sys_days{date}.time_since_epoch().count());
  return 86400.0 * days + *clock - *zone;
}

}  // namespace

TimeValue ParseTime(std::string_view text, double unit_scale, const std::string& where) {
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.front()))) text.remove_prefix(1);
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back()))) text.remove_suffix(1);
  if (text.empty()) throw InputError(where + ": empty time");
  if (const auto absolute = DateTime(text)) return {*absolute, TimeKind::kDateTime};
  std::size_t at = 0;
  if (const auto clock = ClockTime(text, at); clock && at == text.size()) return {*clock, TimeKind::kClockTime};
  // A number in the column's unit, or a quantity with its own unit ("90 min").
  double seconds = 0.0;
  try {
    seconds = CsvQuantity(std::string(text), Dimension::kTime, unit_scale, 0.0, where);
  } catch (const InputError&) {
    throw InputError(where + ": '" + std::string(text) +
                     "' is not a time (seconds, \"90 min\", \"10:15:30\" or \"2026-11-26T10:15:30\")");
  }
  if (!std::isfinite(seconds) || std::abs(seconds) > 1e10)
    throw InputError(where + ": not a plausible time");
  return {seconds, TimeKind::kSeconds};
}

}  // namespace vlt::base_internal
