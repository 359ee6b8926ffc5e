// vlt/inverse.h — the readings a tracker shows when it is locked on a point.
//
// The generated tracker models map readings (range, azimuth, elevation) and an error state to
// the true reflector centre. The inverse answers the planning question "what would the tracker
// read at this point?": start from the closed-form ideal inverse, then Newton iterations on the
// 3x3 reading Jacobian of the generated model until the model reproduces the point to 1e-12 m.
//
// Conventions (docs/conventions.md):
//  - Front face: elevation in [-pi/2, pi/2]. Back face: A_b = A + pi, E_b = pi - E, i.e.
//    elevation in [pi/2, 3pi/2]; both give the same ideal point.
//  - Returned azimuth is normalised to [0, 2pi) on both faces.
#pragma once

#include <array>

#include "vlt/model_info.h"

namespace vlt {

enum class Face { kFront, kBack };

// "front" / "back"; ParseFace throws InputError "<where>: unknown face '<text>' (front, back)".
const char* FaceName(Face face);
Face ParseFace(const char* text, const char* where);

struct InverseOptions {
  double tolerance = 1e-12;  // m: |forward(readings) - point| at convergence
  int max_iterations = 50;
  // A point closer than this to the vertical (standing) axis has no defined azimuth: m.
  double min_horizontal_distance = 1e-6;
  // A point closer than this to the tracker origin has no defined direction: m.
  double min_range = 1e-6;
};

// Closed-form inverse of the ideal tracker (all errors zero):
// rho = |p|, A = atan2(y, x), E = atan2(z, hypot(x, y)); back face A + pi, pi - E.
// Throws NumericalError for a point on the vertical axis or at the origin.
std::array<double, 3> IdealReadings(const std::array<double, 3>& point, Face face,
                                    const InverseOptions& options = {});

// Readings of tracker `model` with error parameters `params` (model.num_params values) locked
// on `point` (tracker frame, m). Throws InputError if the model is not a tracker model and
// NumericalError for a singular point or when Newton does not converge.
std::array<double, 3> InverseReadings(const ModelInfo& model, const double* params,
                                      const std::array<double, 3>& point, Face face,
                                      const InverseOptions& options = {});

// Azimuth wrapped to [0, 2pi).
double NormalizeAzimuth(double azimuth);

}  // namespace vlt
