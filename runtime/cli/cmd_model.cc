// `vlt model list` and `vlt model show NAME [--json]`: the models vlt-gen generated from
// models/*.toml, their readings, error parameters (default estimates and standard
// uncertainties) and outputs (docs/models.md explains every parameter).
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

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
  throw InputError("model: unknown model '" + name + "' (known: " + known + ")");
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

void List(const GlobalOptions& global) {
  if (global.json) {
    nlohmann::json models = nlohmann::json::array();
    for (const ModelInfo* m : AllModels()) {
      models.push_back({{"name", m->name},
                        {"kind", m->kind},
                        {"description", m->description},
                        {"num_readings", m->num_readings},
                        {"num_params", m->num_params},
                        {"num_outputs", m->num_outputs}});
    }
    std::printf("%s\n", nlohmann::json{{"models", models}}.dump(2).c_str());
    return;
  }
  std::printf("%-20s %-8s %6s %6s  %s\n", "model", "kind", "params", "outputs", "description");
  for (const ModelInfo* m : AllModels()) {
    std::printf("%-20s %-8s %6d %6d  %s\n", m->name, m->kind, m->num_params, m->num_outputs, m->description);
  }
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
                       {"nominal_jacobians", m.ops_nominal_jacobians}};
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
      "nominal Jacobians %d\n",
      m.ops_forward, m.ops_forward_jacobians, m.ops_nominal_jacobians);
}

}  // namespace

void AddModelCommand(CLI::App& app, GlobalOptions& global) {
  auto* command = app.add_subcommand("model", "List the generated instrument/custom models or show one");
  command->require_subcommand(1);
  auto* list = command->add_subcommand("list", "List the models (name, kind, parameters, description)");
  list->callback([&global] { List(global); });
  auto* show = command->add_subcommand("show",
                                       "Show one model: readings, error parameters with default "
                                       "uncertainties, outputs (--json for JSON)");
  auto name = std::make_shared<std::string>();
  show->add_option("name", *name, "Model name (vlt model list)")->required();
  show->callback([name, &global] { Show(RequireModel(*name), global); });
}

}  // namespace vlt::cli
