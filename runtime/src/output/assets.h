// output/assets.h — files compiled into the library for report.html (runtime/src/output/plotly.cc).
#pragma once

#include <string_view>

namespace vlt::output_internal {

std::string_view PlotlyJs();        // plotly.js, the exact bytes of the file embedded (cmake/VltPlotly.cmake); never holds "</script"
std::string_view PlotlyVersion();   // e.g. "v4.1.2"
std::string_view PlotlyLicense();   // its MIT licence text, carried into every page that embeds it
std::string_view ReportTemplate();  // runtime/src/output/report.html.in

}  // namespace vlt::output_internal
