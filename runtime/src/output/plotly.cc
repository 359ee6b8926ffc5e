// The assets of report.html compiled into the library (cmake/VltPlotly.cmake, runtime/CMakeLists.txt):
// plotly.js (npm plotly.js-dist-min pinned in package-lock.json, or the copy named at configure time),
// its MIT licence text, and the page template runtime/src/output/report.html.in. The build tool
// vlt_embed (cmake/vlt_embed.cc) writes each file's bytes as pieces of ordinary string literals into
// embedded/assets.inc: portable C++ (no assembler .incbin), so the `vlt` binary writes a
// self-contained, offline report without any file at run time.
#include <algorithm>
#include <cctype>
#include <stdexcept>
#include <string>

#include "assets.inc"
#include "output/assets.h"

namespace vlt::output_internal {
namespace {

template <std::size_t N>
std::string Joined(const std::string_view (&pieces)[N]) {
  std::size_t size = 0;
  for (std::string_view piece : pieces) size += piece.size();
  std::string text;
  text.reserve(size);
  for (std::string_view piece : pieces) text.append(piece);
  return text;
}

// plotly.js as it is inlined in every report's <script> element, which ends at the first
// "</script" in any letter case (HTML 13.2.5.4): a file that holds one (or a lost embedding) is
// refused here, loudly, instead of writing a broken page. Neither the pinned npm file nor Debian's
// python3-plotly copy has one.
std::string CheckedScript(std::string text) {
  std::string lower(text.size(), '\0');
  std::transform(text.begin(), text.end(), lower.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (text.size() < 1000 || lower.find("</script") != std::string::npos) {
    throw std::logic_error("embedded plotly.js is missing or cannot be inlined in a <script> element");
  }
  return text;
}

}  // namespace

// Each asset is joined once, on first use (thread-safe static initialisation), and lives until exit.
std::string_view PlotlyJs() {
  static const std::string text = CheckedScript(Joined(kPlotlyJs));
  return text;
}

std::string_view PlotlyVersion() { return VLT_PLOTLY_VERSION; }

std::string_view PlotlyLicense() {
  static const std::string text = Joined(kPlotlyLicense);
  return text;
}

std::string_view ReportTemplate() {
  static const std::string text = Joined(kReportTemplate);
  return text;
}

}  // namespace vlt::output_internal
