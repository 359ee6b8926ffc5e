// base/decimal.h — a decimal number's text to a double (internal), as the CSV reader and
// ParseQuantity read every number a user writes.
#pragma once

#include <algorithm>
#include <charconv>
#include <cstdint>
#include <string_view>
#include <system_error>

namespace vlt::base_internal {

// std::from_chars (decimal: digits, a point, an exponent; no hex, inf or nan), except that a
// number too small for a double (1e-400: its correctly rounded value is 0, as strtod and Python
// give) reads as 0 instead of result_out_of_range, which then means too large only. The sign of
// such a zero is dropped: vlt writes no -0.
inline std::from_chars_result ParseDecimal(std::string_view text, double& value) {
  std::from_chars_result r = std::from_chars(text.data(), text.data() + text.size(), value);
  if (r.ec != std::errc::result_out_of_range) return r;
  // The matched literal [mantissa][e[+-]digits]: its decimal order of magnitude decides whether it
  // underflowed (order < 0) or overflowed.
  const std::string_view literal(text.data(), static_cast<std::size_t>(r.ptr - text.data()));
  const std::size_t e = literal.find_first_of("eE");
  const std::string_view mantissa = literal.substr(0, e);
  std::int64_t order = 0;  // the mantissa's: of its first nonzero digit
  const std::size_t point = std::min(mantissa.find('.'), mantissa.size());
  const std::size_t first = mantissa.find_first_of("123456789");
  if (first != std::string_view::npos) {
    order = first < point ? static_cast<std::int64_t>(point - first) - 1 : -static_cast<std::int64_t>(first - point);
  }
  bool tiny = order < 0;
  if (e != std::string_view::npos) {
    std::string_view exponent = literal.substr(e + 1);
    const bool negative = !exponent.empty() && exponent.front() == '-';
    if (!exponent.empty() && (exponent.front() == '-' || exponent.front() == '+')) exponent.remove_prefix(1);
    std::int64_t magnitude = 0;
    const std::errc ec = std::from_chars(exponent.data(), exponent.data() + exponent.size(), magnitude).ec;
    // An exponent far beyond the mantissa's order (which the text's length bounds) decides alone,
    // without an addition that could overflow; else the order of the whole number.
    constexpr std::int64_t kDecides = std::int64_t{1} << 40;
    tiny = ec == std::errc::result_out_of_range || magnitude > kDecides
               ? negative
               : order + (negative ? -magnitude : magnitude) < 0;
  }
  if (tiny) {
    value = 0.0;
    r.ec = std::errc();
  }
  return r;
}

}  // namespace vlt::base_internal
