// gpu/trials.h — where the trials of a GPU Monte Carlo are computed (docs/gpu.md): a backend
// computes the values of a block of trials of a PointTrialsJob; the Monte Carlo engine
// (mcm/gpu_run.cc GpuTrialKernel) asks it for blocks and does every statistic on the CPU from the values, as for
// its own trials. Two backends run the same kernel code (gpu/point_trials.h): the GPU, through the
// CUDA driver and NVRTC loaded at run time (gpu/cuda.cc), and the host (the tests' stand-in for a
// GPU: the whole GPU path without one).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "gpu/point_trials.h"

namespace vlt::gpu_internal {

// What the CPU prepared for a block of n trials: stages[i], trial i's stages, where the job has any
// (PointTrialsJob air, pose, thermal), else nullptr; params[k n + i], parameter k of trial i, where
// the CPU drew them (PointTrialsJob params_drawn), else nullptr.
struct PreparedTrials {
  const TrialStages* stages = nullptr;
  const double* params = nullptr;
};

class TrialsBackend {
 public:
  virtual ~TrialsBackend() = default;
  // values[o * n + i] = output o (x, y, z of each point; a custom model's outputs) of trial
  // first + i, i < n: every one of them written (the buffer is an earlier block's, not zeroed).
  virtual void Compute(std::uint64_t first, int n, const PreparedTrials& prepared, double* values) = 0;
  // "NVIDIA H100 80GB HBM3 (compute 9.0; CUDA driver 13.0, NVRTC 13.0)" or "host (GPU kernel code on the CPU)".
  virtual std::string Description() const = 0;
};

// The generated models the kernel carries: the tracker models with a lanes kernel (mirror, head,
// total_station) and the built-in custom models (jcgm101_additive, jcgm101_mass,
// gum_h1_end_gauge: + - * / only; gum_h2_impedance: sin and cos, its CPU engine running its lanes
// kernel).
bool KernelHasModel(std::string_view model_name);

// The job's trials: the settings every trial shares, its points (job.num_points of them) and the
// generated model (KernelHasModel, or a built model's source).
struct TrialsJob {
  PointTrialsJob job;
  std::vector<TrialPoint> points;
  std::string model;
  // A model built at run time (vlt/models.h BuiltModelSource): its generated header, which the
  // kernel compiles in place of an embedded one; empty for a built-in model. Only the GPU backend
  // runs it (HostBackend has no compiled instance of it).
  std::string model_source;
};

// The backend that runs the kernel code on the host, one (trial, point) after another (tests);
// nullptr for a model it has no compiled instance of (KernelHasModel false, or a built model).
std::unique_ptr<TrialsBackend> HostBackend(const TrialsJob& job);

// The GPU backend; nullptr with *why_not (one line: "no NVIDIA driver (libcuda.so.1: cannot open
// shared object file)", "NVRTC: ...") when no GPU works here.
std::unique_ptr<TrialsBackend> CudaBackend(const TrialsJob& job, std::string* why_not);

// Tests: replaces CudaBackend by `factory` (nullptr restores it), so that the GPU path is checked
// where no GPU is.
using BackendFactory = std::function<std::unique_ptr<TrialsBackend>(const TrialsJob&, std::string*)>;
void SetBackendForTest(BackendFactory factory);
std::unique_ptr<TrialsBackend> MakeBackend(const TrialsJob& job, std::string* why_not);

}  // namespace vlt::gpu_internal
