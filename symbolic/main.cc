// vlt-gen — derives the measurement equations of the models in models/*.toml with GiNaC and
// writes generated/<name>.h, generated/<name>.cc and generated/registry.cc (docs/generator.md).
//
//   vlt-gen --models DIR --out DIR [--spec-prefix models/]
//   vlt-gen --plugin SPEC.toml --out DIR    (for `vlt model build`: DIR/generated/<name>.h, .cc, DIR/plugin.cc)
//   vlt-gen --summary SPEC.toml
//
// Exit status: 0 success, 2 bad spec or command line (one line on stderr naming file and key),
// 3 internal error.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "emit.h"
#include "spec.h"

namespace fs = std::filesystem;

namespace {

constexpr const char* kUsage =
    "usage: vlt-gen --models DIR --out DIR [--spec-prefix PREFIX]\n"
    "       vlt-gen --plugin SPEC.toml --out DIR\n"
    "       vlt-gen --summary SPEC.toml\n"
    "Reads every DIR/*.toml (sorted) and writes OUT/<name>.h, OUT/<name>.cc and OUT/registry.cc.\n"
    "PREFIX (default \"models/\") is what the banners name as the directory of the specs.\n";

class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Writes only when the content changes, so an unchanged model does not trigger a rebuild.
void WriteIfChanged(const fs::path& path, const std::string& content) {
  {
    std::ifstream in(path, std::ios::binary);
    if (in) {
      std::stringstream ss;
      ss << in.rdbuf();
      if (ss.str() == content) return;
    }
  }
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << content;
  out.close();
  if (!out) throw UsageError("cannot write " + path.string());
}

std::vector<fs::path> Specs(const fs::path& dir) {
  if (!fs::is_directory(dir)) throw UsageError("--models: not a directory: " + dir.string());
  std::vector<fs::path> specs;
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (entry.is_regular_file() && entry.path().extension() == ".toml") specs.push_back(entry.path());
  }
  std::sort(specs.begin(), specs.end());
  return specs;
}

// One spec as a plugin's sources (vlt model build compiles them into a shared library): nothing is
// written when the spec is bad.
int GeneratePlugin(const fs::path& spec_path, const fs::path& out) {
  const vlt::gen::ModelSpec spec =
      vlt::gen::ReadSpec(spec_path.string(), spec_path.parent_path().string() + "/");
  const vlt::gen::GeneratedModel gen = vlt::gen::GenerateModel(spec, true);
  fs::create_directories(out / "generated");
  WriteIfChanged(out / "generated" / (gen.name + ".h"), gen.header);
  WriteIfChanged(out / "generated" / (gen.name + ".cc"), gen.source);
  WriteIfChanged(out / "plugin.cc", vlt::gen::GeneratePluginEntry(gen.name, spec.spec_file));
  std::printf("%s\n", gen.name.c_str());
  return 0;
}

int Generate(const fs::path& models, const fs::path& out, const std::string& prefix) {
  const auto specs = Specs(models);
  // Everything is derived before anything is written: a bad spec leaves OUT untouched.
  std::vector<vlt::gen::GeneratedModel> generated;
  std::vector<std::string> names;
  for (const auto& path : specs) {
    const vlt::gen::ModelSpec spec = vlt::gen::ReadSpec(path.string(), prefix);
    generated.push_back(vlt::gen::GenerateModel(spec));
    names.push_back(spec.name);
  }
  fs::create_directories(out);
  for (const auto& gen : generated) {
    WriteIfChanged(out / (gen.name + ".h"), gen.header);
    WriteIfChanged(out / (gen.name + ".cc"), gen.source);
  }
  std::sort(names.begin(), names.end());
  WriteIfChanged(out / "registry.cc", vlt::gen::GenerateRegistry(names, prefix));
  return 0;
}

int Summary(const std::string& path) {
  const vlt::gen::ModelSpec spec = vlt::gen::ReadSpec(path, "");
  const vlt::gen::GeneratedModel gen = vlt::gen::GenerateModel(spec);
  std::printf("model       %s\nkind        %s%s\ndescription %s\n", spec.name.c_str(), spec.kind.c_str(),
              spec.kind == "tracker" ? (" (architecture " + spec.architecture + ")").c_str() : "",
              spec.description.c_str());
  std::printf("%s (%zu):\n", spec.kind == "tracker" ? "active error parameters" : "inputs",
              spec.params.size());
  std::printf("  %-3s %-10s %-6s %-10s %-14s %-12s %s\n", "#", "name", "unit", "quantity", "estimate", "u",
              "distribution");
  for (std::size_t k = 0; k < spec.params.size(); ++k) {
    const auto& p = spec.params[k];
    std::printf("  %-3zu %-10s %-6s %-10s %-14.6g %-12.4g %s\n", k, p.name.c_str(), p.unit.c_str(),
                p.quantity.c_str(), p.estimate, p.u, p.distribution.c_str());
  }
  if (!spec.outputs.empty()) {
    std::printf("outputs (%zu):\n", spec.outputs.size());
    for (const auto& o : spec.outputs) {
      std::printf("  %-10s [%s] = %s\n", o.name.c_str(), o.unit.c_str(), o.expression.c_str());
    }
  }
  std::printf(
      "operations after CSE:\n  Forward           %d\n  ForwardJacobians  %d\n"
      "  NominalJacobians  %d\n  Hessians          %d\n",
      gen.ops.forward, gen.ops.forward_jacobians, gen.ops.nominal_jacobians, gen.ops.hessians);
  for (std::size_t k = 0; k < spec.params.size(); ++k) {
    std::printf("  Sensitivity_%-5s %d\n", spec.params[k].name.c_str(), gen.ops.sensitivity[k]);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    std::string models, out, summary, plugin, prefix = "models/";
    for (int i = 1; i < argc; ++i) {
      const std::string arg = argv[i];
      auto value = [&]() -> std::string {
        if (i + 1 >= argc) throw UsageError(arg + " needs a value");
        return argv[++i];
      };
      if (arg == "--models") {
        models = value();
      } else if (arg == "--out") {
        out = value();
      } else if (arg == "--spec-prefix") {
        prefix = value();
      } else if (arg == "--summary") {
        summary = value();
      } else if (arg == "--plugin") {
        plugin = value();
      } else if (arg == "-h" || arg == "--help") {
        std::fputs(kUsage, stdout);
        return 0;
      } else {
        throw UsageError("unknown argument '" + arg + "'");
      }
    }
    if (!summary.empty()) {
      if (!models.empty() || !out.empty()) throw UsageError("--summary takes no --models/--out");
      return Summary(summary);
    }
    if (!plugin.empty()) {
      if (!models.empty() || out.empty()) throw UsageError("--plugin takes --out and no --models");
      return GeneratePlugin(plugin, out);
    }
    if (models.empty() || out.empty()) throw UsageError("--models and --out are required");
    return Generate(models, out, prefix);
  } catch (const UsageError& e) {
    std::fprintf(stderr, "vlt-gen: error: %s\n%s", e.what(), kUsage);
    return 2;
  } catch (const vlt::gen::SpecError& e) {
    std::fprintf(stderr, "vlt-gen: error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "vlt-gen: internal error: %s\n", e.what());
    return 3;
  }
}
