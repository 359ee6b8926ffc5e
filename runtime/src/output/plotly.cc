// The assets of report.html compiled into the library (cmake/VltPlotly.cmake, runtime/CMakeLists.txt):
// plotly.js (npm plotly.js-dist-min, version pinned in package-lock.json), its MIT licence text, and the page template
// runtime/src/output/report.html.in. .incbin copies the files' bytes into .rodata at compile time, so
// the `vlt` binary writes a self-contained, offline report without any file at run time.
#include "output/assets.h"

#ifndef VLT_PLOTLY_JS_FILE
#error "VLT_PLOTLY_JS_FILE must name plotly.min.js (set by runtime/CMakeLists.txt)"
#endif

// Each blob is followed by its end label; sizes are end - start (no terminating NUL needed).
asm(".section .rodata.vlt_assets,\"a\",@progbits\n"
    ".balign 16\n"
    ".globl vlt_asset_plotly_start\n"
    "vlt_asset_plotly_start:\n"
    ".incbin \"" VLT_PLOTLY_JS_FILE
    "\"\n"
    ".globl vlt_asset_plotly_end\n"
    "vlt_asset_plotly_end:\n"
    ".balign 16\n"
    ".globl vlt_asset_plotly_license_start\n"
    "vlt_asset_plotly_license_start:\n"
    ".incbin \"" VLT_PLOTLY_LICENSE_FILE
    "\"\n"
    ".globl vlt_asset_plotly_license_end\n"
    "vlt_asset_plotly_license_end:\n"
    ".balign 16\n"
    ".globl vlt_asset_template_start\n"
    "vlt_asset_template_start:\n"
    ".incbin \"" VLT_REPORT_TEMPLATE_FILE
    "\"\n"
    ".globl vlt_asset_template_end\n"
    "vlt_asset_template_end:\n"
    ".previous\n");

extern "C" {
extern const char vlt_asset_plotly_start[];
extern const char vlt_asset_plotly_end[];
extern const char vlt_asset_plotly_license_start[];
extern const char vlt_asset_plotly_license_end[];
extern const char vlt_asset_template_start[];
extern const char vlt_asset_template_end[];
}

namespace vlt::output_internal {

std::string_view PlotlyJs() {
  return {vlt_asset_plotly_start, static_cast<std::size_t>(vlt_asset_plotly_end - vlt_asset_plotly_start)};
}

std::string_view PlotlyVersion() { return VLT_PLOTLY_VERSION; }

std::string_view PlotlyLicense() {
  return {vlt_asset_plotly_license_start,
          static_cast<std::size_t>(vlt_asset_plotly_license_end - vlt_asset_plotly_license_start)};
}

std::string_view ReportTemplate() {
  return {vlt_asset_template_start,
          static_cast<std::size_t>(vlt_asset_template_end - vlt_asset_template_start)};
}

}  // namespace vlt::output_internal
