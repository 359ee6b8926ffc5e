// mcm_trial_model.cc — the per-point measurement function of the Monte Carlo job kernel with
// the shared-input stages computed once per trial (mcm_engine.h TrialModel). It repeats the
// arithmetic of MeasurementModel::Evaluate / EvaluateTracker (vlt/measurement_model.h):
//   rho' = rho * (n_est / n),   x_t = f(rho', A, E; params),   y = s (R x_t + t)
// in the same order, so the values are identical bit for bit (tests/test_mcm.cc
// McmTrialModel.SameAsMeasurementModelBitForBit).
#include "mcm_engine.h"
#include "vlt/refractive_index.h"

namespace vlt::mcm_internal {

TrialModel::TrialModel(const MeasurementModel& model)
    : model_(model),
      forward_(model.setup().model->forward),
      environment_(model.environment_offset() >= 0),
      pose_(model.pose_offset() >= 0),
      thermal_(model.thermal_offset() >= 0) {}

void TrialModel::Prepare(const double* shared, State* state) const {
  if (environment_) {
    const Environment& e = *model_.setup().environment;
    const double* env = shared + model_.environment_offset();
    AirConditions air;
    air.vacuum_wavelength = e.vacuum_wavelength;
    air.temperature = env[0];
    air.pressure = env[1];
    air.humidity = env[2];
    air.co2 = env[3];
    const AirEquation equation = e.equation == Environment::Equation::kCiddor
                                     ? AirEquation::kCiddor
                                     : AirEquation::kEdlenBoensch;
    state->range_scale = model_.refractive_index_estimate() /
                         AirRefractiveIndexValue(equation, air, "environment");
  }
  if (pose_) {
    state->rotation = model_.PoseRotation(shared);
    state->translation = model_.PoseTranslation(shared);
  }
  if (thermal_) state->thermal_scale = model_.ThermalScale(shared);
}

void TrialModel::Evaluate(const double* readings, const double* shared, const State& state,
                          double* y) const {
  double corrected[3] = {readings[0], readings[1], readings[2]};
  if (environment_) corrected[0] *= state.range_scale;
  Eigen::Vector3d x_t;
  forward_(corrected, shared, x_t.data());
  Eigen::Vector3d x = x_t;
  if (pose_) x = state.rotation * x_t + state.translation;
  if (thermal_) x *= state.thermal_scale;
  y[0] = x(0);
  y[1] = x(1);
  y[2] = x(2);
}

}  // namespace vlt::mcm_internal
