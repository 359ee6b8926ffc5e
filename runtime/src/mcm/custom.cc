// mcm/custom.cc — Monte Carlo for a custom model Y = f(X) (vlt/mcm.h RunMcmCustom), the
// JCGM 101 §9 examples and anything else without readings.
#include <string>
#include <string_view>
#include <vector>

#include "mcm/engine.h"
#include "vlt/error.h"
#include "vlt/mcm.h"

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

class CustomKernel final : public mcm_internal::TrialKernel {
 public:
  CustomKernel(const ModelInfo& model, std::span<const UncertainInput> inputs,
               const Eigen::MatrixXd& correlation, std::span<const MultivariateTGroup> t_groups)
      : model_(model),
        sampler_(Distributions(model, inputs), Names(inputs), correlation, 0,
                 std::string("model '") + model.name + "': input correlation", t_groups) {}

  int num_outputs() const override { return model_.num_outputs; }

  void InitScratch(Scratch& scratch) const override {
    const std::size_t p = static_cast<std::size_t>(model_.num_params);
    // params SoA | copula scratch | one trial's params | one trial's outputs
    scratch.doubles.assign(
        p * kSubBatch + sampler_.scratch_size(kSubBatch) + p + static_cast<std::size_t>(model_.num_outputs),
        0.0);
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
    double* x = copula + sampler_.scratch_size(kSubBatch);
    double* y = x + np;
    for (int i = 0; i < n; ++i) {
      for (int k = 0; k < np; ++k) x[k] = soa[static_cast<std::size_t>(k) * kSubBatch + i];
      model_.forward(nullptr, x, y);
      for (int o = 0; o < no; ++o) outputs[static_cast<std::size_t>(o) * kSubBatch + i] = y[o];
    }
  }

 private:
  const ModelInfo& model_;
  InputSampler sampler_;
};

}  // namespace

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
  // The GPU kernel covers the points of tracker jobs (docs/gpu.md), not custom models.
  constexpr const char* kNoKernel = "the GPU kernel covers the points of tracker jobs, not custom models";
  if (settings.device == McmDevice::kGpu) throw InputError(settings.device_where + ": \"gpu\": " + kNoKernel);
  McmResult result = mcm_internal::RunEngine(kernel, spec, settings);
  if (settings.device == McmDevice::kAuto) result.device_note = kNoKernel;
  return result;
}

}  // namespace vlt
