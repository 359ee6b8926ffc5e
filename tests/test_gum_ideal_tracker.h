// Test scaffolding: a hand-written ideal spherical tracker ModelInfo with four error parameters
// and exact analytic Jacobians, independent of vlt-gen:
//   rho' = (1 + mu) rho + r0,  A' = A + azimuth_index,  E' = E + elevation_index
//   x = rho' (cos E' cos A', cos E' sin A', sin E')
// Params: 0 r0 [m], 1 mu [1], 2 azimuth_index [rad], 3 elevation_index [rad].
#pragma once

#include <cmath>
#include <cstddef>

#include "vlt/model_info.h"

namespace vlt::test {

inline void IdealForwardJacobians(const double* r, const double* p, double* out, double* jr, double* jp) {
  const double rho = (1.0 + p[1]) * r[0] + p[0];
  const double a = r[1] + p[2], e = r[2] + p[3];
  const double ca = std::cos(a), sa = std::sin(a), ce = std::cos(e), se = std::sin(e);
  const double d[3] = {ce * ca, ce * sa, se};
  const double d_da[3] = {-ce * sa, ce * ca, 0.0};
  const double d_de[3] = {-se * ca, -se * sa, ce};
  for (int i = 0; i < 3; ++i) {
    out[i] = rho * d[i];
    if (jr != nullptr) {
      jr[0 + i] = (1.0 + p[1]) * d[i];
      jr[3 + i] = rho * d_da[i];
      jr[6 + i] = rho * d_de[i];
    }
    if (jp != nullptr) {
      jp[0 + i] = d[i];
      jp[3 + i] = r[0] * d[i];
      jp[6 + i] = rho * d_da[i];
      jp[9 + i] = rho * d_de[i];
    }
  }
}

inline void IdealForward(const double* r, const double* p, double* out) {
  IdealForwardJacobians(r, p, out, nullptr, nullptr);
}

inline const QuantityInfo kIdealReadings[] = {
    {"range", "m", "length", "range reading", 0, 0, "normal", 0},
    {"azimuth", "rad", "angle", "azimuth reading", 0, 0, "normal", 0},
    {"elevation", "rad", "angle", "elevation reading", 0, 0, "normal", 0},
};
inline const QuantityInfo kIdealParams[] = {
    {"r0", "m", "length", "range offset", 0, 1e-6, "normal", 0},
    {"mu", "1", "ratio", "range scale", 0, 1e-6, "normal", 0},
    {"azimuth_index", "rad", "angle", "azimuth index", 0, 1e-6, "normal", 0},
    {"elevation_index", "rad", "angle", "elevation index", 0, 1e-6, "normal", 0},
};
inline const QuantityInfo kIdealOutputs[] = {
    {"x", "m", "length", "x", 0, 0, "normal", 0},
    {"y", "m", "length", "y", 0, 0, "normal", 0},
    {"z", "m", "length", "z", 0, 0, "normal", 0},
};

inline const ModelInfo kIdealTracker = {"ideal_test",
                                        "tracker",
                                        "ideal spherical tracker (test scaffolding)",
                                        "tests",
                                        3,
                                        4,
                                        3,
                                        kIdealReadings,
                                        kIdealParams,
                                        kIdealOutputs,
                                        &IdealForward,
                                        &IdealForwardJacobians,
                                        nullptr,
                                        nullptr,
                                        nullptr,
                                        nullptr,
                                        nullptr,
                                        nullptr,  // hessians: the central-difference path
                                        0,
                                        0,
                                        0,
                                        0};

}  // namespace vlt::test
