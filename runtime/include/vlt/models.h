// vlt/models.h — look up the models by name: the ones vlt-gen generated from models/ when vlt was
// built, and the ones a user built since (`vlt model build SPEC.toml`, docs/custom-models.md).
#pragma once

#include <filesystem>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "vlt/model_info.h"

namespace vlt {

// Every model vlt-gen generated from models/ when vlt was built, sorted by name.
std::span<const ModelInfo* const> AllModels();

// The model called `name`: a built-in one, else one built into the model cache (loaded once, kept
// loaded), or nullptr. Throws InputError "model '<name>': <library>: <problem>" when the cache holds
// the model but it cannot be loaded (built for another vlt: "rebuild it with vlt model build").
const ModelInfo* FindModel(std::string_view name);

// The generated C++ header a model built at run time was compiled from (its Forward template, which
// the GPU kernel compiles: docs/gpu.md), read when the model was loaded; empty for a built-in model
// and for one built before vlt kept it beside the library.
std::string BuiltModelSource(const ModelInfo& model);

// Index of the parameter / reading / output called `name` in `model`, or -1.
int FindParam(const ModelInfo& model, std::string_view name);

// --- Models built at run time (docs/custom-models.md "Without rebuilding vlt").

// Where built models live: $VLT_MODEL_CACHE, else $XDG_CACHE_HOME/vlt/models, else
// ~/.cache/vlt/models (never a shared directory; InputError without a home). One directory per model
// name: model-<key>.so (one library per build) and model-<key>.h (the generated header it was
// compiled from), key (SHA-256 of the spec's bytes, vlt's version, kModelAbi and the entry's layout:
// which library is current), spec.toml (the spec it was built from) and build.log. A
// model is loaded only from the user's own entries that nobody else may write.
std::filesystem::path ModelCacheDirectory();

// A model in the cache.
struct BuiltModel {
  std::string name;
  std::filesystem::path library;  // <cache>/<name>/model-<key>.so, the current one
  std::filesystem::path spec;     // the copy of the spec it was built from
  bool current = false;           // its key is this vlt's (else `vlt model build` rebuilds it)
};
// The models in the cache, by name (none when it does not exist).
std::vector<BuiltModel> BuiltModels();

// What BuildModel did.
struct ModelBuild {
  std::string name;
  std::filesystem::path library;
  bool cached = false;   // the cache held it, built from the same spec bytes by this vlt
  double seconds = 0.0;  // wall time of the derivation and the compilation (0 when cached)
};

// Builds the model of the spec at `spec_path` into the cache, unless the cache holds it for these
// spec bytes and this vlt (then nothing is derived, compiled or written): derives it with vlt-gen
// (`vlt-gen --plugin`: $VLT_GEN, else <prefix>/bin/vlt-gen of the running vlt or of the prefix vlt
// was installed to, else the build tree's), compiles it with the system's C++ compiler ($CXX, split
// at spaces, else c++) against vlt's headers ($VLT_INCLUDE_DIR, else <prefix>/include, else the
// source tree's) into a shared library, and installs it (the key replaced last, by a rename). Builds
// of one name, from threads or processes, take turns (a lock per name). Throws InputError with one
// line: a spec error (vlt-gen's "<file>: <key>: <problem>"), "no C++ compiler found", "vlt-gen not
// found", the compiler's exit and first error line (its log kept beside the entry), a name that a
// built-in model has, or a cache that is not the user's own.
ModelBuild BuildModel(const std::filesystem::path& spec_path);

}  // namespace vlt
