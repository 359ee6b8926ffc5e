// Calibration (vlt/calibration.h Calibrate), one core:
//   calibration/identify/<model>   the B89.4.19-pattern data set of examples/layouts (511 scalar
//                                  observations: 156 readings, 35 bar positions, 1 bar
//                                  calibration, 7 reference distances; 20 error parameters,
//                                  120 targets): identifiability SVD, Ceres solve, covariance,
//                                  residual statistics — what `vlt calibrate` computes
//   calibration/simulate/<model>   simulating that data set (inverse of the model per reading),
//                                  for scale
//   calibration/prior/<profile>    `vlt prior`'s derivation for a shipped profile (the tests at
//                                  the compensation, the maximum-entropy solve, the two-face
//                                  factors): issue 35's target <= 2 s
// Target (docs/performance.md): identification < 1 s for 20 parameters and ~500 observations.
#include <string>

#include <benchmark/benchmark.h>

#include "vlt/calibration.h"
#include "vlt/models.h"

namespace vlt::bench {
namespace {

MeasurementSetup Tracker(const char* name) {
  const ModelInfo* model = FindModel(name);
  MeasurementSetup s;
  s.model = model;
  for (int k = 0; k < model->num_params; ++k) {
    UncertainInput in;
    in.name = model->params[k].name;
    in.u = model->params[k].default_u;
    in.estimate = (k % 3 - 1) * 0.8 * in.u;  // a definite error state, alternating signs
    s.params.push_back(in);
  }
  s.noise = {1.0e-6, 0.2e-6, 0.5e-6, 0.5e-6};
  return s;
}

const TestLayout& Layout() {
  static const TestLayout layout =
      LoadTestLayout(std::string(VLT_SOURCE_DIR) + "/examples/layouts/b89_4_19_2006.toml");
  return layout;
}

void BM_Identify(benchmark::State& state, const char* model) {
  const CalibrationData data = SimulateCalibrationData(Tracker(model), Layout(), 2026);
  int observations = 0;
  for (auto _ : state) {
    const CalibrationResult r = Calibrate(data);
    observations = r.observations;
    benchmark::DoNotOptimize(r.covariance.data());
  }
  state.counters["observations"] = observations;
  state.counters["parameters"] = FindModel(model)->num_params;
}

void BM_Simulate(benchmark::State& state, const char* model) {
  const MeasurementSetup tracker = Tracker(model);
  for (auto _ : state) {
    CalibrationData data = SimulateCalibrationData(tracker, Layout(), 2026);
    benchmark::DoNotOptimize(data.readings.data());
  }
}

void BM_Prior(benchmark::State& state, const char* profile) {
  const PriorJob job = LoadPriorJob(std::string(VLT_SOURCE_DIR) + "/profiles/" + profile + ".toml");
  int tests = 0;
  for (auto _ : state) {
    const PriorResult r = DerivePrior(job);
    tests = static_cast<int>(r.tests.size());
    benchmark::DoNotOptimize(r.parameters.data());
  }
  state.counters["tests"] = tests;
}

const bool kRegistered = [] {
  for (const char* profile : {"leica-at500", "faro-vantage", "mirror-15um-6um"}) {
    benchmark::RegisterBenchmark((std::string("calibration/prior/") + profile).c_str(), BM_Prior, profile)
        ->Unit(benchmark::kMillisecond);
  }
  for (const char* model : {"head", "mirror"}) {
    benchmark::RegisterBenchmark((std::string("calibration/identify/") + model).c_str(), BM_Identify, model)
        ->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark((std::string("calibration/simulate/") + model).c_str(), BM_Simulate, model)
        ->Unit(benchmark::kMillisecond);
  }
  return true;
}();

}  // namespace
}  // namespace vlt::bench
