// tasks/axial.h — the axially symmetric features (cylinder, cone) for vlt/fits.h (internal to
// tasks/).
#pragma once

#include <span>
#include <string_view>

#include "vlt/fits.h"

namespace vlt::tasks_internal {

// TaskOutputs of kCylinder and kCone; empty for the other kinds.
std::span<const TaskOutput> AxialOutputs(TaskKind kind);

// The geometric least-squares cylinder (kind kCylinder) or cone (kCone) of the points, with the
// exact Jacobian of its outputs when options.jacobian (docs/tasks.md "Cylinder and cone").
FitResult FitAxialSurface(TaskKind kind, const Eigen::Ref<const Eigen::Matrix3Xd>& points,
                          const FitOptions& options, std::string_view where);

}  // namespace vlt::tasks_internal
