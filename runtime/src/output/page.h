// output/page.h — a self-contained HTML page (plotly.js embedded) for the reports of `vlt test`,
// `vlt calibrate` and `vlt network`: header, server-side sections, the figures' script. The element
// #vlt-status carries data-errors / data-plots for the browser tests (as report.html); each figure's
// script calls done() once drawn.
#pragma once

#include <string>

namespace vlt::output_internal {

std::string Page(const std::string& title, const std::string& subtitle, const std::string& body,
                 const std::string& script);

}  // namespace vlt::output_internal
