// results/internal.h — shared by results/*.cc and report/html.cc.
#pragma once

#include <chrono>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "vlt/mcm.h"
#include "vlt/results.h"

namespace vlt::internal {

// Wall time since `since`, s.
double Seconds(std::chrono::steady_clock::time_point since);

// The Monte Carlo settings of a run: the job's [monte_carlo] with the command line's overrides.
McmSettings McmSettingsFor(const MonteCarloSettings& job, const RunOptions& options, int threads);

// "(x, y, z) m" with 6 significant digits, for messages about grid nodes.
std::string FormatNode(const Eigen::Vector3d& node);

// The Monte Carlo version of a task: refits the drawn points every trial with the same function
// (vlt/fits.h) the GUM engine linearises. Outputs: "<task>.<output>" for every TaskOutputs(kind).
McmTask MakeMcmTask(const TaskSpec& spec, const std::vector<int>& point_indices, const TaskUncertainty& gum);

// Number formatting for CSV/JSON/HTML: shortest round-trip representation ("%.17g" trimmed).
std::string Num(double v);

// Sensitivity of a coordinate (m) to an input, in the units people read (docs/results.md):
// um/um, um/arcsec, um/ppm, um/K, um/hPa, um/%, um/(ppm/K), chosen from the input's SI unit
// ("m", "rad", "1", "degC"/"K", "Pa", "%", "1/K"). Returns {unit, factor}: practical = SI * factor.
std::pair<std::string, double> PracticalSensitivity(const std::string& input_unit);
// Fixed number of significant digits.
std::string Sig(double v, int digits);

// report.html of a job with more points than kReportDetailedPoints embeds those with the largest
// |U| in full and an overview (x, y, z, |U|) of at most kReportOverviewPoints points, so that the
// page stays small and draws (issue: 10^4 points made a 154 MB page that never drew).
inline constexpr std::size_t kReportDetailedPoints = 200;
inline constexpr std::size_t kReportOverviewPoints = 20000;

// results.json text; for_html: compact, "</" escaped, plus the report's own settings (and, for a
// scan, only the points above).
std::string ResultsJsonText(const Results& results, int indent, bool for_html);

std::string HtmlEscape(const std::string& text);
// Safe directory name from a job name ([A-Za-z0-9._-], others -> '_').
std::string SafeFileName(const std::string& name);

}  // namespace vlt::internal
