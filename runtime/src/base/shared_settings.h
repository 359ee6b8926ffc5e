// base/shared_settings.h — one reader per setting that several capabilities share (a job's
// [monte_carlo], [network], [tests], [calibration], [optimize]): the same key is accepted in the
// same forms and refused with the same message everywhere. Each reader leaves `value` as it is
// when the key is absent and returns whether it was given; limits are arguments where the
// capabilities legitimately differ.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "base/section.h"

namespace vlt::base_internal {

// A coverage probability p in (0, 1): a ratio, 0.95 or "95 %".
bool ReadCoverageProbability(Section& s, std::string_view key, double& value);

// A seed of a random generator: an integer >= 0.
bool ReadSeed(Section& s, std::string_view key, std::uint64_t& value);

// A number of Monte Carlo trials in minimum .. maximum; `why_minimum` follows "at least N trials"
// (e.g. the clause the minimum comes from; may be empty).
bool ReadTrials(Section& s, std::string_view key, std::int64_t minimum, std::int64_t maximum,
                const std::string& why_minimum, std::int64_t& value);

// A number of threads: 0 (all hardware threads) .. 1024.
bool ReadThreads(Section& s, std::string_view key, int& value);

// The iteration limit of a Levenberg–Marquardt solve: 1 .. 10000.
bool ReadIterationLimit(Section& s, std::string_view key, int& value);

// The limit on |w| (normalised residual) above which a reading is flagged: a positive number.
bool ReadOutlierLimit(Section& s, std::string_view key, double& value);

}  // namespace vlt::base_internal
