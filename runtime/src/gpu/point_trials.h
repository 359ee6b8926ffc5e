// gpu/point_trials.h — the Monte Carlo trials of measured points, in the C++ that compiles both on
// the host and, by NVRTC, as a GPU kernel (docs/gpu.md; base/portable_math.h says how). Each trial
// draws what the CPU engine draws for it (mcm/job.cc JobKernel, mcm/sampling.cc InputSampler) from
// the same keyed streams and runs the model's generated Forward on one lane (portable::Lane), so
// that its values have the CPU engine's bits: tests/test_gpu_kernel.cc compiles this header as
// C++ and compares it with the engine, value for value.
//
// Scope (what the kernel covers; mcm/job.cc and mcm/custom.cc decide, docs/gpu.md): a tracker
// model with a lanes kernel, the readings' noise normal; or a custom model Y = f(X) (no readings,
// one "point" of its outputs): a built-in one (of + - * / only, or with a lanes kernel, vlt's own
// sine and cosine, which its CPU engine runs), or one built at run time whose Forward calls nothing
// but + - * / and sqrt. The kernel draws the error parameters itself
// where each is independent and normal (or fixed: u = 0); where one is correlated with another
// input or not normal, the CPU draws them all (the copula and the inverse CDFs call libm, whose
// bits a GPU's functions need not have) and hands each trial's to the kernel (DrawnParams). The
// stages around the tracker model (air, station pose, part thermal expansion) depend on a trial's
// shared inputs only: the CPU draws and prepares them with the engine's own code and hands each
// trial's TrialStages to the kernel. Other jobs run on the CPU.
#pragma once

#include "base/portable_math.h"

namespace vlt::gpu_internal {

namespace portable = base_internal::portable;
using portable::U64;

inline constexpr int kMaxParams = 32;
inline constexpr int kMaxOutputs = 16;  // a point's outputs: 3 for a tracker, a custom model's count

// What every trial of a job needs, copied once to the device (plain data, no pointers).
struct PointTrialsJob {
  U64 seed = 0;        // McmSettings::seed: the Philox key
  // The model's parameters (a tracker's error parameters, a custom model's inputs): streams 0 ..
  // num_params - 1.
  int num_params = 0;
  int num_points = 0;  // readings of point p: streams first_reading_stream + 3 p + j
  // A tracker: 3 readings (range, azimuth, elevation) and 3 outputs (x, y, z) a point; a custom
  // model: no readings and its outputs (at most kMaxOutputs), one point. (readings_per_point is 3
  // or 0: the readings' streams are numbered 3 p + j.)
  int readings_per_point = 3;
  int outputs_per_point = 3;
  int first_reading_stream = 0;  // the shared inputs' count: num_params + air, pose, thermal inputs
  // Which stages are on (1) — each trial's TrialStages given when any is.
  int air = 0, pose = 0, thermal = 0;
  // 1: the CPU drew each trial's parameters (DrawnParams); 0: the kernel draws them from
  // param_estimate and param_u.
  int params_drawn = 0;
  double param_estimate[kMaxParams] = {};
  double param_u[kMaxParams] = {};  // 0: fixed at the estimate (no draw, InputSampler's rule)
};

// One trial's stages around the tracker model (MeasurementModel::PreparedShared), prepared on the
// CPU (mcm/job.cc): the air's refractive index calls libm (pow, exp), whose bits a GPU's
// functions need not have, and it is the same for every point of the trial.
struct TrialStages {
  double range_scale = 1.0;                          // n_est / n: the range is multiplied by it
  double rotation[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};  // R, column-major: R(i, j) = rotation[3 j + i]
  double translation[3] = {};                        // t [m]
  double thermal_scale = 1.0;                        // s = 1 / (1 + cte (T - T_ref))
};

// One trial's model parameters where the CPU drew them (PointTrialsJob::params_drawn): parameter
// k at values[k * stride]. A block's are parameter-major, values[k n + i] for its trial i, so that
// neighbouring GPU threads (neighbouring trials) read neighbouring doubles.
struct DrawnParams {
  const double* values = nullptr;
  U64 stride = 0;
};

// One point's readings (range [m], azimuth, elevation [rad]) and their standard uncertainties
// (MeasurementModel::reading_uncertainty of the range), in an array beside the job.
struct TrialPoint {
  double reading[3] = {};
  double reading_u[3] = {};
};

// y = s (R x_t + t) in place of x_t = y, each row summed left to right: MeasurementModel::Place's
// operations in its order (the part frame; x_t where no stage is on).
VLT_PORTABLE void PlaceOnPart(const PointTrialsJob& job, const TrialStages* stages, double y[3]) {
  if (job.pose) {
    const double x_t[3] = {y[0], y[1], y[2]};
    const double* r = stages->rotation;
    for (int i = 0; i < 3; ++i) {
      y[i] = ((r[i] * x_t[0] + r[3 + i] * x_t[1]) + r[6 + i] * x_t[2]) + stages->translation[i];
    }
  }
  if (job.thermal) {
    for (int i = 0; i < 3; ++i) y[i] *= stages->thermal_scale;
  }
}

// Point p of trial `trial`: y = its outputs, job.outputs_per_point of them (a tracker's: the
// point's part coordinates [m]); stages: the trial's (nullptr where no
// stage is on); drawn: the trial's parameters where the CPU drew them. Model: a generated model namespace's Forward (vlt::gen::<model>), as a functor.
// Each (trial, point) is computed on its own (a GPU thread each), so the trial's parameters are
// drawn again for every point: the same draws (they depend on the seed, the trial and the stream
// only).
template <class Model>
VLT_PORTABLE void PointOfTrial(const PointTrialsJob& job, const TrialPoint& point, int p, U64 trial,
                               const TrialStages* stages, DrawnParams drawn, double y[kMaxOutputs]) {
  portable::Lane params[kMaxParams];
  for (int k = 0; k < job.num_params; ++k) {
    if (job.params_drawn) {
      params[k] = drawn.values[static_cast<U64>(k) * drawn.stride];
    } else {
      // mcm/sampling.cc: estimate + u z, or the estimate itself where u = 0.
      params[k] = job.param_u[k] == 0.0 ? job.param_estimate[k]
                                        : job.param_estimate[k] + job.param_u[k] * portable::NormalOfTrial(
                                                                                       job.seed, trial, static_cast<U64>(k));
    }
  }
  portable::Lane readings[3], out[kMaxOutputs];
  for (int j = 0; j < job.readings_per_point; ++j) {
    const U64 stream = static_cast<U64>(job.first_reading_stream + 3 * p + j);
    readings[j] = point.reading[j] + point.reading_u[j] * portable::NormalOfTrial(job.seed, trial, stream);
  }
  // The air: the tracker converted optical path with n_est, the range is rho n_est / n.
  if (job.air) readings[0] = readings[0].v * stages->range_scale;
  Model::Forward(readings, params, out);
  for (int a = 0; a < job.outputs_per_point; ++a) y[a] = out[a].v;
  if (job.pose || job.thermal) PlaceOnPart(job, stages, y);
}

}  // namespace vlt::gpu_internal
