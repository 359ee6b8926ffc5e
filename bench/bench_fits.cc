// The task fits themselves (vlt/fits.h), one core, on points of a 0.1 m radius feature with 10 um
// noise (three rings, or three bands of a sphere's cap):
//   fit/<kind>/trial/N:<n>     a Monte Carlo trial's refit: values only, FitOptions::orientation
//                              set (cylinder and cone start from it, as every trial does)
//   fit/<kind>/gum/N:<n>       the GUM's fit: values and the exact Jacobian (k x 3N)
// Kinds: plane (closed form, the baseline), sphere (the existing geometric fit: LM + Newton with
// the full Hessian), cylinder and cone (docs/tasks.md "Cylinder and cone"). Ratios against the
// sphere of the same N and mode are the like-for-like comparison (docs/performance.md).
//   fit/<form>/trial/N:<n>     form by minimum zone (flatness of the plane's points, roundness of
//                              them as one circle, cylindricity of the cylinder's, straightness of
//                              points along a line): the least-squares fit and the linear programs
//                              (Clp); no GUM (not differentiable). Against fit/plane|cylinder/trial.
#include <cmath>
#include <random>
#include <string>

#include <benchmark/benchmark.h>

#include "vlt/fits.h"

namespace vlt::bench {
namespace {

Eigen::Matrix3Xd FeaturePoints(TaskKind kind, long n) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, 1e-5);
  Eigen::Matrix3Xd p(3, n);
  for (long i = 0; i < n; ++i) {
    const int ring = static_cast<int>(i % 3);
    const double phi = 2.0 * 3.141592653589793 * static_cast<double>(i) / static_cast<double>(n) * 3.0;
    const double h = 0.05 * (ring - 1);
    double r = 0.1;
    if (kind == TaskKind::kCone) r += 0.3 * h;
    Eigen::Vector3d q(r * std::cos(phi), r * std::sin(phi), h);
    if (kind == TaskKind::kSphere)
      q = 0.1 * Eigen::Vector3d(std::cos(phi) * std::cos(h * 10), std::sin(phi) * std::cos(h * 10),
                                std::sin(h * 10));
    if (kind == TaskKind::kPlane || kind == TaskKind::kFlatness || kind == TaskKind::kRoundness) q.z() = 0.0;
    if (kind == TaskKind::kStraightness)
      q = Eigen::Vector3d(0.3 * static_cast<double>(i) / static_cast<double>(n), 0.0, 0.0);
    p.col(i) = q + Eigen::Vector3d(2.0, -1.0, 0.5) + Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
  }
  return p;
}

void BM_Fit(benchmark::State& state, TaskKind kind, bool jacobian) {
  const Eigen::Matrix3Xd points = FeaturePoints(kind, state.range(0));
  FitOptions options;
  const FitResult first = FitTask(kind, points, options);
  options.jacobian = jacobian;
  if (kind == TaskKind::kCylinder || kind == TaskKind::kCone)
    options.orientation = first.values.segment<3>(3);
  if (jacobian && !first.differentiable.empty() && !first.differentiable[0]) options.jacobian = false;
  int iterations = 0;
  for (auto _ : state) {
    const FitResult fit = FitTask(kind, points, options);
    benchmark::DoNotOptimize(fit.values.data());
    iterations = fit.iterations;
  }
  state.counters["fit_iterations"] = iterations;
  state.SetItemsProcessed(state.iterations() * state.range(0));
}

const bool kRegistered = [] {
  for (TaskKind kind : {TaskKind::kPlane, TaskKind::kSphere, TaskKind::kCylinder, TaskKind::kCone}) {
    for (bool jacobian : {false, true}) {
      const std::string name = "fit/" + std::string(TaskKindName(kind)) + (jacobian ? "/gum" : "/trial");
      benchmark::RegisterBenchmark(name.c_str(), BM_Fit, kind, jacobian)
          ->Arg(24)
          ->Arg(10000)
          ->Unit(benchmark::kMicrosecond);
    }
  }
  for (TaskKind kind :
       {TaskKind::kFlatness, TaskKind::kRoundness, TaskKind::kCylindricity, TaskKind::kStraightness}) {
    const std::string name = "fit/" + std::string(TaskKindName(kind)) + "/trial";
    benchmark::RegisterBenchmark(name.c_str(), BM_Fit, kind, false)
        ->Arg(24)
        ->Arg(10000)
        ->Unit(benchmark::kMicrosecond);
  }
  return true;
}();

}  // namespace
}  // namespace vlt::bench
