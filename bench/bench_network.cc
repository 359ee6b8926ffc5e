// Bundle adjustment of a network of stations (vlt/network.h AdjustNetwork), one core:
//   network/adjust/<stations>/<targets>   a simulated measurement (SimulateNetwork, seed 1) of
//                                         `stations` head-model stations on a 14 m circle around a
//                                         10 m x 10 m x 2 m part with `targets` targets, each read
//                                         by 3 stations, 4 floor references (20 um): the Ceres
//                                         solve, the full covariance of every unknown with the 20
//                                         consider parameters, residuals and redundancy numbers
//   network/wing/<trials>                 the wing-size network of issue 29: 6 stations, 300
//                                         targets and 4 scale bars (3 m, 2 um; 8 more targets),
//                                         station S1 held, no references, every station drifting
//                                         (readings 30 s apart, 3 drift checks of 4 nests, N-12),
//                                         every error parameter
//                                         self-calibrated, 5 gross errors of 20 sigma: the robust
//                                         adjustment (data snooping, 5 re-adjustments), then a
//                                         Monte Carlo validation of `trials` re-adjusted simulated
//                                         networks on every core (0: none)
// Counters: unknowns, observations, covariance_MB (the full matrix), peak_rss_MB (the process);
// wing: rejected, worst_ratio (u_MCM / u_GUM farthest from 1), tolerance, agrees (1: within it).
// Target (issue: networks): 10 stations x 500 targets <= 5 s on one core; the wing with Monte
// Carlo validation <= 10 s on the 2-core machine (issue 29).
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

// Every station drifts (N-12): its readings 30 s apart, and three drift checks re-reading the four
// bars' first ends (drift nests every station sees) at a quarter, half and three quarters of its
// time; 10 um/h and 1 arcsec/h of prior rate. The simulation draws the drift from that prior.
void AddDriftChecks(Network& plan) {
  for (NetworkStation& st : plan.stations) {
    std::vector<TargetReading> nests;
    for (std::size_t j = 0; j < st.readings.size(); ++j) {
      st.readings[j].time = 30.0 * static_cast<double>(j);
      if (st.readings[j].target.size() == 5 && st.readings[j].target.ends_with(".A")) nests.push_back(st.readings[j]);
    }
    const double end = 30.0 * static_cast<double>(st.readings.size());
    st.drift.enabled = true;
    st.drift.translation_rate = 10e-6 / 3600.0;
    st.drift.rotation_rate = 1.0 / 206264.806 / 3600.0;
    st.drift.knots = {0.0};
    for (double fraction : {0.25, 0.5, 0.75}) {
      st.drift.knots.push_back(fraction * end);
      for (TargetReading check : nests) {
        check.time = fraction * end;
        st.readings.push_back(check);
      }
    }
    st.drift.knots.push_back(end - 30.0);
  }
}

// The wing network: MakeBenchNetwork's geometry with 6 stations and 300 targets, plus 4 scale bars
// whose 8 targets every station reads; S1 held instead of the references; every station drifting
// with three drift checks; self-calibration; five readings spoiled by 20 sigma.
Network MakeWingNetwork() {
  BenchNetwork b = MakeBenchNetwork(6, 300);
  Network plan = b.network;
  plan.references.clear();
  plan.stations[0].datum = true;
  std::vector<std::vector<PlannedSighting>> sees(plan.stations.size());
  std::vector<std::pair<std::string, Eigen::Vector3d>> bar_targets;
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector3d a(1.0 + 2.0 * k, 0.5 + 2.5 * k, 0.1), b3(a + Eigen::Vector3d(3.0, 0.0, 0.0));
    const std::string name = "SB" + std::to_string(k + 1);
    bar_targets.emplace_back(name + ".A", a);
    bar_targets.emplace_back(name + ".B", b3);
    NetworkDistance d;
    d.name = name;
    d.scale_bar = true;
    d.from = name + ".A";
    d.to = name + ".B";
    d.length = d.calibrated_length = 3.0;
    d.u = d.u_calibrated_length = 2e-6;
    d.where = "bench: " + name;
    plan.distances.push_back(d);
  }
  for (std::size_t i = 0; i < plan.stations.size(); ++i)
    for (const auto& [name, x] : bar_targets) sees[i].push_back({name, Face::kFront, "bench"});
  PlanNetworkReadings(plan, bar_targets, sees);
  for (const auto& t : bar_targets) b.targets.push_back(t);
  AddDriftChecks(plan);
  for (const UncertainInput& p : plan.instruments[0].setup.params)
    if (p.u > 0.0) plan.self_calibrate.push_back(p.name);
  Network sim = SimulateNetwork(plan, b.targets, 2);
  const MeasurementModel model(sim.instruments[0].setup);
  for (int e = 0; e < 5; ++e) {
    std::vector<TargetReading>& readings = sim.stations[e % 6].readings;
    TargetReading& reading = readings[(37 * e + 11) % readings.size()];
    reading.readings(1) += 20.0 * model.reading_uncertainty(reading.readings(0))(1);
  }
  return sim;
}

void BM_WingNetwork(benchmark::State& state) {
  const Network wing = MakeWingNetwork();
  const int trials = static_cast<int>(state.range(0));
  NetworkResult result;
  NetworkMonteCarlo mc;
  for (auto _ : state) {
    result = AdjustNetwork(wing);
    if (trials > 0) mc = ValidateNetworkByMonteCarlo(wing, result, trials, 20090101, 0);
    benchmark::DoNotOptimize(result.covariance.data());
  }
  state.counters["unknowns"] = result.unknowns;
  state.counters["observations"] = result.observations;
  state.counters["rejected"] = static_cast<double>(result.rejected.size());
  state.counters["iterations"] = result.iterations;
  state.counters["worst_ratio"] = trials > 0 ? mc.worst_ratio : 0.0;
  state.counters["tolerance"] = trials > 0 ? mc.tolerance : 0.0;
  state.counters["agrees"] = trials > 0 && mc.agrees ? 1.0 : 0.0;
}

BENCHMARK(BM_WingNetwork)->Name("network/wing")->Arg(0)->Arg(100)->Unit(benchmark::kMillisecond)->UseRealTime();

BENCHMARK(BM_AdjustNetwork)
    ->Name("network/adjust")
    ->Args({3, 50})
    ->Args({10, 500})
    ->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace vlt::bench
