// Bundle adjustment of a network of stations (vlt/network.h AdjustNetwork), one core:
//   network/adjust/<stations>/<targets>   a simulated measurement (SimulateNetwork, seed 1) of
//                                         `stations` head-model stations on a 14 m circle around a
//                                         10 m x 10 m x 2 m part with `targets` targets, each read
//                                         by 3 stations, 4 floor references (20 um): the Ceres
//                                         solve, the full covariance of every unknown with the 20
//                                         consider parameters, residuals and redundancy numbers
// Counters: unknowns, observations, covariance_MB (the full matrix), peak_rss_MB (the process).
// Target (issue: networks): 10 stations x 500 targets <= 5 s on one core.
#include <cmath>
#include <numbers>
#include <string>

#include <sys/resource.h>

#include <benchmark/benchmark.h>

#include "vlt/models.h"
#include "vlt/network.h"

namespace vlt::bench {
namespace {

struct BenchNetwork {
  Network network;
  std::vector<std::pair<std::string, Eigen::Vector3d>> targets;
};

BenchNetwork MakeBenchNetwork(int stations, int targets) {
  BenchNetwork b;
  Network& net = b.network;
  net.where = "bench";
  const ModelInfo* model = FindModel("head");
  MeasurementSetup tracker;
  tracker.model = model;
  for (int k = 0; k < model->num_params; ++k) {
    UncertainInput in;
    in.name = model->params[k].name;
    in.unit = model->params[k].unit;
    in.u = model->params[k].default_u;
    tracker.params.push_back(in);
  }
  tracker.noise = {1.0e-6, 0.4e-6, 2.4e-6, 2.4e-6};
  net.instruments = {{"tracker", tracker}};
  // Targets: a deterministic low-discrepancy (Halton 2, 3, 5) fill of the part.
  auto halton = [](int i, int base) {
    double f = 1.0, r = 0.0;
    for (; i > 0; i /= base) {
      f /= base;
      r += f * (i % base);
    }
    return r;
  };
  for (int j = 0; j < targets; ++j) {
    b.targets.emplace_back(
        "T" + std::to_string(j),
        Eigen::Vector3d(10.0 * halton(j + 1, 2), 10.0 * halton(j + 1, 3), 2.0 * halton(j + 1, 5)));
  }
  std::vector<std::vector<PlannedSighting>> sees(stations);
  for (int i = 0; i < stations; ++i) {
    const double angle = 2.0 * std::numbers::pi * i / stations;
    NetworkStation st;
    st.name = "S" + std::to_string(i + 1);
    st.pose << 0.0, 0.0, angle + std::numbers::pi, 5.0 + 14.0 * std::cos(angle), 5.0 + 14.0 * std::sin(angle),
        0.5;
    st.pose_given = true;
    st.where = "bench: station " + st.name;
    net.stations.push_back(st);
  }
  for (int j = 0; j < targets; ++j) {
    for (int offset : {0, 3, 7})
      sees[(j + offset) % stations].push_back({b.targets[j].first, Face::kFront, "bench"});
  }
  for (int r = 0; r < 4; ++r)
    net.references.push_back({b.targets[r].first, b.targets[r].second, 20e-6, "bench"});
  PlanNetworkReadings(net, b.targets, sees);
  net = SimulateNetwork(net, b.targets, 1);
  return b;
}

void BM_AdjustNetwork(benchmark::State& state) {
  const BenchNetwork b = MakeBenchNetwork(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  NetworkResult result;
  for (auto _ : state) {
    result = AdjustNetwork(b.network);
    benchmark::DoNotOptimize(result.covariance.data());
  }
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  state.counters["unknowns"] = result.unknowns;
  state.counters["observations"] = result.observations;
  state.counters["iterations"] = result.iterations;
  state.counters["covariance_MB"] = static_cast<double>(result.covariance.size()) * 8.0 / 1e6;
  state.counters["peak_rss_MB"] = static_cast<double>(usage.ru_maxrss) / 1024.0;
}

BENCHMARK(BM_AdjustNetwork)
    ->Name("network/adjust")
    ->Args({3, 50})
    ->Args({10, 500})
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace vlt::bench
