// job/job_detail.h — the readers of the job file's sections, one per group of sections, called in
// order by ParseJob (job.cc) and by the readers of the files that hold job sections (custom-model
// jobs, calibration and network files). The strict TOML reading is base/section.h, the
// instrument's sections instrument/readers.h, CSV fields base/csv.h.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include <toml++/toml.h>

#include "base/csv.h"
#include "base/section.h"
#include "instrument/readers.h"
#include "vlt/error.h"
#include "vlt/job.h"
#include "vlt/units.h"

namespace vlt::job_internal {

// The job readers are written in terms of the shared section readers (base/) and the
// instrument's (instrument/).
using namespace base_internal;
using namespace instrument_internal;

// points.cc: the scale of `unit` for `dim` (value_SI = value * scale) of a file's `unit` key,
// with a job-file message for a bad unit.
double UnitScale(const std::string& unit, Dimension dim, const std::string& where);
// points.cc: [plan]; check_reach: every point within range of the job's station and off its
// vertical axis (a network's [targets] are checked per station instead). A plan CSV is read on up
// to `threads` threads (0: all; the same points and the same first error for any count).
void ReadPlan(Section& plan, Job& job, bool check_reach = true, int threads = 1);
// points.cc: [readings]. The time column is read when `columns.time` names it, or, with
// `times_by_default` (a network, whose drift models need times), when a column is called "time".
void ReadReadings(Section& readings, Job& job, bool times_by_default = false);
void ReadTasks(Section& top, Job& job, int threads = 1);  // tasks.cc: [[task]]; threads copy a scan's names
// tasks.cc: [<table>.tolerance.<quantity>] lower, upper of a task's quantities (TaskOutputs).
// `weighting` of a [[task]] or [[alignment]] table: the fits it asks for, as (weighted, name)
// pairs: "none" (default) the ordinary fit under `name`; "covariance" the fit weighted by the
// points' covariance under `name`; "both" the two, the weighted one under "<name>_weighted".
// Throws InputError for another value or a kind that no weighting applies to.
// `table` names it in messages ("task", "alignment").
std::vector<std::pair<bool, std::string>> ReadWeighting(Section& t, TaskKind kind, const std::string& name,
                                                        const char* table);
// The name of the weighted twin of a task named `name` (weighting = "both").
std::string WeightedName(const std::string& name);
void ReadTaskTolerances(Section& table, TaskSpec& spec);
// alignment.cc: [nominal], [[alignment]], [[deviation]], [[profile]] (after the tasks: their names are unique
// among all tasks).
void ReadAlignments(Section& top, Job& job);
void ReadMonteCarlo(Section& top, MonteCarloSettings& settings);  // settings.cc: [monte_carlo]
// "a,b,c,d" or an array of numbers / quantity strings, as one comma-separated text (settings.cc).
std::string ExtentString(const toml::node& node, const std::string& where);
// Exactly `count` lengths [m] from such a text or array (bare numbers are metres).
std::vector<double> LengthList(const toml::node& node, std::size_t count, const std::string& where);
void ReadMap(Section& top, Job& job);       // settings.cc: [map]
void ReadOptimize(Section& top, Job& job);  // optimize.cc: [optimize] (after the tasks)
// settings.cc: [output]; `detail` and `arrays` only where the job writes per-point files (a tracker
// job: point_files), else they are unknown keys.
void ReadOutput(Section& top, OutputSettings& output, bool point_files = false);

}  // namespace vlt::job_internal
