// mcm/custom.cc — Monte Carlo for a custom model Y = f(X) (vlt/mcm.h RunMcmCustom), the
// JCGM 101 §9 examples and anything else without readings.
#include <algorithm>
#include <cctype>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "gpu/trials.h"
#include "mcm/engine.h"
#include "mcm/gpu_run.h"
#include "vlt/error.h"
#include "vlt/mcm.h"
#include "vlt/models.h"

namespace vlt {
namespace {

using mcm_internal::InputSampler;
using mcm_internal::KeyedStream;
using mcm_internal::kSubBatch;
using mcm_internal::Scratch;

std::vector<Distribution> Distributions(const ModelInfo& model, std::span<const UncertainInput> inputs) {
  std::vector<Distribution> out;
  for (const UncertainInput& input : inputs) {
    out.push_back(Distribution::FromInput(input, std::string("model '") + model.name + "'"));
  }
  return out;
}

std::vector<std::string> Names(std::span<const UncertainInput> inputs) {
  std::vector<std::string> out;
  for (const UncertainInput& input : inputs) out.push_back(input.name);
  return out;
}

class CustomKernel final : public mcm_internal::MirroredKernel {
 public:
  CustomKernel(const ModelInfo& model, std::span<const UncertainInput> inputs,
               const Eigen::MatrixXd& correlation, std::span<const MultivariateTGroup> t_groups)
      : model_(model),
        sampler_(Distributions(model, inputs), Names(inputs), correlation, 0,
                 std::string("model '") + model.name + "': input correlation", t_groups) {}

  int num_outputs() const override { return model_.num_outputs; }

  void InitScratch(Scratch& scratch) const override {
    const std::size_t p = static_cast<std::size_t>(model_.num_params);
    const std::size_t o = static_cast<std::size_t>(model_.num_outputs);
    // params SoA | copula scratch | one trial's params | one trial's outputs | params and outputs
    // of kForwardLanes trials
    scratch.doubles.assign(p * kSubBatch + sampler_.scratch_size(kSubBatch) + p + o + (p + o) * kForwardLanes, 0.0);
  }

  std::vector<double> AtEstimates() const override {
    std::vector<double> x;
    for (const Distribution& d : sampler_.inputs()) x.push_back(d.estimate());
    std::vector<double> y(model_.num_outputs);
    model_.forward(nullptr, x.data(), y.data());
    return y;
  }

  void Run(const KeyedStream& rng, std::int64_t first, int n, Scratch& scratch,
           double* outputs) const override {
    const int np = model_.num_params, no = model_.num_outputs;
    double* soa = scratch.doubles.data();
    double* copula = soa + static_cast<std::size_t>(np) * kSubBatch;
    sampler_.Draw(rng, first, n, soa, kSubBatch, copula);
    double* x = copula + sampler_.scratch_size(kSubBatch);
    double* y = x + np;
    if (model_.forward_lanes != nullptr) return RunLanes(soa, n, y + no, outputs);
    if (model_.forward_batch != nullptr) {
      const double* params[64];
      double* outs[64];
      if (np <= 64 && no <= 64) {
        for (int k = 0; k < np; ++k) params[k] = soa + static_cast<std::size_t>(k) * kSubBatch;
        for (int o = 0; o < no; ++o) outs[o] = outputs + static_cast<std::size_t>(o) * kSubBatch;
        model_.forward_batch(static_cast<std::size_t>(n), nullptr, params, outs);
        return;
      }
    }
    for (int i = 0; i < n; ++i) {
      for (int k = 0; k < np; ++k) x[k] = soa[static_cast<std::size_t>(k) * kSubBatch + i];
      model_.forward(nullptr, x, y);
      for (int o = 0; o < no; ++o) outputs[static_cast<std::size_t>(o) * kSubBatch + i] = y[o];
    }
  }

  // kForwardLanes trials at a time through the model's SIMD kernel (base/lanes.h: vlt's own sine
  // and cosine, whose bits the GPU kernel's lane shares; + - * / and sqrt as the double kernel's),
  // the last group padded with the sub-batch's last trial, whose extra results are dropped (each
  // lane is computed on its own). soa: the drawn inputs; lanes: (params + outputs) kForwardLanes.
  void RunLanes(const double* soa, int n, double* lanes, double* outputs) const {
    constexpr int kL = kForwardLanes;
    const int np = model_.num_params, no = model_.num_outputs;
    double* p = lanes;
    double* y = lanes + static_cast<std::size_t>(np) * kL;
    for (int i = 0; i < n; i += kL) {
      if (i + kL <= n) {  // a whole group, read and written in place (rows of kSubBatch)
        model_.forward_lanes(nullptr, soa + i, outputs + i, kSubBatch, kSubBatch);
        continue;
      }
      for (int k = 0; k < np; ++k) {
        for (int l = 0; l < kL; ++l) p[kL * k + l] = soa[static_cast<std::size_t>(k) * kSubBatch + std::min(i + l, n - 1)];
      }
      model_.forward_lanes(nullptr, p, y, kL, kL);
      for (int o = 0; o < no; ++o) std::copy(y + kL * o, y + kL * o + (n - i), outputs + static_cast<std::size_t>(o) * kSubBatch + i);
    }
  }

  // The GPU kernel's inputs (gpu/point_trials.h): the model's inputs as Run draws them, where the
  // CPU draws them (CustomKernelJob); a custom model has no stages.
  void PrepareTrials(const KeyedStream& rng, std::int64_t first, int n, Scratch& scratch,
                     gpu_internal::TrialStages* /*stages*/, double* params, std::int64_t stride) const override {
    if (params == nullptr) return;
    const int np = model_.num_params;
    double* soa = scratch.doubles.data();
    sampler_.Draw(rng, first, n, soa, kSubBatch, soa + static_cast<std::size_t>(np) * kSubBatch);
    for (int k = 0; k < np; ++k) {
      const double* row = soa + static_cast<std::size_t>(k) * kSubBatch;
      std::copy(row, row + n, params + k * stride);
    }
  }
  // A custom model's outputs are all the device's.
  void RunTasks(int, Scratch&, double*) const override {}

  const InputSampler& sampler() const { return sampler_; }

 private:
  const ModelInfo& model_;
  InputSampler sampler_;
};

// Whether `model` is compiled into vlt (else built at run time: vlt/models.h BuildModel).
bool IsBuiltIn(const ModelInfo& model) {
  for (const ModelInfo* built_in : AllModels()) {
    if (built_in == &model) return true;
  }
  return false;
}

// The functions the generated Forward in `header` calls (each identifier followed by "(" in its
// body, vlt-gen's layout: one template function, closed by a "}" alone on its line), in order of
// appearance, each once.
std::vector<std::string> ForwardCalls(const std::string& header) {
  std::vector<std::string> calls;
  const std::size_t begin = header.find("\nvoid Forward(");
  if (begin == std::string::npos) return {"(no Forward)"};
  const std::size_t body = header.find('{', begin);
  const std::size_t end = header.find("\n}\n", body);
  if (body == std::string::npos || end == std::string::npos) return {"(no Forward)"};
  const auto is_word = [](char c) { return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_'; };
  for (std::size_t i = body + 1; i < end; ++i) {
    if (header[i] != '(' || i == 0 || !is_word(header[i - 1])) continue;
    std::size_t start = i;
    while (start > body && is_word(header[start - 1])) --start;
    const std::string name = header.substr(start, i - start);
    if (std::find(calls.begin(), calls.end(), name) == calls.end()) calls.push_back(name);
  }
  return calls;
}

// The generated header of a model built at run time, if the kernel can run its Forward with the
// CPU's bits: the CPU path runs the library's double Forward, so its Forward may call nothing but
// sqrt (correctly rounded on both; sin, cos and the rest are the C library's on the CPU). Else
// empty, with *why_not.
std::string BuiltModelKernelSource(const ModelInfo& model, std::string* why_not) {
  std::string source = BuiltModelSource(model);
  if (source.empty()) {
    *why_not = std::string("model '") + model.name +
               "': no generated source the GPU kernel can compile beside its library in the model cache (a model "
               "built before 2026-11-28: vlt model build builds it again)";
    return "";
  }
  std::string others;
  for (const std::string& call : ForwardCalls(source)) {
    if (call != "sqrt") others += (others.empty() ? "" : ", ") + call;
  }
  if (!others.empty()) {
    *why_not = std::string("the GPU kernel runs a built model whose equations are + - * / and sqrt only; '") +
               model.name + "' calls " + others + " (the C library's on the CPU, whose bits a GPU need not have)";
    return "";
  }
  return source;
}

// The GPU kernel's job for a custom model (gpu/point_trials.h: no readings, one "point" whose
// outputs are the model's), or why the kernel does not cover it. The kernel draws the inputs itself
// where each is normal or fixed (u = 0) and correlated with no other, from the streams the CPU uses
// (input k: stream k); otherwise the CPU draws them all (the copula and the inverse CDFs call libm)
// and hands them over (PointTrialsJob::params_drawn).
std::optional<gpu_internal::TrialsJob> CustomKernelJob(const ModelInfo& model, const InputSampler& sampler,
                                                       const Eigen::MatrixXd& correlation,
                                                       std::span<const MultivariateTGroup> t_groups,
                                                       std::uint64_t seed, std::string* why_not) {
  const auto refuse = [&](const std::string& why) {
    *why_not = why;
    return std::nullopt;
  };
  std::string source;
  if (!IsBuiltIn(model)) {
    source = BuiltModelKernelSource(model, why_not);
    if (source.empty()) return std::nullopt;
  } else if (!gpu_internal::KernelHasModel(model.name)) {
    return refuse(std::string("the GPU kernel has no model '") + model.name + "'");
  }
  if (model.num_params > gpu_internal::kMaxParams || model.num_outputs > gpu_internal::kMaxOutputs) {
    return refuse("the GPU kernel takes at most " + std::to_string(gpu_internal::kMaxParams) + " inputs and " +
                  std::to_string(gpu_internal::kMaxOutputs) + " outputs");
  }
  gpu_internal::TrialsJob trials;
  trials.model = model.name;
  trials.model_source = std::move(source);
  gpu_internal::PointTrialsJob& kernel = trials.job;
  kernel.seed = seed;
  kernel.num_params = model.num_params;
  kernel.num_points = 1;
  kernel.readings_per_point = 0;
  kernel.outputs_per_point = model.num_outputs;
  kernel.first_reading_stream = model.num_params;  // no readings: unused
  bool device_draws = t_groups.empty();
  for (Eigen::Index i = 0; i < correlation.rows(); ++i) {
    for (Eigen::Index j = 0; j < correlation.cols(); ++j) device_draws = device_draws && (i == j || correlation(i, j) == 0.0);
  }
  for (int k = 0; k < model.num_params; ++k) {
    const Distribution& d = sampler.inputs()[static_cast<std::size_t>(k)];
    device_draws = device_draws && (d.u() == 0.0 || d.kind() == DistributionKind::kNormal);
    kernel.param_estimate[k] = d.estimate();
    kernel.param_u[k] = d.u();
  }
  kernel.params_drawn = device_draws ? 0 : 1;
  trials.points.resize(1);
  return trials;
}

}  // namespace

std::vector<double> mcm_internal::CustomTrialValues(const ModelInfo& model, std::span<const UncertainInput> inputs,
                                                    const Eigen::MatrixXd& correlation, std::uint64_t seed,
                                                    std::int64_t first, int n) {
  const CustomKernel kernel(model, inputs, correlation, {});
  return mcm_internal::CpuTrialValues(kernel, model.num_outputs, seed, first, n);
}

mcm_internal::CpuTrialInputs mcm_internal::CustomTrialInputs(const ModelInfo& model,
                                                             std::span<const UncertainInput> inputs,
                                                             const Eigen::MatrixXd& correlation, std::uint64_t seed,
                                                             std::int64_t first, int n, CpuTrialInputs::What what) {
  const CustomKernel kernel(model, inputs, correlation, {});
  return mcm_internal::CpuPreparedInputs(kernel, seed, first, n, what);
}

McmResult RunMcmCustom(const ModelInfo& model, std::span<const UncertainInput> inputs,
                       const Eigen::MatrixXd& correlation, const McmSettings& settings,
                       std::span<const MultivariateTGroup> t_groups) {
  if (std::string_view(model.kind) != "custom") {
    throw InputError(std::string("Monte Carlo: model '") + model.name +
                     "' is not a custom model (use a job for tracker models)");
  }
  if (static_cast<int>(inputs.size()) != model.num_params) {
    throw InputError(std::string("Monte Carlo: model '") + model.name + "' has " +
                     std::to_string(model.num_params) + " inputs, " + std::to_string(inputs.size()) +
                     " given");
  }
  const CustomKernel kernel(model, inputs, correlation, t_groups);
  mcm_internal::OutputSpec spec;
  for (int o = 0; o < model.num_outputs; ++o) {
    spec.names.emplace_back(model.outputs[o].name);
    spec.units.emplace_back(model.outputs[o].unit);
  }
  if (model.num_outputs >= 2) spec.groups.push_back({model.name, 0, model.num_outputs, false});
  McmResult where;
  std::unique_ptr<mcm_internal::GpuTrialKernel> gpu;
  if (settings.device != McmDevice::kCpu) {
    std::string why_not;
    const auto trials = CustomKernelJob(model, kernel.sampler(), correlation, t_groups, settings.seed, &why_not);
    gpu = mcm_internal::GpuKernelFor(kernel, trials, why_not, settings, where);
  }
  McmResult result =
      mcm_internal::RunEngine(gpu ? static_cast<const mcm_internal::TrialKernel&>(*gpu) : kernel, spec, settings);
  result.device_note = where.device_note;
  mcm_internal::NoteDevice(gpu.get(), result);
  return result;
}

}  // namespace vlt
