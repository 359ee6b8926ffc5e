// The Monte Carlo engine (vlt/mcm.h RunMcm) and the ceiling of its per-trial work:
//   mcm/run/point/M:<trials>/threads:<t>  one plan point (5 m, mid-panel), every error parameter
//                                         of the mirror model: trials/s = model evaluations/s,
//                                         including sampling, statistics, coverage intervals
//                                         and the JCGM 102 coverage region
//   mcm/run/plane36/...                   the demo job's 36 panel points + the plane fit refitted
//                                         in every trial (items = trials; point_evals/s counter)
//   mcm/scaling/{point,plane36}/...      the same at 10^7 (point) and 10^6 (plane36) trials on 1, 2,
//                                         4, 8, 16 threads, up to the machine's cores
//   mcm/ceiling/*                         a tight loop of the same per-trial work without the
//                                         engine: 23 SIMD Box-Muller normals + ForwardLanes
//   mcm/gpu_prepare/{air,parameters,both} what the CPU prepares for each trial of the GPU kernel
//                                         (docs/gpu.md), 65 536 trials on one thread: the air's
//                                         range scale (Ciddor), the mirror's 20 parameters drawn
//                                         (one rectangular), or both
//   mcm/gpu_path/air/M:1048576/threads:<t> the whole GPU path of a one-point job with the air on a
//                                         stand-in device that costs nothing (it copies the CPU
//                                         engine's values, computed before the run): the engine's
//                                         threads preparing the blocks and doing the statistics
// Wall-clock time (UseRealTime): the engine runs its own threads.
#include <array>
#include <chrono>
#include <cstdint>
#include <algorithm>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <benchmark/benchmark.h>

#include "bench_common.h"
#include "bench_kernels.h"
#include "gpu/trials.h"
#include "mcm/engine.h"
#include "mcm/gpu_run.h"
#include "mcm/random.h"
#include "vlt/gum.h"
#include "vlt/mcm.h"
#include "vlt/tasks.h"

namespace vlt::bench {
namespace {

McmSettings Settings(std::int64_t trials, int threads) {
  McmSettings s;
  s.seed = 20260101;
  s.trials = trials;
  s.num_threads = threads;
  s.quiet = true;
  return s;
}

void BM_McmPoint(benchmark::State& state, std::int64_t trials, int threads) {
  const MeasurementModel model(TrackerSetup("mirror"));
  McmJob job;
  job.model = &model;
  job.points.push_back({"P", ReadingsForPartPoint(model, Eigen::Vector3d(5.0, 0.25, -0.8))});
  McmResult result;
  for (auto _ : state) {
    result = RunMcm(job, Settings(trials, threads));
    benchmark::DoNotOptimize(result.outputs.data());
  }
  state.SetItemsProcessed(state.iterations() * trials);
  state.counters["u_x_um"] = result.outputs.at(0).u * 1e6;  // GUM: 10.5 um
}

void BM_McmPlane36(benchmark::State& state, std::int64_t trials, int threads) {
  const MeasurementModel model(TrackerSetup("mirror"));
  McmJob job;
  job.model = &model;
  // The demo job's 9 x 4 grid, 0.5 m pitch.
  TaskSpec plane;
  plane.name = "panel_plane";
  plane.kind = TaskKind::kPlane;
  std::vector<int> indices;
  for (int ix = 0; ix < 9; ++ix) {
    for (int iy = 0; iy < 4; ++iy) {
      const Eigen::Vector3d part(3.0 + 0.5 * ix, -0.75 + 0.5 * iy, -0.8);
      std::string name = "P";
      name += std::to_string(ix);
      name += std::to_string(iy);
      indices.push_back(static_cast<int>(job.points.size()));
      job.points.push_back({name, ReadingsForPartPoint(model, part)});
      plane.points.push_back(name);
    }
  }
  job.fit_tasks.push_back(plane);
  job.fit_task_points.push_back(indices);
  for (auto _ : state) {
    const McmResult result = RunMcm(job, Settings(trials, threads));
    benchmark::DoNotOptimize(result.outputs.data());
  }
  state.SetItemsProcessed(state.iterations() * trials);
  state.counters["point_evals/s"] =
      benchmark::Counter(static_cast<double>(state.iterations() * trials * 36), benchmark::Counter::kIsRate);
}

// 23 standard normals per trial from the engine's generator (NormalsBulk: Philox4x32-10 in SIMD
// lanes + Box-Muller, 256 trials of one input per call, as DrawNormals), scaled to the inputs,
// then the model's ForwardLanes (4 trials per call, as the job kernel).
template <bool kForward, bool kNormals>
void BM_McmCeiling(benchmark::State& state) {
  using K = MirrorKernels;
  constexpr int kInputs = 3 + K::kParams;
  const MeasurementModel model(TrackerSetup("mirror"));
  const Eigen::Vector3d estimate = ReadingsForPartPoint(model, Eigen::Vector3d(5.0, 0.25, -0.8));
  const Eigen::Matrix<double, kInputs, 1> u = InputUncertainties<kInputs>(model, estimate(0));
  const mcm_internal::KeyedStream rng(20260101);
  const ForwardLanesFn lanes = model.setup().model->forward_lanes;
  constexpr std::uint64_t kGroups = 1024;                        // 4096 trials per benchmark iteration
  constexpr int kBulk = mcm_internal::KeyedStream::kBulkGroups;  // 256 trials per block
  std::uint64_t group = 0;
  double sum = 0.0;
  std::vector<std::array<double, 4 * kBulk>> z(kInputs);
  for (auto _ : state) {
    for (std::uint64_t g = 0; g < kGroups; g += kBulk, group += kBulk) {
      if constexpr (kNormals) {
        for (int k = 0; k < kInputs; ++k)
          rng.NormalsBulk(group, kBulk, static_cast<std::uint64_t>(k), z[k].data());
      } else {
        for (int k = 0; k < kInputs; ++k) {
          for (int t = 0; t < 4 * kBulk; ++t) z[k][t] = 1e-3 * static_cast<double>((group + k + t) & 7);
        }
      }
      // kL trials at a time, structure of arrays, through the model's ForwardLanes (the engine's
      // path, docs/monte-carlo.md §11); the inputs alone summed without the model.
      constexpr int kL = kForwardLanes;
      for (int t0 = 0; t0 < 4 * kBulk; t0 += kL) {
        double x[kInputs * kL];
        for (int k = 0; k < kInputs; ++k) {
          for (int l = 0; l < kL; ++l) x[kL * k + l] = (k < 3 ? estimate(k) : 0.0) + u(k) * z[k][t0 + l];
        }
        if constexpr (kForward) {
          double y[3 * kL];
          lanes(x, x + 3 * kL, y, kL, kL);
          for (int q = 0; q < 3 * kL; ++q) sum += y[q];
        } else {
          for (int q = 0; q < kInputs * kL; ++q) sum += x[q];
        }
      }
    }
    benchmark::DoNotOptimize(sum);
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * kGroups * 4));
}

// What the CPU prepares for the GPU kernel's trials (mcm/job.cc InputsOfTrials through
// mcm_internal::JobTrialInputs): the stages where the job has the air, the parameters where one is
// not normal. Items = trials prepared: per thread, the most a GPU run of such a job can reach
// (the engine's threads share the preparation of each block with their other work).
void BM_GpuPrepare(benchmark::State& state, bool air, bool drawn) {
  MeasurementSetup setup = TrackerSetup("mirror", air);
  if (drawn) setup.params[0].distribution = "rectangular";
  const MeasurementModel model(setup);
  McmJob job;
  job.model = &model;
  job.points.push_back({"P", ReadingsForPartPoint(model, Eigen::Vector3d(5.0, 0.25, -0.8))});
  const mcm_internal::CpuTrialInputs::What what{air, drawn ? setup.model->num_params : 0};
  constexpr int kTrials = 65536;
  std::int64_t first = 0;
  for (auto _ : state) {
    const mcm_internal::CpuTrialInputs inputs = mcm_internal::JobTrialInputs(job, 20260101, first, kTrials, what);
    benchmark::DoNotOptimize(inputs.params.data());
    benchmark::DoNotOptimize(inputs.stages.data());
    first += kTrials;
  }
  state.SetItemsProcessed(state.iterations() * kTrials);
}

// A device that costs nothing: each block's values copied from the CPU engine's values of the
// run's trials (zeros past them), so that a GPU path run shows what the CPU's part costs. With
// `modelled`, each block also takes the time a GPU would, waiting (not computing) for it: the
// trials at 4·10^8 a second (the CuPy port on an H200) and the values back at 20 GB/s
// (PCIe, pageable memory) — a model, not a measurement, for what overlapping that time is worth.
class ReplayDevice final : public gpu_internal::TrialsBackend {
 public:
  ReplayDevice(std::shared_ptr<const std::vector<double>> values, std::int64_t trials, int outputs, bool modelled)
      : values_(std::move(values)), trials_(trials), outputs_(outputs), modelled_(modelled) {}
  void Compute(std::uint64_t first, int n, const gpu_internal::PreparedTrials&, double* values) override {
    const auto start = std::chrono::steady_clock::now();
    const std::int64_t begin = static_cast<std::int64_t>(first);
    const std::int64_t kept = std::clamp<std::int64_t>(trials_ - begin, 0, n);
    for (int o = 0; o < outputs_; ++o) {
      const double* from = values_->data() + static_cast<std::size_t>(o) * static_cast<std::size_t>(trials_) + begin;
      double* to = values + static_cast<std::size_t>(o) * static_cast<std::size_t>(n);
      std::copy(from, from + kept, to);
      std::fill(to + kept, to + n, 0.0);
    }
    if (modelled_) {
      const double seconds = n / 4e8 + static_cast<double>(n) * outputs_ * 8.0 / 20e9;
      std::this_thread::sleep_until(start + std::chrono::duration<double>(seconds));
    }
  }
  std::string Description() const override { return "replay"; }

 private:
  std::shared_ptr<const std::vector<double>> values_;
  std::int64_t trials_;
  int outputs_;
  bool modelled_;
};

// A one-point mirror job through the GPU path with the ReplayDevice: with the air (the CPU prepares
// each trial's stages), or plain (nothing prepared: the device's values copied out, and every
// statistic of the run — the rate of the CPU's part of the one-point job on a GPU);
// `modelled`: the device takes a GPU's time (ReplayDevice), with the next block computed while the
// engine uses this one (`ahead`, mcm/gpu_run.h AllowComputingAhead) or not.
void BM_GpuPath(benchmark::State& state, bool air, std::int64_t trials, int threads, bool modelled, bool ahead) {
  const MeasurementModel model(TrackerSetup("mirror", air));
  McmJob job;
  job.model = &model;
  job.points.push_back({"P", ReadingsForPartPoint(model, Eigen::Vector3d(5.0, 0.25, -0.8))});
  McmSettings settings = Settings(trials, threads);
  settings.device = McmDevice::kGpu;
  const auto values = std::make_shared<const std::vector<double>>(
      mcm_internal::JobTrialValues(job, settings.seed, 0, static_cast<int>(trials)));
  gpu_internal::SetBackendForTest([values, trials, modelled](const gpu_internal::TrialsJob& kernel, std::string*) {
    return std::make_unique<ReplayDevice>(values, trials, 3 * kernel.job.num_points, modelled);
  });
  mcm_internal::AllowComputingAhead(ahead);
  McmResult result;
  for (auto _ : state) {
    result = RunMcm(job, settings);
    benchmark::DoNotOptimize(result.outputs.data());
  }
  mcm_internal::AllowComputingAhead(true);
  gpu_internal::SetBackendForTest(nullptr);
  if (result.device != "gpu: replay") state.SkipWithError(("ran on " + result.device).c_str());
  state.SetItemsProcessed(state.iterations() * trials);
}

const bool kRegistered = [] {
  using benchmark::RegisterBenchmark;
  for (int threads : {1, 2}) {
    std::string t = "/threads:";
    t += std::to_string(threads);
    RegisterBenchmark(("mcm/run/point/M:10000" + t).c_str(), BM_McmPoint, 10000, threads)
        ->UseRealTime()
        ->Unit(benchmark::kMillisecond);
    RegisterBenchmark(("mcm/run/point/M:1000000" + t).c_str(), BM_McmPoint, 1000000, threads)
        ->UseRealTime()
        ->Iterations(3)
        ->Unit(benchmark::kMillisecond);
  }
  for (int threads : {1, 2}) {
    std::string name = "mcm/run/plane36/M:10000/threads:";
    name += std::to_string(threads);
    RegisterBenchmark(name.c_str(), BM_McmPlane36, 10000, threads)
        ->UseRealTime()
        ->Unit(benchmark::kMillisecond);
  }
  // Thread scaling (issue 33): 1, 2, 4, 8, 16 threads, as many as the machine has cores.
  const int cores = static_cast<int>(std::thread::hardware_concurrency());
  for (int threads : {1, 2, 4, 8, 16}) {
    if (threads > std::max(cores, 1)) break;
    const std::string t = "/threads:" + std::to_string(threads);
    RegisterBenchmark(("mcm/scaling/point/M:10000000" + t).c_str(), BM_McmPoint, 10000000, threads)
        ->UseRealTime()
        ->Iterations(1)
        ->Unit(benchmark::kMillisecond);
    RegisterBenchmark(("mcm/scaling/plane36/M:1000000" + t).c_str(), BM_McmPlane36, 1000000, threads)
        ->UseRealTime()
        ->Iterations(1)
        ->Unit(benchmark::kMillisecond);
  }
  RegisterBenchmark("mcm/ceiling/normals_and_forward", BM_McmCeiling<true, true>);
  RegisterBenchmark("mcm/ceiling/normals_only", BM_McmCeiling<false, true>);
  RegisterBenchmark("mcm/ceiling/forward_only", BM_McmCeiling<true, false>);
  RegisterBenchmark("mcm/gpu_prepare/air", BM_GpuPrepare, true, false)->UseRealTime()->Unit(benchmark::kMillisecond);
  RegisterBenchmark("mcm/gpu_prepare/parameters", BM_GpuPrepare, false, true)
      ->UseRealTime()
      ->Unit(benchmark::kMillisecond);
  RegisterBenchmark("mcm/gpu_prepare/both", BM_GpuPrepare, true, true)->UseRealTime()->Unit(benchmark::kMillisecond);
  for (int threads : {1, 2, 4, 8, 16}) {
    if (threads > std::max(cores, 1)) break;
    const std::string t = "/threads:" + std::to_string(threads);
    RegisterBenchmark(("mcm/gpu_path/air/M:1048576" + t).c_str(), BM_GpuPath, true, std::int64_t{1} << 20, threads,
                      false, true)
        ->UseRealTime()
        ->Iterations(3)
        ->Unit(benchmark::kMillisecond);
    RegisterBenchmark(("mcm/gpu_path/plain/M:4194304" + t).c_str(), BM_GpuPath, false, std::int64_t{1} << 22,
                      threads, false, true)
        ->UseRealTime()
        ->Iterations(3)
        ->Unit(benchmark::kMillisecond);
    for (const bool ahead : {false, true}) {
      RegisterBenchmark(("mcm/gpu_path/plain_modelled/M:4194304" + t + (ahead ? "/ahead" : "/one_at_a_time")).c_str(),
                        BM_GpuPath, false, std::int64_t{1} << 22, threads, true, ahead)
          ->UseRealTime()
          ->Iterations(3)
          ->Unit(benchmark::kMillisecond);
    }
  }
  return true;
}();

}  // namespace
}  // namespace vlt::bench
