// report.html and map.html: the template runtime/src/output/report.html.in (compiled in,
// output/plotly.cc) filled with the results as JSON and plotly.js inline, so the page is one
// self-contained file that opens offline.
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "output/assets.h"
#include "output/page.h"
#include "results/internal.h"

namespace vlt {

namespace {

// Replaces each @NAME@ of the template exactly once per occurrence, in one pass (inserted text is
// never scanned again, so nothing in the data or in plotly.js can be mistaken for a placeholder).
std::string Fill(std::string_view tpl, const std::vector<std::pair<std::string, std::string_view>>& values) {
  std::string out;
  out.reserve(tpl.size() + output_internal::PlotlyJs().size() + 1024 * 1024);
  std::size_t pos = 0;
  while (pos < tpl.size()) {
    std::size_t at = tpl.find('@', pos);
    if (at == std::string_view::npos) break;
    bool replaced = false;
    for (const auto& [name, value] : values) {
      std::string token = "@" + name + "@";
      if (tpl.compare(at, token.size(), token) == 0) {
        out.append(tpl.substr(pos, at - pos));
        out.append(value);
        pos = at + token.size();
        replaced = true;
        break;
      }
    }
    if (!replaced) {
      out.append(tpl.substr(pos, at + 1 - pos));
      pos = at + 1;
    }
  }
  out.append(tpl.substr(pos));
  return out;
}

std::string Page(const std::string& title, const std::string& data) {
  std::string escaped_title = base_internal::HtmlEscape(title);
  std::string version = VLT_VERSION;
  const std::string print = output_internal::PrintDesign(title);  // held: Fill takes string_views
  return Fill(output_internal::ReportTemplate(), {{"VLT_TITLE", escaped_title},
                                         {"VLT_PLOTLY_JS", output_internal::PlotlyJs()},
                                         {"VLT_PLOTLY_LICENSE", output_internal::PlotlyLicense()},
                                         {"VLT_DATA", data},
                                         {"VLT_VERSION", version},
                                         {"VLT_PLOTLY_VERSION", output_internal::PlotlyVersion()},
                                         {"VLT_PRINT", print}});
}

}  // namespace

std::string ReportHtml(const Results& results) {
  return Page("vlt report — " + results.job_name, results_internal::ResultsJsonText(results, -1, true));
}

std::string MapHtml(const MapResult& map, const std::string& title) {
  // The map-only page: the same template with {"kind": "map", "title", "map"}.
  Results holder;
  holder.map = map;
  nlohmann::ordered_json j = nlohmann::ordered_json::parse(results_internal::ResultsJsonText(holder, -1, false));
  nlohmann::ordered_json page;
  page["kind"] = "map";
  page["title"] = title;
  page["map"] = j["map"];
  std::string text = page.dump(-1, ' ', false, nlohmann::ordered_json::error_handler_t::replace);
  const std::string safe = base_internal::ScriptSafe(text);
  return Page("vlt map — " + title, safe);
}

}  // namespace vlt
