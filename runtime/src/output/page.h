// output/page.h — a self-contained HTML page (plotly.js embedded) for the reports of `vlt test`,
// `vlt calibrate` and `vlt network`: header, server-side sections, the figures' script. The element
// #vlt-status carries data-errors / data-plots for the browser tests (as report.html); each figure's
// script calls done() once drawn.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

namespace vlt::output_internal {

// A value as JSON text for a figure's script: base_internal::ScriptSafe of its JSON, so that no
// name (a station's, a test's) can end the <script> element and run its own (issue 32).
std::string ScriptJson(const nlohmann::json& value);

std::string Page(const std::string& title, const std::string& subtitle, const std::string& body,
                 const std::string& script);

}  // namespace vlt::output_internal
