// network/adjust.h — internal to runtime/src/network/: the adjustment of one Monte Carlo trial
// (docs/network.md N-10), which needs less of the adjustment than a result does.
#pragma once

#include "vlt/network.h"

namespace vlt::network_internal {

// AdjustNetwork (vlt/network.h, with its robust rule N-8a) for a simulated trial of the Monte Carlo
// validation: the trial starts at the truth's poses, so Ceres starts as Gauss-Newton (trust region
// 1e8) and stops at a relative step of 1e-10 (a trial's targets then sit within ~1e-8 m of the
// converged solution, 1e-6 of the variance of a 10 um target); and it forms only the covariance
// blocks the trial's own w need (pose, self-calibrated inputs, each target with the unknowns its
// readings touch, the targets tied by distances), not the 3T x 3T target covariance, which is most of
// an adjustment's arithmetic and which no trial reads. Identifiability and the predicted w of
// removed observations are left out. Targets' positions are those of AdjustNetwork to that
// tolerance, and the blocks named above are exact; the result's covariance between targets of
// different groups is not formed (it holds the consider part only) and must not be read.
NetworkResult AdjustNetworkTrial(const Network& network);

}  // namespace vlt::network_internal
