#include "vlt/inverse.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <cstdio>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "vlt/error.h"

namespace vlt {
namespace {

constexpr double kPi = 3.14159265358979323846;

std::string PointText(const std::array<double, 3>& p) {
  char buf[128];
  std::snprintf(buf, sizeof buf, "(%.9g, %.9g, %.9g) m", p[0], p[1], p[2]);
  return buf;
}

}  // namespace

const char* FaceName(Face face) { return face == Face::kFront ? "front" : "back"; }

Face ParseFace(const char* text, const char* where) {
  const std::string t = text;
  if (t == "front") return Face::kFront;
  if (t == "back") return Face::kBack;
  throw InputError(std::string(where) + ": unknown face '" + t + "' (front, back)");
}

double NormalizeAzimuth(double azimuth) {
  double a = std::fmod(azimuth, 2 * kPi);
  if (a < 0) a += 2 * kPi;
  if (a >= 2 * kPi) a = 0.0;  // fmod result -0 or rounding up to 2pi
  return a;
}

std::array<double, 3> IdealReadings(const std::array<double, 3>& point, Face face,
                                    const InverseOptions& options) {
  const double horizontal = std::hypot(point[0], point[1]);
  const double range = std::hypot(horizontal, point[2]);
  if (!(range >= options.min_range)) {
    throw NumericalError("inverse: point " + PointText(point) + " is at the tracker origin (range below " +
                         std::to_string(options.min_range) + " m): direction undefined");
  }
  if (!(horizontal >= options.min_horizontal_distance)) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "%.3g m < %.3g m", horizontal, options.min_horizontal_distance);
    throw NumericalError("inverse: point " + PointText(point) +
                         " is on the tracker's vertical axis (horizontal distance " + buf +
                         "): azimuth undefined");
  }
  double azimuth = std::atan2(point[1], point[0]);
  double elevation = std::atan2(point[2], horizontal);
  if (face == Face::kBack) {
    azimuth += kPi;
    elevation = kPi - elevation;
  }
  return {range, NormalizeAzimuth(azimuth), elevation};
}

std::array<double, 3> InverseReadings(const ModelInfo& model, const double* params,
                                      const std::array<double, 3>& point, Face face,
                                      const InverseOptions& options) {
  if (model.num_readings != 3 || std::string(model.kind) != "tracker") {
    throw InputError(std::string("inverse: model '") + model.name + "' is not a tracker model (no readings)");
  }
  std::array<double, 3> r = IdealReadings(point, face, options);
  const Eigen::Vector3d target(point[0], point[1], point[2]);
  // Floor on the tolerance: the model cannot be evaluated closer than a few ulps of the point.
  const double tolerance =
      std::max(options.tolerance, 8 * std::numeric_limits<double>::epsilon() * target.norm());
  std::vector<double> d_params(3 * static_cast<std::size_t>(std::max(model.num_params, 1)));
  double last = 0;
  for (int it = 0; it <= options.max_iterations; ++it) {
    double out[3];
    Eigen::Matrix3d jac;  // column-major, as the generated code writes it
    model.forward_jacobians(r.data(), params, out, jac.data(), d_params.data());
    const Eigen::Vector3d residual = Eigen::Vector3d(out[0], out[1], out[2]) - target;
    last = residual.norm();
    if (!std::isfinite(last)) break;
    if (last <= tolerance) {
      // Newton starts from the ideal readings of the requested face and the error terms are
      // tiny, so it converges to the solution of that face (the other is pi away).
      r[1] = NormalizeAzimuth(r[1]);
      return r;
    }
    const Eigen::FullPivLU<Eigen::Matrix3d> lu(jac);
    if (!lu.isInvertible() || std::abs(lu.determinant()) < 1e-300) {
      throw NumericalError("inverse: reading Jacobian of model '" + std::string(model.name) +
                           "' is singular at point " + PointText(point));
    }
    const Eigen::Vector3d step = lu.solve(residual);
    for (int i = 0; i < 3; ++i) r[i] -= step[i];
  }
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.3g m", last);
  throw NumericalError("inverse: Newton iteration for model '" + std::string(model.name) +
                       "' did not converge at point " + PointText(point) + " (" + FaceName(face) +
                       " face, residual " + buf + ")");
}

}  // namespace vlt
