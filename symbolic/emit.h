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
  std::vector<int> sensitivity;  // per parameter
};

struct GeneratedModel {
  std::string name;
  std::string header;  // generated/<name>.h
  std::string source;  // generated/<name>.cc
  OpCounts ops;
};

GeneratedModel GenerateModel(const ModelSpec& spec);

// generated/registry.cc for the models (sorted by name by the caller).
std::string GenerateRegistry(const std::vector<std::string>& names, const std::string& spec_prefix);

}  // namespace vlt::gen
