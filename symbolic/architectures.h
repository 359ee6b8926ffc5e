// architectures.h — the kinematic chains vlt-gen knows, and the custom-model builder.
//
// A tracker architecture knows every error parameter it can model (name, unit, quantity). The
// spec lists the ACTIVE ones; the others are set to 0 symbolically before anything is derived,
// so they vanish from the generated code and metadata. Physics: docs/models.md.
#pragma once

#include <string>
#include <vector>

#include <ginac/ginac.h>

#include "graph.h"
#include "spec.h"

namespace vlt::gen {

struct KnownParam {
  const char* name;
  const char* unit;
  const char* quantity;
};

// The parameters an architecture can model, in the order used in docs; empty if unknown.
const std::vector<KnownParam>& ArchitectureParams(const std::string& architecture);

// A model ready for differentiation: the graph, its input symbols (readings then params) with
// their names, and the output names/units/descriptions.
struct BuiltModel {
  Graph graph;
  std::vector<GiNaC::ex> readings;
  std::vector<QuantitySpec> reading_info;
  std::vector<GiNaC::ex> params;
  std::vector<QuantitySpec> output_info;
};

// Checks the spec's parameters against the architecture (unknown name, unit or quantity ->
// SpecError naming file and key) or parses the custom outputs, and builds the graph.
BuiltModel BuildModel(const ModelSpec& spec);

}  // namespace vlt::gen
