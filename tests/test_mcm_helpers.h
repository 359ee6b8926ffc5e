// Shared by the Monte Carlo tests: a mirror-tracker measurement setup and a small job.
#pragma once

#include <cmath>
#include <cstdint>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "gpu/trials.h"
#include "vlt/mcm.h"
#include "vlt/measurement_model.h"
#include "vlt/models.h"

namespace vlt::test {

inline constexpr double kArcsec = 4.84813681109536e-6;

// A tracker model's error parameters at their generated defaults (estimate, u, distribution).
inline std::vector<UncertainInput> DefaultParams(const ModelInfo& model) {
  std::vector<UncertainInput> params;
  for (int k = 0; k < model.num_params; ++k) {
    const QuantityInfo& q = model.params[k];
    UncertainInput in;
    in.name = q.name;
    in.unit = q.unit;
    in.group = "parameter";
    in.estimate = q.default_estimate;
    in.u = q.default_u;
    in.distribution = q.default_distribution;
    in.shape = q.default_shape;
    params.push_back(in);
  }
  return params;
}

// The mirror tracker with every error parameter at its generated default (estimate 0, default u,
// normal), reading noise 5 um + 0.5 um/m, 1 arcsec, and a station pose.
inline MeasurementSetup MirrorSetup(bool pose = true) {
  MeasurementSetup setup;
  setup.model = FindModel("mirror");
  EXPECT_NE(setup.model, nullptr);
  setup.params = DefaultParams(*setup.model);
  setup.noise.range_a = 5e-6;
  setup.noise.range_b = 0.5e-6;
  setup.noise.azimuth = kArcsec;
  setup.noise.elevation = kArcsec;
  if (pose) {
    StationPose p;
    auto input = [](const char* name, const char* unit, double estimate, double u) {
      UncertainInput in;
      in.name = name;
      in.unit = unit;
      in.group = "pose";
      in.estimate = estimate;
      in.u = u;
      return in;
    };
    p.rx = input("pose.rx", "rad", 0.001, 2 * kArcsec);
    p.ry = input("pose.ry", "rad", -0.002, 2 * kArcsec);
    p.rz = input("pose.rz", "rad", 0.3, 2 * kArcsec);
    p.tx = input("pose.tx", "m", 1.0, 10e-6);
    p.ty = input("pose.ty", "m", -2.0, 10e-6);
    p.tz = input("pose.tz", "m", 0.5, 10e-6);
    setup.pose = p;
  }
  return setup;
}

// Readings of a few points 3 m .. 8 m away.
inline std::vector<McmPoint> SomePoints() {
  return {
      {"P1", {3.0, 0.2, 0.1}}, {"P2", {5.0, 0.6, -0.2}}, {"P3", {8.0, -0.4, 0.3}}, {"P4", {4.0, 1.2, 0.05}}};
}

}  // namespace vlt::test

namespace vlt::test {

// A custom ModelInfo around a plain function (forward only: exercises the engine's per-trial
// path; forward_batch stays null).
inline ModelInfo CustomModel(const char* name, int num_params, int num_outputs, const QuantityInfo* params,
                             const QuantityInfo* outputs, ForwardFn forward) {
  ModelInfo m{};
  m.name = name;
  m.kind = "custom";
  m.description = name;
  m.spec_file = "";
  m.num_readings = 0;
  m.num_params = num_params;
  m.num_outputs = num_outputs;
  m.params = params;
  m.outputs = outputs;
  m.forward = forward;
  return m;
}

// Settings of a quiet run: M = trials (0: adaptive, JCGM 101 7.9.4), threads 0 = all.
inline McmSettings Fixed(std::int64_t trials, std::uint64_t seed = 1, int threads = 0) {
  McmSettings s;
  s.trials = trials;
  s.seed = seed;
  s.num_threads = threads;
  s.quiet = true;
  return s;
}

inline UncertainInput Input(const char* name, double estimate, double u, const char* distribution = "normal",
                            double shape = 0.0) {
  UncertainInput in;
  in.name = name;
  in.unit = "1";
  in.group = "parameter";
  in.estimate = estimate;
  in.u = u;
  in.distribution = distribution;
  in.shape = shape;
  return in;
}

// A results.json text but the lines that say where and how long the trials ran, and when
// ("seconds", "gum_seconds", "mcm_seconds", "device", "device_note", "created"): what two runs of
// one job on different devices share byte for byte.
inline std::string WithoutRunLines(const std::string& text) {
  std::string out;
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);) {
    if (line.find("seconds\"") != std::string::npos || line.find("\"device") != std::string::npos ||
        line.find("\"created\"") != std::string::npos) {
      continue;
    }
    out += line + "\n";
  }
  return out;
}

// f() with the GPU kernel's code on the host standing in for a GPU (gpu/trials.h HostBackend):
// the whole GPU path without one. Returns what f returns.
template <class F>
auto WithTheKernelOnTheHost(F f) {
  gpu_internal::SetBackendForTest(
      [](const gpu_internal::TrialsJob& trials, std::string*) { return gpu_internal::HostBackend(trials); });
  struct Restore {
    ~Restore() { gpu_internal::SetBackendForTest(nullptr); }
  } restore;
  return f();
}

// Two runs' files (name -> bytes) the same: every file byte for byte but results.json, which is
// the same but its run lines (WithoutRunLines), and report.html (its timings and device).
inline void ExpectTheSameFilesButTheRunLines(std::map<std::string, std::string> a,
                                             std::map<std::string, std::string> b) {
  ASSERT_EQ(a.size(), b.size());
  for (const auto& [name, text] : a) {
    if (name == "results.json" || name == "report.html") continue;
    EXPECT_TRUE(text == b[name]) << name << " differs";
  }
  EXPECT_TRUE(WithoutRunLines(a["results.json"]) == WithoutRunLines(b["results.json"]));
}

// The GPU kernel's job for a custom model under `seed` (gpu/point_trials.h: no readings, one
// "point" of the model's outputs), built here independently of mcm/custom.cc: its inputs' estimates
// and u, drawn by the kernel (`kernel_draws`) or by the CPU.
inline gpu_internal::TrialsJob CustomKernelTrials(const ModelInfo& model, const std::vector<UncertainInput>& inputs,
                                                  std::uint64_t seed, bool kernel_draws) {
  gpu_internal::TrialsJob trials;
  trials.model = model.name;
  trials.points.resize(1);
  gpu_internal::PointTrialsJob& kernel = trials.job;
  kernel.seed = seed;
  kernel.num_params = model.num_params;
  kernel.num_points = 1;
  kernel.readings_per_point = 0;
  kernel.outputs_per_point = model.num_outputs;
  kernel.first_reading_stream = model.num_params;
  kernel.params_drawn = kernel_draws ? 0 : 1;
  for (int k = 0; k < model.num_params && k < static_cast<int>(inputs.size()); ++k) {
    kernel.param_estimate[k] = inputs[static_cast<std::size_t>(k)].estimate;
    kernel.param_u[k] = inputs[static_cast<std::size_t>(k)].u;
  }
  return trials;
}

}  // namespace vlt::test
