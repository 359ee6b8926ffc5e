// tasks/minimum_zone.h — internal to tasks/: form by the minimum-zone (Chebyshev) definition of
// ISO 1101 and its specifications (flatness ISO 12781-1, straightness ISO 12780-1, roundness ISO
// 12181-1, cylindricity ISO 12180-1), beside the least-squares-referenced value (docs/tasks.md
// "Form by minimum zone").
#pragma once

#include <span>
#include <string_view>

#include <Eigen/Core>

#include "vlt/fits.h"

namespace vlt::tasks_internal {

// The outputs of kFlatness, kStraightness, kRoundness, kCylindricity: the minimum-zone form and the
// least-squares-referenced one ("flatness", "flatness_least_squares", ...).
std::span<const TaskOutput> FormOutputs(TaskKind kind);

// The two values of a form kind (neither differentiable: the GUM has no value for them, Monte
// Carlo does). Throws as the least-squares fit of the feature does, and NumericalError when the
// linear programs fail.
FitResult FitForm(TaskKind kind, const Eigen::Ref<const Eigen::Matrix3Xd>& points, const FitOptions& options,
                  std::string_view where);

}  // namespace vlt::tasks_internal
