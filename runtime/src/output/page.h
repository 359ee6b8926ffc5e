// output/page.h — a self-contained HTML page (plotly.js embedded) for the reports of `vlt test`,
// `vlt calibrate` and `vlt network`: header, server-side sections, the figures' script. The element
// #vlt-status carries data-errors / data-plots for the browser tests (as report.html); each figure's
// script calls done() once drawn.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "vlt/job_record.h"

namespace vlt::output_internal {

// A job's record (vlt/job_record.h) in results.json `job.record`: customer, instrument {make, model,
// serial}, operator, place, conditions; null for what was not given; null as a whole when nothing was.
nlohmann::json RecordJson(const JobRecord& record);
// The same for a summary's header: "Customer ...; instrument ...; operator ...; place ...;
// conditions ...\n" with what was given; "" when nothing was.
std::string RecordLine(const JobRecord& record);

// A value as JSON text for a figure's script: base_internal::ScriptSafe of its JSON, so that no
// name (a station's, a test's) can end the <script> element and run its own (issue 32).
std::string ScriptJson(const nlohmann::json& value);

// The print design every report shares (docs/results.md "Printing"): A4 or US Letter as the user's
// print dialog picks, 15/12 mm margins, the report's name top left and "Page i of N" bottom right
// of every page (CSS page-margin boxes), tables that break between rows and repeat their header,
// plots redrawn to the page's width when printing, no controls. A <style> and a <script> for the end
// of <body>; `name` is written as a CSS string (base_internal::CssString).
std::string PrintDesign(const std::string& name);

std::string Page(const std::string& title, const std::string& subtitle, const std::string& body,
                 const std::string& script);

}  // namespace vlt::output_internal
