// base/format.h — numbers and text as vlt's files print them: the shortest digits that read back,
// fixed decimals, CSV fields (RFC 4180), HTML escaping, safe file names. Used by every folder that
// writes files (results/, custom/, calibration/, network/, planning/, output/).
#pragma once

#include <chrono>
#include <string>

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
// A CSV field quoted when it holds a comma, quote or line break (RFC 4180).
std::string CsvField(const std::string& field);
// Text for HTML: & < > " ' escaped.
std::string HtmlEscape(const std::string& text);
// JSON text for a <script> element (inline code or application/json): every '<' as \u003c, so
// that no text inside a string ("</script>", "<!--") can close or change the element; the parsed
// values are the same. The one escaping layer of every report's scripts.
std::string ScriptSafe(const std::string& text);

}  // namespace base_internal
}  // namespace vlt
