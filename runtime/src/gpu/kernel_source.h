// gpu/kernel_source.h — the GPU kernel's source as NVRTC compiles it (docs/gpu.md): a main file
// that includes base/portable_math.h, the model's generated header and gpu/point_trials.h, whose
// texts — the very files the CPU build compiles, embedded at build time — are handed to NVRTC as
// its headers, with a <cmath> of three using-declarations for the generated code.
#pragma once

#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace vlt::gpu_internal {

struct KernelSource {
  std::string main;                                          // vlt_point_trials.cu
  std::vector<std::pair<std::string, std::string>> headers;  // include name, text
};

// The kernel of PointTrial for a generated model the kernel carries (gpu/trials.h KernelHasModel),
// or for a model built at run time from `model_source` (its generated header: vlt/models.h
// BuiltModelSource); throws std::invalid_argument for another.
KernelSource PointTrialsSource(std::string_view model_name, const std::string& model_source = "");

// The embedded text of a source file of the kernel, by its include name ("base/portable_math.h",
// "gpu/point_trials.h", "generated/mirror.h", ...); empty when not embedded. Test: equal to the
// file in the source tree.
std::string EmbeddedKernelFile(std::string_view include_name);

}  // namespace vlt::gpu_internal
