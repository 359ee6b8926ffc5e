// base/format.h — numbers and text as vlt's files print them: the shortest digits that read back,
// fixed decimals, CSV fields (RFC 4180), HTML escaping, safe file names. Used by every folder that
// writes files (results/, custom/, calibration/, network/, planning/, output/).
#pragma once

#include <chrono>
#include <string>
#include <string_view>

#include <Eigen/Core>

namespace vlt {

// Safe directory name from a job name ([A-Za-z0-9._-], others -> '_'); public in vlt/results.h.
std::string SafeFileName(const std::string& name);

namespace base_internal {

using vlt::SafeFileName;

// Wall time since `since`, s.
double Seconds(std::chrono::steady_clock::time_point since);

// "(x, y, z) m" with 6 significant digits, for messages about grid nodes.
std::string FormatNode(const Eigen::Vector3d& node);

// Number formatting for CSV/JSON/HTML: shortest round-trip representation ("%.17g" trimmed).
std::string Num(double v);
// Appends Num(v) to out without allocating a string per number (the per-point files).
void AppendNum(std::string& out, double v);
// Fixed number of significant digits.
std::string Sig(double v, int digits);
// Fixed number of decimals, never "-0.00" (tables of reports).
std::string Fixed(double v, int decimals);
// Appends v rounded to `decimals` decimals (std::to_chars, exact decimal rounding of the double),
// trailing zeros and a trailing '.' dropped, never "-0": the compact points.csv (1500.25, not
// 1500.2500000000002). Not for a non-finite v (appends it as %g).
void AppendDecimals(std::string& out, double v, int decimals);
// Appends an uncertainty v >= 0 rounded *up* to `digits` significant digits (JCGM 100 7.2.6: an
// uncertainty may be rounded up, never understated), trailing zeros kept ("81.0"), no exponent
// (at least units: 1234.2 with 3 digits is "1235"): ceil(v 10^d) / 10^d, d the decimals.
void AppendRoundedUp(std::string& out, double v, int digits);
// A result as JCGM 100 7.2.6 asks it written: the expanded uncertainty U rounded up to two
// significant digits (10.47 -> 11; an excess below 1/20 of the last digit dropped, as 7.2.6's
// "28.05 should be rounded down to 28"), the value rounded (to nearest) to the same decimal place, each in the unit it
// is shown in (value_scale, expanded_scale: shown units per SI unit, e.g. 1e3 for mm, 1e6 for um).
// The value gets at least the decimals that reach U's last digit (for units whose ratio is not a
// power of ten, deg and arcsec, one decimal place at most that fine). Never "-0". `expanded` must
// be finite and > 0; `value` finite.
struct GumRounded {
  std::string value;       // e.g. "4000.013"
  std::string expanded;    // e.g. "14"
  int value_decimals = 0;  // decimals of `value`, for other numbers printed beside it (an interval)
};
GumRounded RoundLikeGum(double value, double value_scale, double expanded, double expanded_scale);
// The shortest decimal that reads back as v (SI), at most 15 significant digits (so that a limit
// typed in mm and rounded in its conversion to m comes back as typed: 300.05 mm, held as
// 0.30005000000000004 m), written in a unit `scale` times smaller (a power of ten: 1, 1e3 for mm,
// 1e6 for um) by moving the decimal point, not by multiplying (3.9999905 m is "3999.9905" mm, not
// 3999.9904999999999): a limit as it was specified. Below 10^-6 or from 10^16 (in the shown unit)
// with an exponent: 5e-12, 1.25e+20. Other scales (degrees):
// ten significant digits of v * scale.
std::string ShortestAt(double v, double scale);
// v (SI) shown with `decimals` decimals after scaling (negative decimals: rounded to 10^-decimals),
// never "-0".
std::string ShownAt(double v, double scale, int decimals);
// A unit as people read it: every "um" that is a unit of its own ("um", "um/m", "um/arcsec") as
// "µm". Files for programs (CSV headers and unit columns, results.json) keep the ASCII spelling.
std::string HumanUnit(std::string_view ascii_unit);
// `text` padded with spaces to `width` columns of a terminal, counting characters, not bytes (a
// "µm" is two bytes and one column): right-aligned, or left-aligned with align_left.
std::string PadColumns(const std::string& text, int width, bool align_left = false);
// A CSV field quoted when it holds a comma, quote or line break (RFC 4180).
std::string CsvField(const std::string& field);
// Text for HTML: & < > " ' escaped.
std::string HtmlEscape(const std::string& text);
// JSON text for a <script> element (inline code or application/json): every '<' as \u003c, so
// that no text inside a string ("</script>", "<!--") can close or change the element; the parsed
// values are the same. The one escaping layer of every report's scripts.
std::string ScriptSafe(const std::string& text);
// A CSS string literal ("..."): backslash and quote escaped, every ASCII character that is not a
// letter, digit, space or one of - _ . , : ( ) / + written as a hex escape (so that no '<' can end
// the <style> element and no line break the string); other UTF-8 bytes kept.
std::string CssString(const std::string& text);

}  // namespace base_internal
}  // namespace vlt
