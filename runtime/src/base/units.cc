// base/units.cc — conversion of "<number> <unit>" strings to vlt's internal SI representation.
//
// Every factor is an exact definition (SI Brochure, 9th ed., tables 4 and 8; the conventional
// millimetre of mercury 133.322387415 Pa; the inch 0.0254 m, 1959 agreement) so that the
// conversions add no uncertainty of their own.
#include "vlt/units.h"

#include <array>
#include <charconv>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include "base/decimal.h"
#include "vlt/error.h"

namespace vlt {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kZeroCelsiusInKelvin = 273.15;  // SI Brochure 2.3.1: t/degC = T/K - 273.15

// si = value * factor + offset  (offset is non-zero only for kelvin -> degC).
struct UnitDef {
  Dimension dimension;
  std::string_view name;  // ASCII spelling; see Canonical() for the Unicode spellings
  double factor;
  double offset = 0.0;
};

// Order matters for messages only: a unit found under several dimensions ("%", "K", "1") is
// reported as the first one listed when it appears under the wrong key.
constexpr UnitDef kUnits[] = {
    // Length, m
    {Dimension::kLength, "m", 1.0},
    {Dimension::kLength, "mm", 1e-3},
    {Dimension::kLength, "um", 1e-6},
    {Dimension::kLength, "nm", 1e-9},
    {Dimension::kLength, "cm", 1e-2},
    {Dimension::kLength, "km", 1e3},
    {Dimension::kLength, "in", 0.0254},
    // Angle, rad
    {Dimension::kAngle, "rad", 1.0},
    {Dimension::kAngle, "mrad", 1e-3},
    {Dimension::kAngle, "urad", 1e-6},
    {Dimension::kAngle, "nrad", 1e-9},
    {Dimension::kAngle, "deg", kPi / 180.0},
    {Dimension::kAngle, "arcmin", kPi / 10800.0},
    {Dimension::kAngle, "arcsec", kPi / 648000.0},
    {Dimension::kAngle, "gon", kPi / 200.0},
    {Dimension::kAngle, "mgon", kPi / 200000.0},
    // Ratio (scale factor, length per length), 1
    {Dimension::kRatio, "1", 1.0},
    {Dimension::kRatio, "m/m", 1.0},
    {Dimension::kRatio, "%", 1e-2},
    {Dimension::kRatio, "ppm", 1e-6},
    {Dimension::kRatio, "ppb", 1e-9},
    {Dimension::kRatio, "mm/m", 1e-3},
    {Dimension::kRatio, "um/m", 1e-6},
    {Dimension::kRatio, "nm/m", 1e-9},
    // Temperature (absolute, expressed in degC)
    {Dimension::kTemperature, "degC", 1.0},
    {Dimension::kTemperature, "K", 1.0, -kZeroCelsiusInKelvin},
    // Temperature difference, K
    {Dimension::kTemperatureDifference, "K", 1.0},
    {Dimension::kTemperatureDifference, "mK", 1e-3},
    {Dimension::kTemperatureDifference, "degC", 1.0},
    // Pressure, Pa
    {Dimension::kPressure, "Pa", 1.0},
    {Dimension::kPressure, "hPa", 1e2},
    {Dimension::kPressure, "kPa", 1e3},
    {Dimension::kPressure, "MPa", 1e6},
    {Dimension::kPressure, "mbar", 1e2},
    {Dimension::kPressure, "bar", 1e5},
    {Dimension::kPressure, "mmHg", 133.322387415},
    {Dimension::kPressure, "Torr", 101325.0 / 760.0},
    // Relative humidity, % RH
    {Dimension::kHumidity, "%", 1.0},
    {Dimension::kHumidity, "%RH", 1.0},
    // Mole fraction (CO2), 1
    {Dimension::kFraction, "1", 1.0},
    {Dimension::kFraction, "mol/mol", 1.0},
    {Dimension::kFraction, "%", 1e-2},
    {Dimension::kFraction, "ppm", 1e-6},
    {Dimension::kFraction, "umol/mol", 1e-6},
    {Dimension::kFraction, "ppb", 1e-9},
    {Dimension::kFraction, "nmol/mol", 1e-9},
    // Expansion coefficient, 1/K
    {Dimension::kPerKelvin, "1/K", 1.0},
    {Dimension::kPerKelvin, "/K", 1.0},
    {Dimension::kPerKelvin, "ppm/K", 1e-6},
    {Dimension::kPerKelvin, "ppb/K", 1e-9},
    {Dimension::kPerKelvin, "um/m/K", 1e-6},
    {Dimension::kPerKelvin, "1/degC", 1.0},
    {Dimension::kPerKelvin, "/degC", 1.0},
    {Dimension::kPerKelvin, "ppm/degC", 1e-6},
    {Dimension::kPerKelvin, "um/m/degC", 1e-6},
    // Dimensionless
    {Dimension::kDimensionless, "1", 1.0},
    // Time, s
    {Dimension::kTime, "s", 1.0},
    {Dimension::kTime, "ms", 1e-3},
    {Dimension::kTime, "us", 1e-6},
    {Dimension::kTime, "min", 60.0},
    {Dimension::kTime, "h", 3600.0},
};

constexpr Dimension kAllDimensions[] = {
    Dimension::kLength,
    Dimension::kAngle,
    Dimension::kRatio,
    Dimension::kTemperature,
    Dimension::kTemperatureDifference,
    Dimension::kPressure,
    Dimension::kHumidity,
    Dimension::kFraction,
    Dimension::kPerKelvin,
    Dimension::kDimensionless,
    Dimension::kTime,
};

// The ASCII spelling of a unit: micro sign (U+00B5) and Greek mu (U+03BC) -> "u",
// "°C" -> "degC", "°" -> "deg", blanks inside "% RH" removed.
std::string Canonical(std::string_view unit) {
  std::string out;
  for (std::size_t i = 0; i < unit.size(); ++i) {
    const std::string_view rest = unit.substr(i);
    if (rest.starts_with("\xC2\xB5") || rest.starts_with("\xCE\xBC")) {
      out += 'u';
      ++i;
    } else if (rest.starts_with("\xC2\xB0"
                                "C")) {
      out += "degC";
      i += 2;
    } else if (rest.starts_with("\xC2\xB0")) {
      out += "deg";
      ++i;
    } else if (unit[i] != ' ' && unit[i] != '\t') {
      out += unit[i];
    }
  }
  return out;
}

const UnitDef* Find(std::string_view canonical, Dimension dimension) {
  for (const UnitDef& u : kUnits) {
    if (u.dimension == dimension && u.name == canonical) return &u;
  }
  return nullptr;
}

const UnitDef& FindOrThrow(std::string_view unit, Dimension dimension) {
  const UnitDef* u = Find(Canonical(unit), dimension);
  if (u == nullptr) {
    throw std::invalid_argument("vlt::units: '" + std::string(unit) + "' is not a unit of " +
                                std::string(DimensionName(dimension)));
  }
  return *u;
}

std::string WithArticle(std::string_view noun) {
  const bool vowel = !noun.empty() && std::string_view("aeiou").find(noun[0]) != std::string_view::npos;
  return std::string(vowel ? "an " : "a ") + std::string(noun);
}

std::string UnitList(Dimension dimension) {
  std::string list;
  for (std::string_view name : AcceptedUnits(dimension)) {
    if (!list.empty()) list += ", ";
    list += name;
  }
  return list;
}

std::string_view Trim(std::string_view s) {
  const auto blank = [](char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; };
  while (!s.empty() && blank(s.front())) s.remove_prefix(1);
  while (!s.empty() && blank(s.back())) s.remove_suffix(1);
  return s;
}

bool IsDigit(char c) { return c >= '0' && c <= '9'; }

// Length of the decimal literal at the start of `s` ([+-] digits [. digits] [e [+-] digits],
// at least one mantissa digit), or 0 when there is none or its exponent is incomplete.
std::size_t NumberLength(std::string_view s) {
  std::size_t i = 0;
  if (i < s.size() && (s[i] == '+' || s[i] == '-')) ++i;
  std::size_t digits = 0;
  while (i < s.size() && IsDigit(s[i])) ++i, ++digits;
  if (i < s.size() && s[i] == '.') {
    ++i;
    while (i < s.size() && IsDigit(s[i])) ++i, ++digits;
  }
  if (digits == 0) return 0;
  if (i < s.size() && (s[i] == 'e' || s[i] == 'E')) {
    std::size_t j = i + 1;
    if (j < s.size() && (s[j] == '+' || s[j] == '-')) ++j;
    std::size_t exp_digits = 0;
    while (j < s.size() && IsDigit(s[j])) ++j, ++exp_digits;
    if (exp_digits == 0) return 0;  // "1e" / "1e+": malformed, not "1" with unit "e"
    i = j;
  }
  return i;
}

}  // namespace

std::string_view TimeKindName(TimeKind kind) {
  switch (kind) {
    case TimeKind::kSeconds: return "seconds";
    case TimeKind::kClockTime: return "a clock time";
    case TimeKind::kDateTime: return "a date and time";
  }
  return "seconds";
}

std::string_view DimensionName(Dimension dimension) {
  switch (dimension) {
    case Dimension::kLength: return "length";
    case Dimension::kAngle: return "angle";
    case Dimension::kRatio: return "ratio";
    case Dimension::kTemperature: return "temperature";
    case Dimension::kTemperatureDifference: return "temperature difference";
    case Dimension::kPressure: return "pressure";
    case Dimension::kHumidity: return "humidity";
    case Dimension::kFraction: return "fraction";
    case Dimension::kPerKelvin: return "expansion coefficient";
    case Dimension::kDimensionless: return "dimensionless";
    case Dimension::kTime: return "time";
  }
  return "unknown";
}

std::string_view SiUnit(Dimension dimension) {
  switch (dimension) {
    case Dimension::kLength: return "m";
    case Dimension::kAngle: return "rad";
    case Dimension::kRatio: return "1";
    case Dimension::kTemperature: return "degC";
    case Dimension::kTemperatureDifference: return "K";
    case Dimension::kPressure: return "Pa";
    case Dimension::kHumidity: return "%";
    case Dimension::kFraction: return "1";
    case Dimension::kPerKelvin: return "1/K";
    case Dimension::kDimensionless: return "1";
    case Dimension::kTime: return "s";
  }
  return "1";
}

std::span<const std::string_view> AcceptedUnits(Dimension dimension) {
  // Built once from kUnits, one list per dimension, in table order.
  static const std::array<std::vector<std::string_view>, std::size(kAllDimensions)> lists = [] {
    std::array<std::vector<std::string_view>, std::size(kAllDimensions)> l;
    for (const UnitDef& u : kUnits) l[static_cast<std::size_t>(u.dimension)].push_back(u.name);
    return l;
  }();
  return lists[static_cast<std::size_t>(dimension)];
}

double ParseQuantity(std::string_view text, Dimension expected, std::string_view where) {
  const std::string_view trimmed = Trim(text);
  // Built with append: GCC 12 reports a false -Wrestrict for "literal" + std::string.
  std::string quoted(1, '\'');
  quoted.append(trimmed).push_back('\'');
  std::string prefix(where);
  prefix.append(": ");
  if (trimmed.empty()) {
    throw InputError(prefix + "empty value, expected " + WithArticle(DimensionName(expected)) + " (e.g. '1 " +
                     std::string(SiUnit(expected)) + "')");
  }
  const std::size_t length = NumberLength(trimmed);
  if (length == 0) {
    throw InputError(prefix + quoted + " does not start with a number, expected " +
                     WithArticle(DimensionName(expected)) + " such as '1.5 " +
                     std::string(AcceptedUnits(expected).front()) + "'");
  }
  std::string_view number = trimmed.substr(0, length);
  const std::string_view unit = Trim(trimmed.substr(length));
  if (number.front() == '+') number.remove_prefix(1);  // from_chars takes no '+'
  double value = 0.0;
  const auto [end, ec] = base_internal::ParseDecimal(number, value);
  if (ec == std::errc::result_out_of_range || !std::isfinite(value)) {
    throw InputError(prefix + quoted + " is out of the range of finite numbers");
  }
  if (ec != std::errc() || end != number.data() + number.size()) {
    throw InputError(prefix + quoted + " is not a valid number");
  }

  double si = value;  // a bare number is already in the internal representation
  if (!unit.empty()) {
    const std::string canonical = Canonical(unit);
    const UnitDef* def = Find(canonical, expected);
    if (def == nullptr) {
      for (Dimension other : kAllDimensions) {
        if (Find(canonical, other) != nullptr) {
          throw InputError(prefix + quoted + " is " + WithArticle(DimensionName(other)) + ", expected " +
                           WithArticle(DimensionName(expected)) + " (" + UnitList(expected) + ")");
        }
      }
      throw InputError(prefix + "unknown unit '" + std::string(unit) + "' in " + quoted + "; " +
                       WithArticle(DimensionName(expected)) + " takes " + UnitList(expected));
    }
    si = value * def->factor + def->offset;
  }
  if (!std::isfinite(si)) {
    throw InputError(prefix + quoted + " is out of the range of finite numbers");
  }
  if (expected == Dimension::kTemperature && si < -kZeroCelsiusInKelvin) {
    throw InputError(prefix + quoted + " is below absolute zero (-273.15 degC)");
  }
  return si;
}

double FromSi(double si, Dimension dimension, std::string_view unit) {
  const UnitDef& u = FindOrThrow(unit, dimension);
  return (si - u.offset) / u.factor;
}

double ToSi(double value, Dimension dimension, std::string_view unit) {
  const UnitDef& u = FindOrThrow(unit, dimension);
  return value * u.factor + u.offset;
}

std::string FormatQuantity(double si, Dimension dimension, std::string_view unit, int significant_digits) {
  if (unit.empty()) unit = SiUnit(dimension);
  const double value = FromSi(si, dimension, unit);
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*g", significant_digits < 1 ? 1 : significant_digits, value);
  return std::string(buffer) + " " + std::string(unit);
}

std::string FormatReadable(double si, Dimension dimension) {
  const double a = std::abs(si);
  switch (dimension) {
    case Dimension::kLength:
      return a >= 1e-3 ? FormatQuantity(si, dimension, "mm", 12) : FormatQuantity(si, dimension, "µm", 4);
    case Dimension::kAngle:
      return a >= 3.14159265358979323846 / 180.0 ? FormatQuantity(si, dimension, "deg", 8)
                                                 : FormatQuantity(si, dimension, "arcsec", 4);
    case Dimension::kRatio:
    case Dimension::kFraction: return FormatQuantity(si, dimension, "ppm", 4);
    case Dimension::kPerKelvin: return FormatQuantity(si, dimension, "ppm/K", 4);
    case Dimension::kPressure: return FormatQuantity(si, dimension, "hPa", 6);
    case Dimension::kTemperature: return FormatQuantity(si, dimension, "degC", 6);
    case Dimension::kTemperatureDifference: return FormatQuantity(si, dimension, "K", 4);
    case Dimension::kHumidity: return FormatQuantity(si, dimension, "%", 4);
    default: return FormatQuantity(si, dimension, {}, 6);
  }
}

std::string TypedUnit(std::string_view text) {
  std::size_t i = 0;
  while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
  if (i < text.size() && (text[i] == '+' || text[i] == '-')) ++i;
  while (i < text.size() && (std::isdigit(static_cast<unsigned char>(text[i])) || text[i] == '.')) ++i;
  if (i < text.size() && (text[i] == 'e' || text[i] == 'E') && i + 1 < text.size() &&
      (std::isdigit(static_cast<unsigned char>(text[i + 1])) || text[i + 1] == '-' || text[i + 1] == '+')) {
    i += 2;
    while (i < text.size() && std::isdigit(static_cast<unsigned char>(text[i]))) ++i;
  }
  std::size_t end = text.size();
  while (end > i && std::isspace(static_cast<unsigned char>(text[end - 1]))) --end;
  while (i < end && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
  return std::string(text.substr(i, end - i));
}

}  // namespace vlt
