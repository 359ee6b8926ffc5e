// spec.h — the model spec (models/*.toml) as vlt-gen reads it. Format: docs/generator.md.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

namespace vlt::gen {

// Limits of a custom model's spec, so that no spec can crash, hang or exhaust vlt-gen or the
// compiler (docs/custom-models.md "Limits"): inputs and outputs (the Hessians' code grows with the
// inputs squared per output), an output expression's length and nesting, an integer power.
inline constexpr std::size_t kMaxCustomInputs = 100;
inline constexpr std::size_t kMaxCustomOutputs = 100;
inline constexpr std::size_t kMaxExpressionLength = 4096;
inline constexpr int kMaxExpressionDepth = 32;
inline constexpr int kMaxIntegerPower = 64;

// A spec that cannot be used. The message is one line naming the file and the key.
class SpecError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// One named scalar of a spec: an error parameter (tracker), an input or an output (custom).
struct QuantitySpec {
  std::string name;
  std::string unit;
  std::string quantity;
  std::string description;
  double estimate = 0.0;
  double u = 0.0;
  std::string distribution = "normal";
  double shape = 0.0;
  std::string expression;  // outputs of custom models only (GiNaC syntax)
};

struct ModelSpec {
  std::string path;       // as given on the command line (error messages)
  std::string spec_file;  // spec prefix + file name, e.g. "models/mirror.toml" (banner, metadata)
  std::string name;
  std::string kind;          // "tracker" | "custom"
  std::string architecture;  // trackers: "mirror" | "head"
  std::string description;
  std::vector<QuantitySpec> params;   // tracker [[parameter]] or custom [[input]], in spec order
  std::vector<QuantitySpec> outputs;  // custom [[output]]
};

// Reads and checks one spec; throws SpecError. `spec_prefix` is prepended to the file name.
ModelSpec ReadSpec(const std::string& path, const std::string& spec_prefix);

// True if `name` can be a C++ identifier in the generated code (and is not reserved by it).
bool IsValidIdentifier(const std::string& name);

}  // namespace vlt::gen
