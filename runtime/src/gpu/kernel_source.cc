// The GPU kernel's source (gpu/kernel_source.h): the files embedded by vlt_embed into
// embedded/gpu_sources.inc (runtime/CMakeLists.txt), assembled for NVRTC.
#include "gpu/kernel_source.h"

#include <stdexcept>

#include "gpu/trials.h"
#include "gpu_sources.inc"

namespace vlt::gpu_internal {
namespace {

template <std::size_t N>
std::string Joined(const std::string_view (&pieces)[N]) {
  std::string text;
  for (std::string_view piece : pieces) text.append(piece);
  return text;
}

// The generated code's `using std::cos; using std::sin; using std::sqrt;` find the device's
// functions (vlt's own for portable::Lane by argument-dependent lookup); through a namespace of
// their own, so that no declaration NVRTC may already have in std conflicts (jitify's way).
constexpr const char* kCmathShim =
    "#pragma once\n"
    "namespace vlt_device_cmath {\n"
    "using ::cos;\n"
    "using ::sin;\n"
    "using ::sqrt;\n"
    "}  // namespace vlt_device_cmath\n"
    "namespace std {\n"
    "using namespace vlt_device_cmath;\n"
    "}  // namespace std\n";

}  // namespace

std::string EmbeddedKernelFile(std::string_view include_name) {
  if (include_name == "base/portable_math.h") return Joined(kPortableMath);
  if (include_name == "gpu/point_trials.h") return Joined(kPointTrials);
  if (include_name == "generated/mirror.h") return Joined(kModelMirror);
  if (include_name == "generated/head.h") return Joined(kModelHead);
  if (include_name == "generated/total_station.h") return Joined(kModelTotalStation);
  if (include_name == "generated/jcgm101_additive.h") return Joined(kModelJcgm101Additive);
  if (include_name == "generated/jcgm101_mass.h") return Joined(kModelJcgm101Mass);
  if (include_name == "generated/gum_h1_end_gauge.h") return Joined(kModelGumH1EndGauge);
  if (include_name == "generated/gum_h2_impedance.h") return Joined(kModelGumH2Impedance);
  return "";
}

KernelSource PointTrialsSource(std::string_view model_name, const std::string& model_source) {
  if (model_source.empty() && !KernelHasModel(model_name)) {
    throw std::invalid_argument("no GPU kernel for model '" + std::string(model_name) + "'");
  }
  const std::string model(model_name);
  const std::string header = "generated/" + model + ".h";
  KernelSource source;
  source.headers = {{"cmath", kCmathShim},
                    {"base/portable_math.h", EmbeddedKernelFile("base/portable_math.h")},
                    {"gpu/point_trials.h", EmbeddedKernelFile("gpu/point_trials.h")},
                    {header, model_source.empty() ? EmbeddedKernelFile(header) : model_source}};
  source.main = "#include \"" + header +
                "\"\n"
                "#include \"gpu/point_trials.h\"\n"
                "struct KernelModel {\n"
                "  template <class S>\n"
                "  static void Forward(const S* readings, const S* params, S* out) {\n"
                "    vlt::gen::" + model + "::Forward<S>(readings, params, out);\n"
                "  }\n"
                "};\n"
                "// One thread per (trial, point), trials fastest: values[(m p + a) * n + i] = output a of\n"
                "// point p in trial first + i (m = job->outputs_per_point); stages[i]: that trial's stages (nullptr: the job has none);\n"
                "// params[k * n + i]: its parameter k where the CPU drew them (nullptr: the kernel draws them).\n"
                "extern \"C\" __global__ void vlt_point_trials(const vlt::gpu_internal::PointTrialsJob* job,\n"
                "                                              const vlt::gpu_internal::TrialPoint* points,\n"
                "                                              const vlt::gpu_internal::TrialStages* stages,\n"
                "                                              const double* params,\n"
                "                                              unsigned long long first, int n, double* values) {\n"
                "  const unsigned long long t = static_cast<unsigned long long>(blockIdx.x) * blockDim.x + threadIdx.x;\n"
                "  const unsigned long long count = static_cast<unsigned long long>(n);\n"
                "  if (t >= count * static_cast<unsigned long long>(job->num_points)) return;\n"
                "  const int p = static_cast<int>(t / count);\n"
                "  const unsigned long long i = t % count;\n"
                "  double y[vlt::gpu_internal::kMaxOutputs];\n"
                "  const vlt::gpu_internal::DrawnParams drawn{params == nullptr ? nullptr : params + i, count};\n"
                "  vlt::gpu_internal::PointOfTrial<KernelModel>(*job, points[p], p, first + i,\n"
                "                                               stages == nullptr ? nullptr : stages + i, drawn, y);\n"
                "  const int m = job->outputs_per_point;\n"
                "  for (int a = 0; a < m; ++a) values[static_cast<unsigned long long>(m * p + a) * count + i] = y[a];\n"
                "}\n";
  return source;
}

}  // namespace vlt::gpu_internal
