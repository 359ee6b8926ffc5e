// Shared by tests/test_calibration*.cc: a simulated tracker whose true error state is drawn from
// the model's default uncertainties, and the shipped B89.4.19-pattern layout.
#pragma once

#include <cstdint>
#include <random>
#include <string>

#include "vlt/measurement_model.h"
#include "vlt/models.h"

namespace vlt::test {

inline const std::string kB89Layout = std::string(VLT_SOURCE_DIR) + "/examples/layouts/b89_4_19_2006.toml";

// Parameter estimates = state_scale * u * N(0, 1) (seeded), u = the model's default; reading
// noise 1 um + 0.2 um/m, 0.1 arcsec.
inline MeasurementSetup SimulatedTracker(const std::string& model_name, double state_scale,
                                         std::uint64_t seed) {
  const ModelInfo* model = FindModel(model_name);
  MeasurementSetup s;
  s.model = model;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal;
  for (int k = 0; k < model->num_params; ++k) {
    UncertainInput in;
    in.name = model->params[k].name;
    in.unit = model->params[k].unit;
    in.u = model->params[k].default_u;
    in.estimate = state_scale * in.u * normal(rng);
    s.params.push_back(in);
  }
  s.noise = {1.0e-6, 0.2e-6, 0.5e-6, 0.5e-6};
  return s;
}

}  // namespace vlt::test
