// `vlt model list`, `vlt model show NAME [--json]` and `vlt model build SPEC.toml`: the models
// vlt-gen generated from models/*.toml when vlt was built and those built since into the model cache
// (vlt/models.h), their readings, error parameters (default estimates and standard uncertainties)
// and outputs (docs/models.md explains every parameter; docs/custom-models.md the build).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "commands.h"
#include "vlt/error.h"
#include "vlt/models.h"
#include "vlt/units.h"

namespace vlt::cli {
namespace {

const ModelInfo& RequireModel(const std::string& name) {
  const ModelInfo* model = FindModel(name);
  if (model) return *model;
  std::string known;
  for (const ModelInfo* m : AllModels()) known += (known.empty() ? "" : ", ") + std::string(m->name);
  for (const BuiltModel& m : BuiltModels()) known += ", " + m.name;
  throw InputError("model: unknown model '" + name + "' (known: " + known +
                   "; build one with vlt model build SPEC.toml)");
}

// A value in the unit a metrologist reads it in (FormatReadable, vlt/units.h), else %.6g.
std::string Friendly(double si, const std::string& quantity) {
  if (quantity == "length") return FormatReadable(si, Dimension::kLength);
  if (quantity == "angle") return FormatQuantity(si, Dimension::kAngle, "arcsec", 4);
  if (quantity == "ratio") return FormatReadable(si, Dimension::kRatio);
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", si);
  return buf;
}

nlohmann::json QuantityJson(const QuantityInfo& q, bool with_defaults) {
  nlohmann::json j = {
      {"name", q.name}, {"unit", q.unit}, {"quantity", q.quantity}, {"description", q.description}};
  if (with_defaults) {
    j["default_estimate"] = q.default_estimate;
    j["default_u"] = q.default_u;
    j["default_distribution"] = q.default_distribution;
    if (q.default_shape != 0.0) j["default_shape"] = q.default_shape;
  }
  return j;
}

// The built-in models, then those in the model cache (loaded to read their tables).
std::vector<const ModelInfo*> ListedModels() {
  std::vector<const ModelInfo*> out(AllModels().begin(), AllModels().end());
  for (const BuiltModel& m : BuiltModels()) {
    try {
      if (const ModelInfo* info = FindModel(m.name)) out.push_back(info);
    } catch (const InputError& e) {
      std::fprintf(stderr, "vlt: warning: %s\n", e.what());
    }
  }
  return out;
}

void List(const GlobalOptions& global) {
  const std::vector<const ModelInfo*> models = ListedModels();
  const std::size_t built_in = AllModels().size();
  if (global.json) {
    nlohmann::json list = nlohmann::json::array();
    for (std::size_t i = 0; i < models.size(); ++i) {
      const ModelInfo* m = models[i];
      list.push_back({{"name", m->name},
                      {"kind", m->kind},
                      {"built", i >= built_in},
                      {"description", m->description},
                      {"num_readings", m->num_readings},
                      {"num_params", m->num_params},
                      {"num_outputs", m->num_outputs}});
    }
    std::printf("%s\n",
                nlohmann::json{{"models", list}, {"cache", ModelCacheDirectory().string()}}.dump(2).c_str());
    return;
  }
  int width = 20;
  for (const ModelInfo* m : models)
    width = std::max(width, static_cast<int>(std::string_view(m->name).size()));
  std::printf("%-*s %-8s %6s %6s  %s\n", width, "model", "kind", "params", "outputs", "description");
  for (std::size_t i = 0; i < models.size(); ++i) {
    const ModelInfo* m = models[i];
    std::printf("%-*s %-8s %6d %6d  %s%s\n", width, m->name, m->kind, m->num_params, m->num_outputs,
                i >= built_in ? "(built) " : "", m->description);
  }
}

// `vlt model build SPEC`: into the cache, or found there.
void Build(const std::string& spec, const GlobalOptions& global) {
  const ModelBuild b = BuildModel(spec);
  const ModelInfo* m = FindModel(b.name);
  if (global.json) {
    std::printf("%s\n", nlohmann::json{{"name", b.name},
                                       {"library", b.library.string()},
                                       {"cached", b.cached},
                                       {"seconds", b.seconds},
                                       {"kind", m ? m->kind : ""}}
                            .dump(2)
                            .c_str());
    return;
  }
  if (global.quiet) return;  // --quiet: nothing on standard output (errors still on standard error)
  if (b.cached) {
    std::printf("Model '%s' is up to date in the cache: %s\n", b.name.c_str(), b.library.string().c_str());
  } else {
    const int inputs = m ? m->num_params : 0, outputs = m ? m->num_outputs : 0;
    std::printf("Built model '%s' (%s, %d input%s, %d output%s) in %.1f s: %s\n", b.name.c_str(),
                m ? m->kind : "?", inputs, inputs == 1 ? "" : "s", outputs, outputs == 1 ? "" : "s",
                b.seconds, b.library.string().c_str());
  }
  std::printf("Use it by name: model = \"%s\" (vlt model show %s)\n", b.name.c_str(), b.name.c_str());
}

void Show(const ModelInfo& m, const GlobalOptions& global) {
  if (global.json) {
    nlohmann::json j = {
        {"name", m.name}, {"kind", m.kind}, {"description", m.description}, {"spec_file", m.spec_file}};
    j["readings"] = nlohmann::json::array();
    for (int i = 0; i < m.num_readings; ++i) j["readings"].push_back(QuantityJson(m.readings[i], false));
    j["params"] = nlohmann::json::array();
    for (int i = 0; i < m.num_params; ++i) j["params"].push_back(QuantityJson(m.params[i], true));
    j["outputs"] = nlohmann::json::array();
    for (int i = 0; i < m.num_outputs; ++i) j["outputs"].push_back(QuantityJson(m.outputs[i], false));
    j["operations"] = {{"forward", m.ops_forward},
                       {"forward_jacobians", m.ops_forward_jacobians},
                       {"nominal_jacobians", m.ops_nominal_jacobians},
                       {"hessians", m.ops_hessians}};
    std::printf("%s\n", j.dump(2).c_str());
    return;
  }
  std::printf("model        %s (%s)\n%s\nspec         %s\n", m.name, m.kind, m.description, m.spec_file);
  if (m.num_readings > 0) {
    std::printf("\nreadings:\n");
    for (int i = 0; i < m.num_readings; ++i) {
      std::printf("  %-10s [%s]  %s\n", m.readings[i].name, m.readings[i].unit, m.readings[i].description);
    }
  }
  std::printf("\n%s (default estimate, standard uncertainty, distribution):\n",
              std::string(m.kind) == "tracker" ? "error parameters" : "inputs");
  for (int i = 0; i < m.num_params; ++i) {
    const QuantityInfo& q = m.params[i];
    std::printf("  %-10s [%s]  %s  u = %s  %s\n      %s\n", q.name, q.unit,
                Friendly(q.default_estimate, q.quantity).c_str(), Friendly(q.default_u, q.quantity).c_str(),
                q.default_distribution, q.description);
  }
  std::printf("\noutputs:\n");
  for (int i = 0; i < m.num_outputs; ++i) {
    std::printf("  %-10s [%s]  %s\n", m.outputs[i].name, m.outputs[i].unit, m.outputs[i].description);
  }
  std::printf(
      "\ngenerated kernels (operations after CSE): forward %d, forward+Jacobians %d, "
      "nominal Jacobians %d, Hessians %d\n",
      m.ops_forward, m.ops_forward_jacobians, m.ops_nominal_jacobians, m.ops_hessians);
}

}  // namespace

void AddModelCommand(CLI::App& app, GlobalOptions& global) {
  auto* command =
      app.add_subcommand("model", "List the instrument/custom models, show one, or build one from its spec");
  command->require_subcommand(1);
  auto* list = command->add_subcommand("list", "List the models (name, kind, parameters, description)");
  list->callback([&global] { List(global); });
  auto* show = command->add_subcommand("show",
                                       "Show one model: readings, error parameters with default "
                                       "uncertainties, outputs (--json for JSON)");
  auto name = std::make_shared<std::string>();
  show->add_option("name", *name, "Model name (vlt model list)")->required();
  show->callback([name, &global] { Show(RequireModel(*name), global); });
  auto* build = command->add_subcommand(
      "build",
      "Build a model from its spec (TOML) into the model cache, to use by name without rebuilding vlt");
  auto spec = std::make_shared<std::string>();
  build->add_option("spec", *spec, "The model's spec (docs/custom-models.md, docs/generator.md)")->required();
  build->callback([spec, &global] { Build(*spec, global); });
}

}  // namespace vlt::cli
