// The kernel code run on the host (gpu/trials.h HostBackend), and the choice of backend.
#include <mutex>
#include <utility>

#include "generated/gum_h1_end_gauge.h"
#include "generated/gum_h2_impedance.h"
#include "generated/head.h"
#include "generated/jcgm101_additive.h"
#include "generated/jcgm101_mass.h"
#include "generated/mirror.h"
#include "generated/total_station.h"
#include "gpu/trials.h"

namespace vlt::gpu_internal {
namespace {

using TrialFn = void (*)(const PointTrialsJob&, const TrialPoint&, int, U64, const TrialStages*, DrawnParams, double*);

// A generated model namespace as PointTrial's Model (the kernel source's is the same, gpu/cuda.cc).
#define VLT_KERNEL_MODEL(name)                                              \
  struct Model_##name {                                                     \
    template <class S>                                                      \
    static void Forward(const S* readings, const S* params, S* out) {       \
      gen::name::Forward<S>(readings, params, out);                         \
    }                                                                       \
  };
VLT_KERNEL_MODEL(mirror)
VLT_KERNEL_MODEL(head)
VLT_KERNEL_MODEL(total_station)
VLT_KERNEL_MODEL(jcgm101_additive)
VLT_KERNEL_MODEL(jcgm101_mass)
VLT_KERNEL_MODEL(gum_h1_end_gauge)
VLT_KERNEL_MODEL(gum_h2_impedance)
#undef VLT_KERNEL_MODEL

TrialFn TrialOf(std::string_view model_name) {
  if (model_name == "mirror") return &PointOfTrial<Model_mirror>;
  if (model_name == "head") return &PointOfTrial<Model_head>;
  if (model_name == "total_station") return &PointOfTrial<Model_total_station>;
  // The built-in custom models: + - * / only (the CPU engine's double kernel has the same bits),
  // or, gum_h2_impedance, with a lanes kernel (ModelInfo::forward_lanes), which the CPU engine runs,
  // so that its sine and cosine are vlt's own on both sides.
  if (model_name == "jcgm101_additive") return &PointOfTrial<Model_jcgm101_additive>;
  if (model_name == "jcgm101_mass") return &PointOfTrial<Model_jcgm101_mass>;
  if (model_name == "gum_h1_end_gauge") return &PointOfTrial<Model_gum_h1_end_gauge>;
  if (model_name == "gum_h2_impedance") return &PointOfTrial<Model_gum_h2_impedance>;
  return nullptr;
}

class Host final : public TrialsBackend {
 public:
  Host(const TrialsJob& job, TrialFn trial) : job_(job), trial_(trial) {}
  void Compute(std::uint64_t first, int n, const PreparedTrials& prepared, double* values) override {
    for (int p = 0; p < job_.job.num_points; ++p) {
      for (int i = 0; i < n; ++i) {
        double y[kMaxOutputs];
        const DrawnParams drawn{prepared.params == nullptr ? nullptr : prepared.params + i, static_cast<U64>(n)};
        trial_(job_.job, job_.points[static_cast<std::size_t>(p)], p, static_cast<U64>(first) + static_cast<U64>(i),
               prepared.stages == nullptr ? nullptr : prepared.stages + i, drawn, y);
        const int m = job_.job.outputs_per_point;
        for (int a = 0; a < m; ++a) values[static_cast<std::size_t>(m * p + a) * static_cast<std::size_t>(n) + i] = y[a];
      }
    }
  }
  std::string Description() const override { return "host (the GPU kernel's code on the CPU)"; }

 private:
  TrialsJob job_;
  TrialFn trial_;
};

std::mutex& FactoryMutex() {
  static std::mutex mutex;
  return mutex;
}
BackendFactory& Factory() {
  static BackendFactory factory;
  return factory;
}

}  // namespace

bool KernelHasModel(std::string_view model_name) { return TrialOf(model_name) != nullptr; }

std::unique_ptr<TrialsBackend> HostBackend(const TrialsJob& job) {
  const TrialFn trial = job.model_source.empty() ? TrialOf(job.model) : nullptr;
  return trial == nullptr ? nullptr : std::make_unique<Host>(job, trial);
}

void SetBackendForTest(BackendFactory factory) {
  const std::lock_guard<std::mutex> lock(FactoryMutex());
  Factory() = std::move(factory);
}

std::unique_ptr<TrialsBackend> MakeBackend(const TrialsJob& job, std::string* why_not) {
  BackendFactory factory;
  {
    const std::lock_guard<std::mutex> lock(FactoryMutex());
    factory = Factory();
  }
  return factory ? factory(job, why_not) : CudaBackend(job, why_not);
}

}  // namespace vlt::gpu_internal
