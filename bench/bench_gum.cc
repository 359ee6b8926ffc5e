// The GUM engine through its public API (vlt/gum.h, vlt/measurement_model.h), per point over a
// batch of plan points, and a task's uncertainty over N points:
//   gum_engine/evaluate_with_jacobian  the scalar per-point API: MeasurementModel::
//                                      EvaluateWithJacobian + J U J^T (as bench_common.h)
//   gum_engine/covariance_field        CovarianceField: the engine's batch path for the full 3x3
//                                      covariance per point (the same output as the above);
//                                      _scalar: the same without the model's SIMD kernel
//   gum_engine/field                   ExpandedUncertaintyField, the engine's lean batch path
//                                      (what `vlt map` uses: expanded uncertainty per axis),
//                                      1 and 2 threads, 4096 and 65536 points
//   gum_engine/points                  PropagatePoints, full per-point results (covariances in
//                                      both frames, line-of-sight split, ellipsoid), without and
//                                      with the uncertainty budget
//   gum_task/plane/N                   plane fit + its GUM uncertainty over N points
// `env:1` variants add the demo job's weather station (refractive index of the air: 4 more
// shared inputs and the Ciddor equation in every Jacobian).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <benchmark/benchmark.h>

#include "bench_common.h"
#include "vlt/fits.h"
#include "vlt/gum.h"

namespace vlt::bench {
namespace {

std::vector<PointReadings> Points(const std::vector<Eigen::Vector3d>& readings) {
  std::vector<PointReadings> points(readings.size());
  for (std::size_t i = 0; i < readings.size(); ++i) {
    char name[32];  // (not "P" + std::to_string: GCC 12 -Wrestrict false positive)
    std::snprintf(name, sizeof name, "P%zu", i + 1);
    points[i].name = name;
    points[i].readings = readings[i];
  }
  return points;
}

void BM_EvaluateWithJacobian(benchmark::State& state, bool env) {
  const MeasurementModel model(TrackerSetup("mirror", env));
  const std::vector<Eigen::Vector3d> readings = PanelReadings(model, kBatch);
  const Eigen::VectorXd x = model.shared_estimates();
  const int s = model.num_shared();
  Eigen::VectorXd u(3 + s);
  for (int k = 0; k < s; ++k) u(3 + k) = model.shared_inputs()[k].u;
  Eigen::Matrix<double, 3, Eigen::Dynamic> j(3, 3 + s), a(3, 3 + s);  // no heap in the loop
  std::vector<Eigen::Matrix3d> cov(kBatch);
  for (auto _ : state) {
    for (std::size_t i = 0; i < kBatch; ++i) {
      Eigen::Vector3d y;
      model.EvaluateWithJacobian(readings[i].data(), x.data(), y.data(), j.data(), j.data() + 9);
      u.head<3>() = model.reading_uncertainty(readings[i](0));
      a.noalias() = j * u.asDiagonal();
      Eigen::Matrix3d& c = cov[i];  // U_y = a a^T, the six distinct entries
      for (int p = 0; p < 3; ++p) {
        for (int q = p; q < 3; ++q) c(p, q) = c(q, p) = a.row(p).dot(a.row(q));
      }
    }
    benchmark::DoNotOptimize(cov.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * kBatch));
}

void BM_Field(benchmark::State& state, bool env, int threads, std::size_t n) {
  const MeasurementModel model(TrackerSetup("mirror", env));
  const std::vector<Eigen::Vector3d> readings = PanelReadings(model, n);
  for (auto _ : state) {
    std::vector<Eigen::Vector3d> field = ExpandedUncertaintyField(model, readings, 0.95, threads);
    benchmark::DoNotOptimize(field.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * n));
}

// The engine's full-covariance batch path (the same output as evaluate_with_jacobian above).
// simd = false: the same engine path with the model's batched kernel removed (a copy of its
// ModelInfo with nominal_jacobians_batch = nullptr), so the points go one by one through the
// scalar kernel: the like-for-like measure of what the SIMD lanes give (the same numbers to rounding, tested).
void BM_CovarianceField(benchmark::State& state, bool env, int threads, std::size_t n, bool simd) {
  MeasurementSetup setup = TrackerSetup("mirror", env);
  static ModelInfo scalar_only;
  if (!simd) {
    scalar_only = *setup.model;
    scalar_only.nominal_jacobians_batch = nullptr;
    setup.model = &scalar_only;
  }
  const MeasurementModel model(setup);
  const std::vector<Eigen::Vector3d> readings = PanelReadings(model, n);
  for (auto _ : state) {
    std::vector<Eigen::Matrix3d> field = CovarianceField(model, readings, threads);
    benchmark::DoNotOptimize(field.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * n));
}

void BM_Points(benchmark::State& state, bool env, bool budgets, int threads) {
  GumOptions options;
  options.budgets = budgets;
  options.threads = threads;
  const MeasurementModel model(TrackerSetup("mirror", env));
  const std::vector<PointReadings> points = Points(PanelReadings(model, kBatch));
  for (auto _ : state) {
    std::vector<PointUncertainty> results = PropagatePoints(model, points, options);
    benchmark::DoNotOptimize(results.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * kBatch));
}

// A plane fitted to N points of the panel and its GUM uncertainty: value and G = d plane /
// d coordinates from vlt/fits.h (FitPlane), then the engine's PropagateTaskCovariance (points
// correlated through the shared inputs; memory O(N)). Timed: both steps, points/s = N / time.
void BM_PlaneTask(benchmark::State& state, std::size_t n) {
  const MeasurementModel model(TrackerSetup("mirror"));
  const std::vector<PointReadings> points = Points(PanelReadings(model, n));
  std::vector<int> indices(n);
  for (std::size_t i = 0; i < n; ++i) indices[i] = static_cast<int>(i);
  GumOptions options;
  options.threads = 1;
  double u_normal_x = 0.0;
  for (auto _ : state) {
    const std::vector<Eigen::Vector3d> y = PointEstimates(model, points, 1);
    const Eigen::Map<const Eigen::Matrix3Xd> coordinates(y.data()->data(), 3, static_cast<Eigen::Index>(n));
    FitOptions fit_options;
    fit_options.jacobian = true;
    const FitResult fit = FitPlane(coordinates, fit_options);
    TaskUncertainty result;
    result.name = "plane";
    result.kind = TaskKind::kPlane;
    result.value = fit.values;
    PropagateTaskCovariance(model, points, indices, fit.jacobian, options, result);
    benchmark::DoNotOptimize(result.covariance.data());
    u_normal_x = result.u(3);
  }
  // Tilt of the plane about y: correlated through the shared inputs, it does not average out.
  state.counters["u_normal_x_urad"] = u_normal_x * 1e6;
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * n));
}

// The best-fit alignment of N measured points to their nominal positions (vlt/fits.h FitBestFit,
// docs/tasks.md) with its GUM covariance, through the public PropagateTask (estimates, fit with
// its exact Jacobian, PropagateTaskCovariance). The nominal is the panel as planned, turned and
// moved, so the fit is a real 6-DOF one. Issue 30: 10^4 points in <= 0.5 s.
// weighted: the same fit weighted by the points' covariance (docs/tasks.md "Fits weighted by the
// points' covariance"): the covariance's factor (TaskPointCovariance), the ordinary fit, Gauss-Newton
// steps with W by Woodbury's identity and the exact Jacobian by nested automatic differentiation.
void BM_AlignmentTask(benchmark::State& state, std::size_t n, bool weighted) {
  const MeasurementModel model(TrackerSetup("mirror"));
  const std::vector<PointReadings> points = Points(PanelReadings(model, n));
  const std::vector<Eigen::Vector3d> y = PointEstimates(model, points, 1);
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.1, 0.2, 1.0).normalized()).toRotationMatrix();
  TaskSpec task;
  task.name = "to_cad";
  task.kind = TaskKind::kBestFit;
  auto nominal = std::make_shared<NominalGeometry>();
  nominal->positions.resize(3, static_cast<Eigen::Index>(n));
  nominal->alignment_points = static_cast<int>(n);
  for (std::size_t i = 0; i < n; ++i) {
    task.points.push_back(points[i].name);
    nominal->positions.col(static_cast<Eigen::Index>(i)) = turn * y[i] + Eigen::Vector3d(1.0, -2.0, 0.5);
  }
  task.nominal = nominal;
  task.weighted = weighted;
  GumOptions options;
  options.threads = 1;
  double u_rz = 0.0;
  for (auto _ : state) {
    const TaskUncertainty result = PropagateTask(model, points, task, options);
    benchmark::DoNotOptimize(result.covariance.data());
    u_rz = result.u(5);
  }
  state.counters["u_rz_urad"] = u_rz * 1e6;
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * n));
}

const bool kRegistered = [] {
  using benchmark::RegisterBenchmark;
  // One thread: the engine runs inline (parallel_internal::ForEachChunk), CPU time of the benchmark thread is the
  // work and stays meaningful on a shared machine; two threads: wall-clock time.
  RegisterBenchmark("gum_engine/evaluate_with_jacobian/env:0", BM_EvaluateWithJacobian, false);
  RegisterBenchmark("gum_engine/evaluate_with_jacobian/env:1", BM_EvaluateWithJacobian, true);
  RegisterBenchmark("gum_engine/covariance_field/env:0/threads:1", BM_CovarianceField, false, 1, kBatch,
                    true);
  RegisterBenchmark("gum_engine/covariance_field_scalar/env:0/threads:1", BM_CovarianceField, false, 1,
                    kBatch, false);
  RegisterBenchmark("gum_engine/covariance_field/env:1/threads:1", BM_CovarianceField, true, 1, kBatch, true);
  RegisterBenchmark("gum_engine/covariance_field_scalar/env:1/threads:1", BM_CovarianceField, true, 1, kBatch,
                    false);
  RegisterBenchmark("gum_engine/covariance_field/env:0/threads:2", BM_CovarianceField, false, 2, kBatch, true)
      ->UseRealTime();
  RegisterBenchmark("gum_engine/covariance_field/env:0/N:65536/threads:1", BM_CovarianceField, false, 1,
                    65536, true)
      ->UseRealTime();
  RegisterBenchmark("gum_engine/covariance_field/env:0/N:65536/threads:2", BM_CovarianceField, false, 2,
                    65536, true)
      ->UseRealTime();
  RegisterBenchmark("gum_engine/field/env:0/threads:1", BM_Field, false, 1, kBatch);
  RegisterBenchmark("gum_engine/field/env:0/threads:2", BM_Field, false, 2, kBatch)->UseRealTime();
  RegisterBenchmark("gum_engine/field/env:1/threads:1", BM_Field, true, 1, kBatch);
  // A larger map (65536 points): 16 times the work per wake-up of the pool's workers.
  RegisterBenchmark("gum_engine/field/env:0/N:65536/threads:1", BM_Field, false, 1, 65536)->UseRealTime();
  RegisterBenchmark("gum_engine/field/env:0/N:65536/threads:2", BM_Field, false, 2, 65536)->UseRealTime();
  RegisterBenchmark("gum_engine/points/env:0/budgets:0/threads:1", BM_Points, false, false, 1);
  RegisterBenchmark("gum_engine/points/env:0/budgets:0/threads:2", BM_Points, false, false, 2)->UseRealTime();
  RegisterBenchmark("gum_engine/points/env:0/budgets:1/threads:1", BM_Points, false, true, 1);
  RegisterBenchmark("gum_engine/points/env:1/budgets:1/threads:1", BM_Points, true, true, 1);
  for (std::size_t n : {10, 100, 1000, 10000, 100000, 1000000}) {
    std::string name = "gum_task/plane/N:";
    name += std::to_string(n);
    auto* b = RegisterBenchmark(name.c_str(), BM_PlaneTask, n)->Unit(benchmark::kMillisecond);
    if (n >= 100000) b->Iterations(n >= 1000000 ? 1 : 3);
  }
  for (std::size_t n : {100, 10000}) {
    const std::string name = "gum_task/best_fit/N:" + std::to_string(n);
    RegisterBenchmark(name.c_str(), BM_AlignmentTask, n, false)->Unit(benchmark::kMillisecond);
    const std::string weighted = "gum_task/best_fit_weighted/N:" + std::to_string(n);
    RegisterBenchmark(weighted.c_str(), BM_AlignmentTask, n, true)->Unit(benchmark::kMillisecond);
  }
  return true;
}();

}  // namespace
}  // namespace vlt::bench
