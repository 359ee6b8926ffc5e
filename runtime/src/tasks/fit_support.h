// tasks/fit_support.h — what every fit in tasks/ shares: its refusals, its result's shape and the
// sign convention of a fitted unit vector (internal to tasks/; defined in fits.cc).
#pragma once

#include <string>
#include <string_view>

#include <Eigen/Core>

#include "vlt/fits.h"

namespace vlt::tasks_internal {

// Throws NumericalError "<where>: <kind>: <reason>".
[[noreturn]] void Fail(std::string_view where, TaskKind kind, const std::string& reason);

// Throws InputError unless there are `minimum` points (exactly, or at least) and all are finite.
void CheckPoints(const Eigen::Ref<const Eigen::Matrix3Xd>& points, TaskKind kind, int minimum, bool exact,
                 std::string_view where);

// A result of `kind` with zero values, every output differentiable, and a zero Jacobian for
// num_points points when options.jacobian.
FitResult MakeResult(TaskKind kind, long num_points, const FitOptions& options);

// +1 or -1 so that sign * v follows FitOptions::orientation (docs/tasks.md "Sign conventions").
double OrientationSign(const Eigen::Vector3d& v, const FitOptions& options);

// A fit weighted by the points' covariance (FitOptions::covariance or ::weights).
inline bool Weighted(const FitOptions& options) {
  return options.covariance != nullptr || options.weights != nullptr;
}
// Throws InputError "<where>: <kind>: ..." unless `kind` can be weighted (vlt/fits.h FitOptions).
void CheckWeightable(TaskKind kind, std::string_view where);
// The weighted plane, sphere, circle, line, cylinder or cone (tasks/weighted.cc).
FitResult FitWeightedFeature(TaskKind kind, const Eigen::Ref<const Eigen::Matrix3Xd>& points,
                             const FitOptions& options, std::string_view where);

}  // namespace vlt::tasks_internal
