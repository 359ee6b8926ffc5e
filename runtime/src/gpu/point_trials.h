// gpu/point_trials.h — the Monte Carlo trials of measured points, in the C++ that compiles both on
// the host and, by NVRTC, as a GPU kernel (docs/gpu.md; base/portable_math.h says how). Each trial
// draws what the CPU engine draws for it (mcm/job.cc JobKernel, mcm/sampling.cc InputSampler) from
// the same keyed streams and runs the model's generated Forward on one lane (portable::Lane), so
// that its values have the CPU engine's bits: tests/test_gpu_kernel.cc compiles this header as
// C++ and compares it with the engine, value for value.
//
// Scope (what the kernel covers; mcm/job.cc KernelJob decides, docs/gpu.md): a tracker model
// with a lanes kernel, every error parameter independent and normal (or fixed: u = 0), no
// environment, pose or thermal inputs, the readings' noise normal. Other jobs run on the CPU.
#pragma once

#include "base/portable_math.h"

namespace vlt::gpu_internal {

namespace portable = base_internal::portable;
using portable::U64;

inline constexpr int kMaxParams = 32;

// What every trial of a job needs, copied once to the device (plain data, no pointers).
struct PointTrialsJob {
  U64 seed = 0;        // McmSettings::seed: the Philox key
  int num_params = 0;  // the tracker model's error parameters, streams 0 .. num_params - 1
  int num_points = 0;  // readings of point p: streams num_params + 3 p + j
  double param_estimate[kMaxParams] = {};
  double param_u[kMaxParams] = {};  // 0: fixed at the estimate (no draw, InputSampler's rule)
};

// One point's readings (range [m], azimuth, elevation [rad]) and their standard uncertainties
// (MeasurementModel::reading_uncertainty of the range), in an array beside the job.
struct TrialPoint {
  double reading[3] = {};
  double reading_u[3] = {};
};

// Point p of trial `trial`: y = its coordinates (tracker frame = part frame here, m). Model: a
// generated model namespace's Forward (vlt::gen::<model>), as a functor. Each (trial, point) is
// computed on its own (a GPU thread each), so the trial's parameters are drawn again for every
// point: the same draws (they depend on the seed, the trial and the stream only).
template <class Model>
VLT_PORTABLE void PointOfTrial(const PointTrialsJob& job, const TrialPoint& point, int p, U64 trial, double y[3]) {
  portable::Lane params[kMaxParams];
  for (int k = 0; k < job.num_params; ++k) {
    // mcm/sampling.cc: estimate + u z, or the estimate itself where u = 0.
    params[k] = job.param_u[k] == 0.0
                    ? job.param_estimate[k]
                    : job.param_estimate[k] + job.param_u[k] * portable::NormalOfTrial(job.seed, trial, static_cast<U64>(k));
  }
  portable::Lane readings[3], out[3];
  for (int j = 0; j < 3; ++j) {
    const U64 stream = static_cast<U64>(job.num_params + 3 * p + j);
    readings[j] = point.reading[j] + point.reading_u[j] * portable::NormalOfTrial(job.seed, trial, stream);
  }
  Model::Forward(readings, params, out);
  for (int a = 0; a < 3; ++a) y[a] = out[a].v;
}

}  // namespace vlt::gpu_internal
