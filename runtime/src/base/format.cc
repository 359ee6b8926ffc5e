// base/format.cc — numbers and text as vlt's files print them (base/format.h).
#include "base/format.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string_view>
#include <system_error>

#include "vlt/results.h"

namespace vlt::base_internal {

double Seconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

std::string FormatNode(const Eigen::Vector3d& node) {
  char buffer[96];
  std::snprintf(buffer, sizeof buffer, "(%.6g, %.6g, %.6g) m", node.x(), node.y(), node.z());
  return buffer;
}

// The old definition, kept as the specification: the first of "%.6g" ... "%.17g" that reads back
// as v. Computed directly: the shortest round-trip representation (std::to_chars, Ryu) has d
// significant digits, no p < d round-trips, so the answer is "%.{max(6, d)}g" unless that rounding
// falls outside v's rounding interval (possible next to a power of two), then one more digit.
// std::to_chars(general, p) is specified as printf's %.pg ([charconv.to.chars]).
void AppendNum(std::string& out, double v) {
  char buffer[40];
  if (!std::isfinite(v)) {
    std::snprintf(buffer, sizeof buffer, "%g", v);
    out += buffer;
    return;
  }
  auto shortest = std::to_chars(buffer, buffer + sizeof buffer, v, std::chars_format::scientific);
  int digits = 0;
  const char* e = buffer;
  for (; e < shortest.ptr && *e != 'e'; ++e) digits += (*e >= '0' && *e <= '9') ? 1 : 0;
  int exponent = 0;
  std::from_chars(e + 1 + (e[1] == '+' ? 1 : 0), shortest.ptr, exponent);
  // Away from a power of two the rounding interval is symmetric about v, and the closest
  // p-digit decimal (%.pg, p >= d) is then the shortest one padded with zeros, which %g strips:
  // "%.{max(6, d)}g" is the shortest digits laid out as %g lays them out (scientific when the
  // exponent is < -4 or >= the precision, else fixed). At a power of two (fraction bits all zero)
  // the interval below is half as wide, and subnormals are coarser: there %.pg is formatted and
  // read back for p = max(6, d) ... 17.
  std::uint64_t bits = 0;
  std::memcpy(&bits, &v, sizeof bits);
  const bool power_of_two = (bits & ((std::uint64_t{1} << 52) - 1)) == 0;
  // Subnormals have fewer significant bits: their interval can hold several 6-digit decimals.
  const bool subnormal = (bits & (std::uint64_t{0x7ff} << 52)) == 0;
  const int precision = std::max(6, digits);
  if (!power_of_two && !subnormal) {
    if (exponent < -4 || exponent >= precision) {
      out.append(buffer, shortest.ptr);
    } else {
      auto fixed = std::to_chars(buffer, buffer + sizeof buffer, v, std::chars_format::fixed);
      out.append(buffer, fixed.ptr);
    }
    return;
  }
  for (int p = precision; p <= 17; ++p) {
    auto end = std::to_chars(buffer, buffer + sizeof buffer, v, std::chars_format::general, p).ptr;
    double back = 0.0;
    std::from_chars(buffer, end, back);
    if (back == v || p == 17) {
      out.append(buffer, end);
      return;
    }
  }
}

std::string Num(double v) {
  std::string out;
  AppendNum(out, v);
  return out;
}

std::string Sig(double v, int digits) {
  char buffer[40];
  std::snprintf(buffer, sizeof buffer, "%.*g", digits, v);
  return buffer;
}

std::string HtmlEscape(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string HumanUnit(std::string_view ascii_unit) {
  std::string out;
  auto letter = [](char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_'; };
  for (std::size_t i = 0; i < ascii_unit.size(); ++i) {
    const bool word_start = i == 0 || !letter(ascii_unit[i - 1]);
    const bool word_end = i + 2 >= ascii_unit.size() || !letter(ascii_unit[i + 2]);
    if (word_start && word_end && ascii_unit.substr(i, 2) == "um") {
      out += "µm";
      ++i;
    } else {
      out += ascii_unit[i];
    }
  }
  return out;
}

std::string PadColumns(const std::string& text, int width, bool align_left) {
  int columns = 0;
  for (unsigned char c : text) columns += (c & 0xC0) != 0x80;  // UTF-8: one per lead byte
  std::string out;
  const std::size_t pad = width > columns ? static_cast<std::size_t>(width - columns) : 0;
  out.reserve(text.size() + pad);
  if (!align_left) out.append(pad, ' ');
  out.append(text);
  if (align_left) out.append(pad, ' ');
  return out;
}

std::string CsvField(const std::string& field) {
  if (field.find_first_of(",\"\n\r") == std::string::npos) return field;
  std::string out = "\"";
  for (char c : field) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + "\"";
}

void AppendDecimals(std::string& out, double v, int decimals) {
  char buffer[400];  // |v| < 1.8e308: 309 digits, the sign, the point and up to 17 decimals
  if (!std::isfinite(v)) {
    std::snprintf(buffer, sizeof buffer, "%g", v);
    out += buffer;
    return;
  }
  decimals = std::clamp(decimals, 0, 17);
  const auto written = std::to_chars(buffer, buffer + sizeof buffer, v, std::chars_format::fixed, decimals);
  char* end = written.ptr;
  if (decimals > 0) {
    while (end[-1] == '0') --end;
    if (end[-1] == '.') --end;
  }
  const bool negative_zero = buffer[0] == '-' && end - buffer == 2 && buffer[1] == '0';
  out.append(negative_zero ? buffer + 1 : buffer, end);
}

void AppendRoundedUp(std::string& out, double v, int digits) {
  if (!std::isfinite(v) || !(v > 0.0)) {
    AppendDecimals(out, v, 0);
    return;
  }
  const int magnitude = static_cast<int>(std::floor(std::log10(v)));
  const int decimals = std::clamp(digits - 1 - magnitude, 0, 17);
  const double scale = std::pow(10.0, decimals);  // exact: 10^d for d <= 22
  const double up = std::ceil(v * scale) / scale;
  char buffer[400];
  const auto written = std::to_chars(buffer, buffer + sizeof buffer, up, std::chars_format::fixed, decimals);
  out.append(buffer, written.ptr);
}

std::string ShownAt(double v, double scale, int decimals) {
  double shown = v * scale;
  if (decimals < 0) {
    const double step = std::pow(10.0, -decimals);
    shown = std::round(shown / step) * step;
    decimals = 0;
  }
  char buffer[400];
  const auto written =
      std::to_chars(buffer, buffer + sizeof buffer, shown, std::chars_format::fixed, decimals);
  if (written.ec != std::errc() || !std::isfinite(shown)) return Num(shown);  // too long, or not finite
  std::string text(buffer, written.ptr);
  if (text.find_first_not_of("-0.") == std::string::npos && text[0] == '-') text.erase(0, 1);  // no "-0.000"
  return text;
}

std::string ShortestAt(double v, double scale) {
  if (v == 0.0) return "0";
  const double shift = std::log10(scale);
  if (!std::isfinite(v) || shift != std::round(shift) || std::abs(shift) > 30) {
    char buffer[64];
    std::snprintf(buffer, sizeof buffer, "%.10g", v * scale);
    return buffer;
  }
  // Shortest round-trip digits and exponent: "-d.ddde+XX", at most 15 significant digits: a limit
  // typed in mm and held in m (300.05 mm is 0.30005000000000004 m) comes back as typed, since 15
  // decimal digits survive the trip through a double and the unit's rounding is far below them.
  char buffer[64];
  auto written = std::to_chars(buffer, buffer + sizeof buffer, v, std::chars_format::scientific);
  const std::string_view shortest(buffer, static_cast<std::size_t>(written.ptr - buffer));
  if (std::count_if(shortest.begin(), shortest.begin() + static_cast<std::ptrdiff_t>(shortest.find('e')),
                    [](char c) { return c >= '0' && c <= '9'; }) > 15) {
    written = std::to_chars(buffer, buffer + sizeof buffer, v, std::chars_format::scientific, 14);
  }
  std::string text(buffer, written.ptr);
  // Trailing zeros of the 15-digit form ("3.00050000000000e-01") are not digits of the limit.
  const std::size_t mantissa_end = text.find('e');
  std::size_t last = mantissa_end;
  while (last > 1 && text[last - 1] == '0') --last;
  if (last > 0 && text[last - 1] == '.') --last;
  text.erase(last, mantissa_end - last);
  const std::size_t e = text.find('e');
  std::string digits;
  for (std::size_t i = 0; i < e; ++i) {
    if (text[i] >= '0' && text[i] <= '9') digits += text[i];
  }
  const int exponent = std::stoi(text.substr(e + 1)) + static_cast<int>(std::round(shift));
  // digits d0 d1 ... with the decimal point after d0 times 10^exponent.
  std::string out = v < 0.0 ? "-" : "";
  if (exponent < -6 || exponent > 15) {
    // Beyond six leading zeros or fifteen digits: with an exponent (5e-12, 1.25e+20), as people
    // write such limits, not 0.000000000005.
    out += digits.substr(0, 1);
    if (digits.size() > 1) out += "." + digits.substr(1);
    return out + "e" + (exponent < 0 ? "-" : "+") + std::to_string(std::abs(exponent));
  }
  const int point = exponent + 1;  // digits before the decimal point
  if (point <= 0) {
    out += "0." + std::string(static_cast<std::size_t>(-point), '0') + digits;
  } else if (point >= static_cast<int>(digits.size())) {
    out += digits + std::string(static_cast<std::size_t>(point) - digits.size(), '0');
  } else {
    out += digits.substr(0, static_cast<std::size_t>(point)) + "." +
           digits.substr(static_cast<std::size_t>(point));
  }
  return out == "-0" ? "0" : out;
}

GumRounded RoundLikeGum(double value, double value_scale, double expanded, double expanded_scale) {
  GumRounded r;
  const double u_shown = expanded * expanded_scale;
  if (!(std::isfinite(u_shown) && u_shown >= std::numeric_limits<double>::min() && std::isfinite(value))) {
    // Nothing to round by (callers state such a U otherwise): the numbers as they are.
    r.value = Num(value * value_scale);
    r.expanded = Num(u_shown);
    r.value_decimals = 17;
    return r;
  }
  // The place of U's second significant digit, 10^place in the shown unit.
  int place = static_cast<int>(std::floor(std::log10(u_shown))) - 1;
  double step = std::pow(10.0, place);
  // Up to that place (7.2.6: "10.47 might be rounded up to 11"), but "common sense should prevail:
  // 28.05 should be rounded down to 28": an excess below 1/20 of the last digit is dropped (U is
  // then understated by less than 0.5 %).
  auto rounded = [&](double s) {
    const double units = u_shown / s;
    const double down = std::floor(units);
    return (units - down <= 0.05 + 1e-9 && down >= 10.0 ? down : std::ceil(units)) * s;
  };
  double up = rounded(step);
  if (up >= 100.0 * step) {  // 99.2 -> 100: three digits; keep two (100 = 1.0e2)
    ++place;
    step *= 10.0;
    up = rounded(step);
  }
  r.expanded = ShownAt(up, 1.0, -place);
  // The same decimal place in the value's unit: 10^place expanded units = 10^place * value_scale /
  // expanded_scale value units; the value's decimals reach at least that fine.
  const double value_step = step * value_scale / expanded_scale;
  r.value_decimals = static_cast<int>(std::ceil(-std::log10(value_step) - 1e-9));
  r.value = ShownAt(value, value_scale, r.value_decimals);
  return r;
}

std::string Fixed(double v, int decimals) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*f", decimals, v);
  std::string s = buffer;
  if (s.find_first_not_of("-0.") == std::string::npos && s[0] == '-') s.erase(0, 1);  // no "-0.00"
  return s;
}

std::string ScriptSafe(const std::string& text) {
  // Every '<' as the JSON escape \u003c (the same string once parsed; outside strings JSON has no
  // '<'): no "</script", "<!--" or "<script" can then change how the HTML parser reads the
  // element, whatever a name holds (issue 32).
  std::string safe;
  safe.reserve(text.size());
  for (const char c : text) {
    if (c == '<') {
      safe += "\\u003c";
    } else {
      safe += c;
    }
  }
  return safe;
}

std::string CssString(const std::string& text) {
  std::string css = "\"";
  for (const char c : text) {
    const auto u = static_cast<unsigned char>(c);
    const bool plain = u >= 0x80 || std::isalnum(u) || std::string_view(" -_.,:()/+").find(c) != std::string_view::npos;
    if (plain) {
      css += c;
    } else {
      char hex[8];
      std::snprintf(hex, sizeof hex, "\\%x ", u);  // CSS 2.1 4.1.3: a hex escape ends at the space
      css += hex;
    }
  }
  return css + "\"";
}

}  // namespace vlt::base_internal

namespace vlt {

// The public name (vlt/results.h): the default output directory of a job is named after it.
std::string SafeFileName(const std::string& name) {
  std::string out;
  for (char c : name) {
    bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' ||
              c == '_' || c == '-';
    out += ok ? c : '_';
  }
  if (out.empty() || out == "." || out == "..") out = "job";
  return out;
}

}  // namespace vlt
