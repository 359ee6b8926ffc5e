// emit.h — the files vlt-gen writes: generated/<name>.h (templated kernels), <name>.cc (double
// instantiations + ModelInfo) and registry.cc. Layout: docs/generator.md.
#pragma once

#include <string>
#include <vector>

#include "spec.h"

namespace vlt::gen {

struct OpCounts {
  int forward = 0;
  int forward_jacobians = 0;
  int nominal_jacobians = 0;
  int hessians = 0;
  std::vector<int> sensitivity;  // per parameter
};

struct GeneratedModel {
  std::string name;
  std::string header;  // generated/<name>.h
  std::string source;  // generated/<name>.cc
  OpCounts ops;
};

// plugin: for `vlt model build` (a shared library loaded at run time): the source needs the public
// headers only (vlt/model_info.h, Eigen), so the Monte Carlo lanes kernel, whose lane type is
// internal to the runtime (base/lanes.h), is left out (ModelInfo::forward_lanes = nullptr; the
// engine then calls Forward per trial: libm's sin and cos, where the lanes use vlt's own, within 2.4
// ulp, so a trial may differ from the built-in model's in the last bits).
GeneratedModel GenerateModel(const ModelSpec& spec, bool plugin = false);

// The entry point of a plugin (<out>/plugin.cc): extern "C" vlt_model_plugin, returning the
// model's ModelInfo and vlt::kModelAbi (vlt/model_info.h).
std::string GeneratePluginEntry(const std::string& name, const std::string& spec_file);

// generated/registry.cc for the models (sorted by name by the caller).
std::string GenerateRegistry(const std::vector<std::string>& names, const std::string& spec_prefix);

}  // namespace vlt::gen
