// vlt/units.h — quantities with units in job files ("12 um", "0.8 arcsec", "20 degC").
//
// Every value vlt reads from a user is converted here to the SI representation used internally
// (docs/units.md): metres, radians, ratios as plain numbers, temperatures in degC, temperature
// differences in K, pressures in Pa, relative humidity in % (0..100), CO2 as a mole fraction,
// expansion coefficients in 1/K. A bare number (no unit) is already in that representation.
//
// Parsing is strict: a unit of the wrong dimension, an unknown unit, a malformed or non-finite
// number, or an absolute temperature below 0 K is an InputError whose one-line message starts
// with `where` (the file and key, e.g. "job.toml: tracker.noise.azimuth").
#pragma once

#include <span>
#include <string>
#include <string_view>

namespace vlt {

// The kind of quantity a key expects. The comment gives the internal (SI) representation and the
// units accepted; ASCII "u" and the micro sign / Greek mu are interchangeable for "micro".
enum class Dimension {
  kLength,                 // m      | m, mm, um, µm, nm, cm, km, in (exactly 0.0254 m)
  kAngle,                  // rad    | rad, mrad, urad, µrad, nrad, deg, °, arcmin, arcsec, gon, mgon
  kRatio,                  // 1      | 1, m/m, %, ppm, ppb, mm/m, um/m, µm/m, nm/m  (scale factors,
                           //          length per length; "10 ppm" = "10 um/m" = 1e-5)
  kTemperature,            // degC   | degC, °C, K (absolute: 293.15 K -> 20 degC; below 0 K rejected)
  kTemperatureDifference,  // K      | K, mK, degC, °C (a difference: 1 degC = 1 K)
  kPressure,               // Pa     | Pa, hPa, kPa, MPa, mbar, bar, mmHg (133.322387415 Pa), Torr
  kHumidity,               // % RH   | %, %RH (the number is percent relative humidity, 0..100)
  kFraction,               // 1 (mole fraction) | 1, mol/mol, %, ppm, umol/mol, µmol/mol, ppb
  kPerKelvin,              // 1/K    | 1/K, /K, ppm/K, ppb/K, um/m/K, µm/m/K, 1/degC, /degC, ppm/degC,
                           //          um/m/degC
  kDimensionless,          // 1      | 1
  kTime,                   // s      | s, ms, us, µs, min, h
};

// Lower-case name used in messages and in QuantityInfo::quantity: "length", "angle", "ratio",
// "temperature", "temperature difference", "pressure", "humidity", "fraction",
// "expansion coefficient", "dimensionless", "time".
std::string_view DimensionName(Dimension dimension);

// The unit string of the internal representation, as in UncertainInput::unit / QuantityInfo::unit:
// "m", "rad", "1", "degC", "K", "Pa", "%", "1", "1/K", "1", "s".
std::string_view SiUnit(Dimension dimension);

// The kind of a time of a reading (docs/job-file.md "Readings"): seconds from a file's own origin
// (a number, "90 min"), a clock time of day (seconds from midnight), or a date and time (seconds
// since 1970-01-01). Times of different kinds have different origins and are never mixed.
enum class TimeKind { kSeconds, kClockTime, kDateTime };
// "seconds", "a clock time", "a date and time".
std::string_view TimeKindName(TimeKind kind);

// The units ParseQuantity accepts for `dimension` (for help texts and docs), in ASCII spelling;
// the spellings with the micro sign / Greek mu ("µm", "μm") and the degree sign ("°", "°C") are
// accepted as well.
std::span<const std::string_view> AcceptedUnits(Dimension dimension);

// "<number>[ ]<unit>" or "<number>" -> the value in the internal representation of `expected`.
// Leading/trailing blanks are ignored; the number is a decimal floating-point literal (optional
// sign, optional exponent); there may be blanks between number and unit.
// Throws InputError "<where>: '<text>' is an angle, expected a length" (and similar for unknown
// units, malformed or non-finite numbers, temperatures below absolute zero).
double ParseQuantity(std::string_view text, Dimension expected, std::string_view where);

// Value of `si` (internal representation of `dimension`) expressed in `unit`, which must be one
// of AcceptedUnits(dimension) (else std::invalid_argument: a programming error, not user input).
// Example: FromSi(4.84813681109536e-6, Dimension::kAngle, "arcsec") == 1.0.
double FromSi(double si, Dimension dimension, std::string_view unit);

// Inverse of FromSi: `value` in `unit` -> internal representation.
double ToSi(double value, Dimension dimension, std::string_view unit);

// "<value in unit> <unit>" with `significant_digits` significant digits (%g style), e.g.
// FormatQuantity(1.2e-5, Dimension::kLength, "um") == "12 um". ParseQuantity reads it back
// (to the printed precision). An empty `unit` means SiUnit(dimension).
std::string FormatQuantity(double si, Dimension dimension, std::string_view unit = {},
                           int significant_digits = 6);

// A value in the unit a metrologist reads it in: lengths below 1 mm in µm (UTF-8), else in mm with 12
// digits (a gauge's 50.000623 mm); angles below 1 deg in arcsec, else deg; ratios, fractions and
// expansion coefficients in ppm (ppm/K); pressures in hPa; temperatures in degC, differences in K.
std::string FormatReadable(double si, Dimension dimension);

// The unit a quantity string was typed with ("0.4 arcsec" -> "arcsec", "12" -> ""): the text
// after the number, trimmed. For showing a value back in the user's unit.
std::string TypedUnit(std::string_view text);

// The dimension named by a model's quantity kind (QuantityInfo::quantity: "length", "angle",
// "ratio", ... as DimensionName spells them). Throws InputError "<where>: the model declares an
// unknown quantity kind '<kind>'".
Dimension DimensionOfQuantity(std::string_view quantity, const std::string& where);

}  // namespace vlt
