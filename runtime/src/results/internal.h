// results/internal.h — internal to results/: running a job and writing its files.
#pragma once

#include <chrono>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "base/format.h"
#include "results/run_options.h"
#include "vlt/mcm.h"
#include "vlt/results.h"

namespace vlt::results_internal {

using namespace base_internal;  // number and file-name formatting (base/format.h)

// The Monte Carlo version of a task: refits the drawn points every trial with the same function
// (vlt/fits.h) the GUM engine linearises. Outputs: "<task>.<output>" for every TaskOutputs(kind).
McmTask MakeMcmTask(const TaskSpec& spec, const std::vector<int>& point_indices, const TaskUncertainty& gum);

// The headline quantities of a task: those the summary's task table and the result statements show
// (a plane's normal_x, normal_y and flatness; a circle's centre, radius and normal; ...).
bool IsHeadline(const TaskResult& t, const std::string& quantity);

// Whether quantity q of a task is decided and stated from its Monte Carlo distribution rather than
// from the GUM's y +- U: Monte Carlo was run, and the GUM has no first-order value (not
// differentiable, or a first-order u of 0 to rounding: validation "not applicable") or is not
// validated by it (JCGM 101 8: the Monte Carlo result is then the one to state).
bool DecidedByMonteCarlo(const TaskResult& task, std::size_t q);

// Each headline task quantity's result as JCGM 100 7.2 asks it stated (results/statement.cc):
// "4000.013 mm, U = 14 µm (k = 1.96, p = 95 %); Monte Carlo 95 % coverage interval [...] mm, GUM
// validated (JCGM 101 8)", with the decision against a tolerance where one is given.
struct ResultStatement {
  std::string task, quantity, text;
};
std::vector<ResultStatement> ResultStatements(const Results& results);

// Sensitivity of a coordinate (m) to an input, in the units people read (docs/results.md):
// um/um, um/arcsec, um/ppm, um/K, um/hPa, um/%, um/(ppm/K), chosen from the input's SI unit
// ("m", "rad", "1", "degC"/"K", "Pa", "%", "1/K"). Returns {unit, factor}: practical = SI * factor.
std::pair<std::string, double> PracticalSensitivity(const std::string& input_unit);

// report.html of a job with more points than kReportDetailedPoints embeds those with the largest
// |U| in full and an overview (x, y, z, |U|) of at most kReportOverviewPoints points, so that the
// page stays small and draws (issue: 10^4 points made a 154 MB page that never drew).
inline constexpr std::size_t kReportDetailedPoints = 200;
inline constexpr std::size_t kReportOverviewPoints = 20000;

// results.json text; for_html: compact, "</" escaped, plus the report's own settings (and, for a
// scan, only the points above).
std::string ResultsJsonText(const Results& results, int indent, bool for_html);

// Largest number of per-source map values (layers x nodes) put into results.json and map.html:
// beyond it the page would not draw in a browser (docs/results.md); map.csv has them all.
inline constexpr std::size_t kMaxMapLayerValues = 4000000;

// Writes the text of n items (points) to `out` in item order: format(begin, end, text) appends
// the text of items [begin, end) to `text`; ranges are formatted on up to `threads` threads
// (0: all), the output does not depend on the thread count.
void WriteInBlocks(OutputText& out, std::size_t n, int threads,
                   const std::function<void(std::size_t, std::size_t, std::string&)>& format);
// WriteInBlocks over every point of `results` with the points' full GUM results (recomputed as
// PointDetails does, with budgets when `budgets`): format(first, points first.., text).
void WritePointDetails(
    const Results& results, OutputText& out, bool budgets,
    const std::function<void(std::size_t, std::span<const PointUncertainty>, std::string&)>& format);

}  // namespace vlt::results_internal
