// Custom models Y = f(X) on the GPU path (issue 37, docs/gpu.md "What the kernel covers"): the
// kernel's trials of a custom model are the CPU engine's bit for bit (mcm_internal::CustomTrialValues,
// the engine's own custom kernel, is the reference), and a custom-model job run with the kernel on
// the host in place of a GPU writes the CPU run's files byte for byte.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "gpu/point_trials.h"
#include "gpu/trials.h"
#include "mcm/engine.h"
#include "test_mcm_helpers.h"
#include "vlt/custom_job.h"
#include "vlt/distributions.h"
#include "vlt/error.h"
#include "vlt/results.h"

namespace vlt {
namespace {

std::uint64_t Bits(double x) { return std::bit_cast<std::uint64_t>(x); }

std::string ExampleJob(const char* name) {
  return (std::filesystem::path(VLT_SOURCE_DIR) / "examples" / "custom" / name).string();
}

// JCGM 101 9.2.2's additive model with every input normal but one fixed rectangular (u = 0: its
// estimate; the kernel draws them), the same with
// x1 and x2 correlated (r = 0.6) and x3 fixed, so that the CPU draws them through the copula, and
// GUM H.2's impedance (its sine and cosine vlt's own on both sides: the CPU engine runs the model's
// lanes kernel) with its spec's normal inputs, V and phi correlated (r = -0.7) in a second job.
constexpr const char* kAllNormal = R"(
[job]
name = "additive_normal"
[model]
name = "jcgm101_additive"
[inputs.x4]
u = 0
distribution = "rectangular"
[monte_carlo]
trials = 20000
seed = 11
)";
constexpr const char* kCorrelated = R"(
[job]
name = "additive_correlated"
[model]
name = "jcgm101_additive"
[inputs.x3]
u = 0
[correlations.pair]
inputs = ["x1", "x2"]
matrix = [[1.0, 0.6], [0.6, 1.0]]
[monte_carlo]
trials = 20000
seed = 12
)";
constexpr const char* kImpedance = R"(
[job]
name = "impedance"
[model]
name = "gum_h2_impedance"
[monte_carlo]
trials = 20000
seed = 13
)";
constexpr const char* kImpedanceCorrelated = R"(
[job]
name = "impedance_correlated"
[model]
name = "gum_h2_impedance"
[correlations.source]
inputs = ["V", "phi"]
matrix = [[1.0, -0.7], [-0.7, 1.0]]
[monte_carlo]
trials = 20000
seed = 14
)";

// GUM H.2's impedance from 7 simultaneous observations of V, I and phi (JCGM 102 6.5.3: one
// multivariate t of nu = n - N = 4 over the three, drawn on the CPU), in dir.
CustomJob ImpedanceFromObservations() {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "vlt-gpu-custom";
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "observations.csv") << "V,I_amp,phi\n5.007,0.019663,1.0456\n4.994,0.019639,1.0438\n"
                                             "5.005,0.019640,1.0468\n4.990,0.019685,1.0428\n4.999,0.019678,1.0433\n"
                                             "5.003,0.019660,1.0450\n4.996,0.019655,1.0441\n";
  return ParseCustomJob(R"(
[job]
name = "impedance_observed"
[model]
name = "gum_h2_impedance"
[observations]
file = "observations.csv"
simultaneous = true
[inputs.V]
observations = "V"
[inputs.I_amp]
observations = "I_amp"
[inputs.phi]
observations = "phi"
[monte_carlo]
trials = 20000
seed = 15
)",
                        "impedance_observed.toml", dir);
}

// The custom jobs of the GPU path: the four above, the observed impedance and the examples whose
// models the kernel carries (rectangular inputs, the mass calibration's buoyancy, GUM H.1's
// t-distributed inputs and tolerance).
std::vector<CustomJob> KernelJobs() {
  std::vector<CustomJob> jobs = {ParseCustomJob(kAllNormal, "normal.toml", "."),
                                 ParseCustomJob(kCorrelated, "correlated.toml", "."),
                                 ParseCustomJob(kImpedance, "impedance.toml", "."),
                                 ParseCustomJob(kImpedanceCorrelated, "impedance_correlated.toml", "."),
                                 ImpedanceFromObservations()};
  for (const char* name : {"jcgm101_additive_dominant.toml", "jcgm101_additive_rectangular.toml",
                           "jcgm101_mass.toml", "gum_h1_end_gauge.toml"}) {
    jobs.push_back(LoadCustomJob(ExampleJob(name)));
  }
  return jobs;
}

// Whether the kernel can draw the job's inputs itself (each normal or fixed, none correlated with
// another, no multivariate t), decided here from the job, independently of mcm/custom.cc.
bool KernelDrawsTheInputs(const CustomJob& job) {
  if (!job.simultaneous.empty()) return false;
  for (std::size_t k = 0; k < job.mcm_inputs.size(); ++k) {
    const UncertainInput& input = job.mcm_inputs[k];
    if (input.u != 0.0 && Distribution::FromInput(input, "test").kind() != DistributionKind::kNormal) return false;
    for (std::size_t j = 0; j < job.mcm_inputs.size(); ++j) {
      if (j != k && job.correlation.size() > 0 && job.correlation(static_cast<Eigen::Index>(k), static_cast<Eigen::Index>(j)) != 0.0) {
        return false;
      }
    }
  }
  return true;
}

// Every output of every trial from an unaligned first trial, the host backend (the kernel's code)
// against the engine's custom kernel.
TEST(GpuCustom, TrialsAreTheCpuEnginesBitForBit) {
  int drawn_on_cpu = 0;
  for (const CustomJob& job : KernelJobs()) {
    SCOPED_TRACE(job.file);
    if (!job.simultaneous.empty()) continue;  // CustomTrialValues takes no multivariate t groups
    const std::uint64_t seed = 0xfedcba9876543210ull;
    const std::int64_t first = 77'777;
    const int n = 3000;
    const std::vector<double> engine =
        mcm_internal::CustomTrialValues(*job.model, job.mcm_inputs, job.correlation, seed, first, n);
    const gpu_internal::TrialsJob trials =
        test::CustomKernelTrials(*job.model, job.mcm_inputs, seed, KernelDrawsTheInputs(job));
    drawn_on_cpu += trials.job.params_drawn;
    const mcm_internal::CpuTrialInputs inputs = mcm_internal::CustomTrialInputs(
        *job.model, job.mcm_inputs, job.correlation, seed, first, n, mcm_internal::CpuTrialInputs::For(trials.job));
    ASSERT_EQ(inputs.params.size(), trials.job.params_drawn ? static_cast<std::size_t>(trials.job.num_params) * n : 0u);
    const std::unique_ptr<gpu_internal::TrialsBackend> host = gpu_internal::HostBackend(trials);
    ASSERT_NE(host, nullptr) << job.model->name;
    std::vector<double> values(engine.size());
    host->Compute(static_cast<std::uint64_t>(first), n, inputs.prepared(), values.data());
    int differing = 0;
    for (std::size_t v = 0; v < values.size(); ++v) differing += Bits(values[v]) != Bits(engine[v]);
    EXPECT_EQ(differing, 0) << "of " << values.size() << " values";
    // Not constants: the first output spreads.
    double mean = 0.0, sq = 0.0;
    for (int i = 0; i < n; ++i) mean += engine[static_cast<std::size_t>(i)] / n;
    for (int i = 0; i < n; ++i) sq += std::pow(engine[static_cast<std::size_t>(i)] - mean, 2) / (n - 1);
    EXPECT_GT(sq, 0.0);
  }
  EXPECT_GE(drawn_on_cpu, 4);  // the correlated pairs, the rectangular inputs, the mass's densities
  EXPECT_FALSE(ImpedanceFromObservations().simultaneous.empty());
}

std::map<std::string, std::string> FilesOf(const CustomResults& r) {
  std::map<std::string, std::string> files;
  for (const auto& [name, text] : ResultFiles(r)) files[name] = text;
  return files;
}

// A custom-model job end to end with the kernel on the host in place of a GPU: every file the same
// bytes as on the CPU but the lines that say where and how long the trials ran.
TEST(GpuCustom, TheSameFilesAsTheCpuWithTheKernelOnTheHost) {
  for (const CustomJob& job : KernelJobs()) {
    SCOPED_TRACE(job.file);
    RunOptions cpu;
    cpu.threads = 3;
    cpu.trials = 60000;  // several blocks of 4096 trials, from three threads
    cpu.device = McmDevice::kCpu;
    const CustomResults on_cpu = RunCustomJob(job, cpu);
    RunOptions gpu = cpu;
    gpu.device = McmDevice::kGpu;
    // The host backend, recording what the custom Monte Carlo hands it: who draws the inputs is
    // decided as KernelDrawsTheInputs decides it here.
    int params_drawn = -1;
    gpu_internal::SetBackendForTest([&params_drawn](const gpu_internal::TrialsJob& trials, std::string*) {
      params_drawn = trials.job.params_drawn;
      return gpu_internal::HostBackend(trials);
    });
    const CustomResults on_gpu = RunCustomJob(job, gpu);
    gpu_internal::SetBackendForTest(nullptr);
    EXPECT_EQ(params_drawn, KernelDrawsTheInputs(job) ? 0 : 1);
    ASSERT_TRUE(on_cpu.has_mcm && on_gpu.has_mcm);
    std::map<std::string, std::string> a = FilesOf(on_cpu), b = FilesOf(on_gpu);
    test::ExpectTheSameFilesButTheRunLines(a, b);
    EXPECT_NE(b["results.json"].find("\"gpu: host"), std::string::npos);
    EXPECT_GT(on_gpu.outputs[0].mcm.u, 0.0);
  }
}

// On a machine with a GPU (scripts/device-check.sh run gpu): the files of custom-model jobs from
// --device gpu against --device cpu, byte for byte but the lines that say where and how long the
// trials ran. Jobs given inline (the test runs there from a copy of the tree elsewhere): the normal
// and correlated additive ones, GUM H.2's impedance (sine and cosine), and JCGM 101 9.3's mass
// calibration as the model's defaults have it
// (three rectangular inputs: drawn on the CPU). Skipped, with the reason, where no GPU works.
TEST(GpuCustom, OnARealGpuTheSameFilesAsTheCpu) {
  const gpu_internal::TrialsJob probe = test::CustomKernelTrials(*FindModel("jcgm101_mass"), {}, 1, true);
  std::string why_not;
  if (gpu_internal::CudaBackend(probe, &why_not) == nullptr) GTEST_SKIP() << "no GPU: " << why_not;
  const std::vector<CustomJob> jobs = {ParseCustomJob(kAllNormal, "normal.toml", "."),
                                       ParseCustomJob(kCorrelated, "correlated.toml", "."),
                                       ParseCustomJob(kImpedance, "impedance.toml", "."),
                                       ParseCustomJob("[job]\nname = \"mass\"\n[model]\nname = \"jcgm101_mass\"\n"
                                                      "[monte_carlo]\ntrials = 1000000\nseed = 3\n",
                                                      "mass.toml", ".")};
  for (const CustomJob& job : jobs) {
    SCOPED_TRACE(job.file);
    RunOptions cpu;
    cpu.device = McmDevice::kCpu;
    RunOptions gpu;
    gpu.device = McmDevice::kGpu;
    const CustomResults on_cpu = RunCustomJob(job, cpu), on_gpu = RunCustomJob(job, gpu);
    EXPECT_EQ(on_gpu.mcm.device.rfind("gpu: ", 0), 0u) << on_gpu.mcm.device;
    test::ExpectTheSameFilesButTheRunLines(FilesOf(on_cpu), FilesOf(on_gpu));
  }
}

}  // namespace
}  // namespace vlt
