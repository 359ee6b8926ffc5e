// results/run_options.h — the command line's overrides of a job's settings, shared by the runs of
// tracker jobs (results/results.cc) and of custom-model jobs (custom/run.cc).
#pragma once

#include "vlt/job.h"
#include "vlt/mcm.h"
#include "vlt/results.h"

namespace vlt::results_internal {

// The Monte Carlo settings of a run: the job's [monte_carlo] (of `file`, for messages) with the
// command line's overrides.
McmSettings McmSettingsFor(const MonteCarloSettings& job, const RunOptions& options, int threads,
                           const std::string& file);

}  // namespace vlt::results_internal
