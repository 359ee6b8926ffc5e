// The forward model evaluated by GiNaC itself — the baseline the generated code replaces.
// The symbolic model is the generator's own (symbolic/architectures.cc BuildModel from
// models/<name>.toml, linked from the vlt_bench_symbolic library; the physics is not duplicated):
// per point, the readings and parameter values are substituted into each intermediate quantity
// of the model graph in dependency order and evaluated numerically (subs + evalf), then into the
// outputs. Only a few points are run (GiNaC needs milliseconds per point); max_abs_diff_m is the
// largest difference from the generated Forward<double> over those points [m].
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>
#include <ginac/ginac.h>

#include "architectures.h"
#include "bench_common.h"
#include "graph.h"
#include "spec.h"
#include "vlt/gum.h"

namespace vlt::bench {
namespace {

double Evaluate(const gen::BuiltModel& m, const double* readings, const double* params, double* out) {
  GiNaC::exmap values;
  for (std::size_t k = 0; k < m.readings.size(); ++k) values[m.readings[k]] = readings[k];
  for (std::size_t k = 0; k < m.params.size(); ++k) values[m.params[k]] = params[k];
  for (std::size_t j = 0; j < m.graph.nodes.size(); ++j) {
    values[m.graph.nodes[j]] = m.graph.defs[j].subs(values).evalf();
  }
  for (std::size_t i = 0; i < m.graph.outputs.size(); ++i) {
    const GiNaC::ex v = m.graph.outputs[i].subs(values).evalf();
    out[i] = GiNaC::ex_to<GiNaC::numeric>(v).to_double();
  }
  return out[0];
}

void BM_GinacForward(benchmark::State& state, const char* model_name) {
  constexpr std::size_t kPoints = 8;
  const gen::ModelSpec spec =
      gen::ReadSpec(std::string(VLT_SOURCE_DIR) + "/models/" + model_name + ".toml", "models/");
  const gen::BuiltModel built = gen::BuildModel(spec);
  const MeasurementModel model(TrackerSetup(model_name));
  const std::vector<Eigen::Vector3d> readings = PanelReadings(model, kPoints);
  // Parameters at small non-zero values (1 u each), so that no term vanishes.
  std::vector<double> params(built.params.size());
  for (std::size_t k = 0; k < params.size(); ++k) params[k] = model.shared_inputs()[k].u;
  std::size_t i = 0;
  for (auto _ : state) {
    double out[3];
    benchmark::DoNotOptimize(Evaluate(built, readings[i].data(), params.data(), out));
    i = (i + 1) % kPoints;
  }
  state.SetItemsProcessed(state.iterations());
  double diff = 0.0;
  for (std::size_t p = 0; p < kPoints; ++p) {
    double symbolic[3], generated[3];
    Evaluate(built, readings[p].data(), params.data(), symbolic);
    model.setup().model->forward(readings[p].data(), params.data(), generated);
    for (int o = 0; o < 3; ++o) diff = std::max(diff, std::abs(symbolic[o] - generated[o]));
  }
  state.counters["max_abs_diff_m"] = diff;
}

const bool kRegistered = [] {
  benchmark::RegisterBenchmark("forward_ginac/mirror", BM_GinacForward, "mirror")
      ->Unit(benchmark::kMicrosecond)
      ->MinTime(0.2);
  benchmark::RegisterBenchmark("forward_ginac/head", BM_GinacForward, "head")
      ->Unit(benchmark::kMicrosecond)
      ->MinTime(0.2);
  return true;
}();

}  // namespace
}  // namespace vlt::bench
