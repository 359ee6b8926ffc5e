// `vlt simulate --model NAME --point X,Y,Z [--face front|back] [PARAM=VALUE ...] [--json]`
// (a custom model: `vlt simulate --model NAME [INPUT=VALUE ...]`, its outputs and sensitivities):
// what a tracker with the given error state shows when locked on a point (vlt/inverse.h),
// the coordinates it reports with its nominal (error-free) model, and the coordinate error
// (reported minus true). Values take units (vlt/units.h): tmv=5um rmv=1arcsec mu=2ppm.
// Parameters not given are at their default estimates (0 for the tracker models).
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "commands.h"
#include "vlt/error.h"
#include "vlt/inverse.h"
#include "vlt/models.h"
#include "vlt/units.h"

namespace vlt::cli {
namespace {

constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

struct SimulateOptions {
  std::string model;
  std::string point;
  std::string face = "front";
  std::vector<std::string> assignments;
};

// The kind's dimension where vlt/units.h knows it (vlt::DimensionOfQuantity); a plain
// number in the spec's unit otherwise (a custom model's "voltage").
Dimension DimensionOf(const QuantityInfo& q) {
  try {
    return vlt::DimensionOfQuantity(q.quantity, "");
  } catch (const InputError&) {
    return Dimension::kDimensionless;
  }
}

std::array<double, 3> ParsePoint(const std::string& text) {
  std::array<double, 3> p{};
  std::size_t start = 0;
  for (int i = 0; i < 3; ++i) {
    const std::size_t comma = text.find(',', start);
    if ((i < 2) != (comma != std::string::npos)) {
      throw InputError(
          "command line: --point: expected three coordinates X,Y,Z (e.g. 2,1,0.5 or "
          "2m,1m,500mm), got '" +
          text + "'");
    }
    const std::string part = text.substr(start, i < 2 ? comma - start : std::string::npos);
    p[i] = ParseQuantity(part, Dimension::kLength, "command line: --point");
    start = comma + 1;
  }
  CheckTrackerPoint(p, "command line: --point");  // the rule of every source (vlt/job.h)
  return p;
}

// INPUT=VALUE assignments over the model's default estimates. Values take units where the
// quantity kind has them (length, angle, ratio, temperature, ...); other kinds (a custom model's
// "voltage") are plain numbers in the spec's unit.
std::vector<double> AssignedParams(const ModelInfo* model, const std::vector<std::string>& assignments) {
  std::vector<double> params(model->num_params);
  for (int k = 0; k < model->num_params; ++k) params[k] = model->params[k].default_estimate;
  for (const std::string& a : assignments) {
    const std::size_t eq = a.find('=');
    if (eq == std::string::npos || eq == 0) {
      throw InputError("command line: '" + a + "': expected PARAMETER=VALUE, e.g. tmv=5um");
    }
    const std::string name = a.substr(0, eq);
    const int k = FindParam(*model, name);
    if (k < 0) {
      std::string known;
      for (int i = 0; i < model->num_params; ++i)
        known += (i ? ", " : "") + std::string(model->params[i].name);
      throw InputError("command line: unknown parameter '" + name + "' of model '" + model->name +
                       "' (known: " + known + ")");
    }
    params[k] = ParseQuantity(a.substr(eq + 1), DimensionOf(model->params[k]), "command line: " + name);
    CheckValueMagnitude(params[k], "command line: " + name);
  }
  return params;
}

// A custom model: y = f(x) and the sensitivities dy/dx at the given inputs (exact, generated).
void SimulateCustom(const ModelInfo* model, const SimulateOptions& options, const GlobalOptions& global) {
  if (!options.point.empty()) {
    throw InputError("command line: --point: '" + options.model +
                     "' is a custom model (no readings); give its inputs as NAME=VALUE");
  }
  const std::vector<double> x = AssignedParams(model, options.assignments);
  std::vector<double> y(model->num_outputs),
      jac(static_cast<std::size_t>(model->num_outputs) * model->num_params);
  double unused = 0.0;
  model->forward_jacobians(nullptr, x.data(), y.data(), &unused, jac.data());
  for (double v : y) {
    if (!std::isfinite(v))
      throw InputError("command line: the model '" + options.model + "' is not finite at these inputs");
  }
  if (global.json) {
    nlohmann::json j;
    j["model"] = model->name;
    nlohmann::json in = nlohmann::json::object(), out = nlohmann::json::object();
    for (int k = 0; k < model->num_params; ++k) in[model->params[k].name] = x[k];
    for (int o = 0; o < model->num_outputs; ++o) {
      nlohmann::json sens = nlohmann::json::object();
      for (int k = 0; k < model->num_params; ++k) {
        sens[model->params[k].name] = jac[static_cast<std::size_t>(k) * model->num_outputs + o];
      }
      out[model->outputs[o].name] = {
          {"value", y[o]}, {"unit", model->outputs[o].unit}, {"sensitivities", sens}};
    }
    j["inputs"] = in;
    j["outputs"] = out;
    std::printf("%s\n", j.dump(2).c_str());
    return;
  }
  if (global.quiet) return;
  std::printf("model %s (custom), inputs:", model->name);
  for (int k = 0; k < model->num_params; ++k)
    std::printf(" %s=%.10g %s", model->params[k].name, x[k], model->params[k].unit);
  std::printf("\n");
  for (int o = 0; o < model->num_outputs; ++o) {
    std::printf("%s = %.12g %s   sensitivities:", model->outputs[o].name, y[o], model->outputs[o].unit);
    for (int k = 0; k < model->num_params; ++k) {
      std::printf(" d/d%s %.6g", model->params[k].name,
                  jac[static_cast<std::size_t>(k) * model->num_outputs + o] + 0.0);
    }
    std::printf("\n");
  }
}

void Simulate(const SimulateOptions& options, const GlobalOptions& global) {
  const ModelInfo* model = FindModel(options.model);
  if (!model) {
    std::string known;
    for (const ModelInfo* m : AllModels()) known += (known.empty() ? "" : ", ") + std::string(m->name);
    throw InputError("command line: --model: unknown model '" + options.model + "' (known: " + known + ")");
  }
  if (std::string(model->kind) != "tracker") {
    SimulateCustom(model, options, global);
    return;
  }
  if (options.point.empty()) throw InputError("command line: --point is required for a tracker model");
  const Face face = ParseFace(options.face.c_str(), "command line: --face");
  const std::array<double, 3> point = ParsePoint(options.point);
  const std::vector<double> params = AssignedParams(model, options.assignments);

  const std::array<double, 3> readings = InverseReadings(*model, params.data(), point, face);
  // What the tracker reports: its nominal model, every parameter 0.
  const std::vector<double> zero(model->num_params, 0.0);
  double reported[3];
  model->forward(readings.data(), zero.data(), reported);
  const double error[3] = {reported[0] - point[0], reported[1] - point[1], reported[2] - point[2]};
  const double error_norm = std::sqrt(error[0] * error[0] + error[1] * error[1] + error[2] * error[2]);

  if (global.json) {
    nlohmann::json j;
    j["model"] = model->name;
    j["face"] = FaceName(face);
    j["point_m"] = point;
    nlohmann::json ps = nlohmann::json::object();
    for (int k = 0; k < model->num_params; ++k) {
      if (params[k] != 0.0) ps[model->params[k].name] = params[k];
    }
    j["params_si"] = ps;
    j["readings"] = {{"range_m", readings[0]}, {"azimuth_rad", readings[1]}, {"elevation_rad", readings[2]}};
    j["reported_m"] = {reported[0], reported[1], reported[2]};
    j["error_m"] = {error[0], error[1], error[2]};
    j["error_norm_m"] = error_norm;
    std::printf("%s\n", j.dump(2).c_str());
    return;
  }
  if (global.quiet) return;
  std::printf("model %s, %s face, true point (%.9f, %.9f, %.9f) m\n", model->name, FaceName(face), point[0],
              point[1], point[2]);
  std::printf("error state:");
  bool any = false;
  for (int k = 0; k < model->num_params; ++k) {
    if (params[k] == 0.0) continue;
    std::printf(" %s=%.6g %s", model->params[k].name, params[k], model->params[k].unit);
    any = true;
  }
  std::printf("%s\n", any ? "" : " none (ideal tracker)");
  std::printf("readings:  range %.9f m   azimuth %.9f deg (%.12f rad)   elevation %.9f deg (%.12f rad)\n",
              readings[0], readings[1] * kRadToDeg, readings[1], readings[2] * kRadToDeg, readings[2]);
  std::printf("reported:  (%.9f, %.9f, %.9f) m   (nominal, error-free model)\n", reported[0], reported[1],
              reported[2]);
  std::printf("error:     (%+.3f, %+.3f, %+.3f) µm   |error| %.3f µm   (reported - true)\n", error[0] * 1e6,
              error[1] * 1e6, error[2] * 1e6, error_norm * 1e6);
}

}  // namespace

void AddSimulateCommand(CLI::App& app, GlobalOptions& global) {
  auto* command =
      app.add_subcommand("simulate",
                         "Readings a tracker with a given error state shows at a point, the coordinates it "
                         "reports with its nominal model, and the coordinate error");
  auto options = std::make_shared<SimulateOptions>();
  command
      ->add_option("--model", options->model,
                   "Model (vlt model list): a tracker, or a custom model "
                   "(then: its outputs and sensitivities at the inputs given)")
      ->required();
  command->add_option("--point", options->point,
                      "Tracker models: true reflector centre X,Y,Z in the tracker frame "
                      "(m, or with units: 2m,1m,500mm)");
  command->add_option("--face", options->face, "front (elevation in [-90, 90] deg) or back (A+180, 180-E)");
  command->add_option("assignments", options->assignments,
                      "Error parameters PARAMETER=VALUE with units, e.g. tmv=5um rmv=1arcsec mu=2ppm; "
                      "a custom model's inputs INPUT=VALUE");
  command->footer(
      "Exit status: 0 success, 2 bad input or a point where the readings are undefined "
      "(on the vertical axis). Parameters: vlt model show NAME, docs/models.md.");
  command->callback([options, &global] { Simulate(*options, global); });
}

}  // namespace vlt::cli
