// tasks/alignment.h — the outputs of the alignment kinds (best_fit, best_fit_scale, deviation),
// for vlt/fits.h TaskOutputs (internal to tasks/).
#pragma once

#include <span>

#include "vlt/fits.h"

namespace vlt::tasks_internal {

// TaskOutputs of kBestFit, kBestFitScale, kDeviation and kPosition; empty for the other kinds.
std::span<const TaskOutput> AlignmentOutputs(TaskKind kind);

}  // namespace vlt::tasks_internal
