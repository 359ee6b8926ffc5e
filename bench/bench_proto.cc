// TEMPORARY prototype (removed before hand-over): ExpandedUncertaintyField's per-point loop
// with the variance accumulated in registers.
#include <cmath>
#include <vector>

#include <benchmark/benchmark.h>

#include "bench_common.h"
#include "vlt/gum.h"

namespace vlt::bench {
namespace {

void BM_FieldProto(benchmark::State& state) {
  const MeasurementModel model(TrackerSetup("mirror", false));
  const std::vector<Eigen::Vector3d> readings = PanelReadings(model, kBatch);
  const Eigen::VectorXd x = model.shared_estimates();
  const int num_shared = model.num_shared();
  Eigen::VectorXd us(num_shared);
  for (int s = 0; s < num_shared; ++s) us(s) = model.shared_inputs()[s].u;
  std::vector<double> js(3 * num_shared);
  std::vector<Eigen::Vector3d> field(kBatch);
  const double k = NormalCoverageFactor(0.95);
  for (auto _ : state) {
    for (std::size_t i = 0; i < kBatch; ++i) {
      const Eigen::Vector3d& r = readings[i];
      Eigen::Vector3d y;
      Eigen::Matrix3d jr;
      model.EvaluateWithJacobian(r.data(), x.data(), y.data(), jr.data(), js.data());
      const Eigen::Vector3d ur = model.reading_uncertainty(r(0));
      Eigen::Vector3d var = (jr * ur.asDiagonal()).rowwise().squaredNorm();
      double v0 = var(0), v1 = var(1), v2 = var(2);
      for (int s = 0; s < num_shared; ++s) {
        const double u = us(s);
        const double* c = js.data() + 3 * s;
        v0 += (c[0] * u) * (c[0] * u);
        v1 += (c[1] * u) * (c[1] * u);
        v2 += (c[2] * u) * (c[2] * u);
      }
      var << v0, v1, v2;
      field[i] = k * var.cwiseSqrt();
      if (!field[i].allFinite() || !y.allFinite()) throw 1;
    }
    benchmark::DoNotOptimize(field.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * kBatch));
  const std::vector<Eigen::Vector3d> ref = ExpandedUncertaintyField(model, readings, 0.95, 1);
  double diff = 0;
  for (std::size_t i = 0; i < kBatch; ++i) diff = std::max(diff, (ref[i] - field[i]).cwiseAbs().maxCoeff());
  state.counters["diff"] = diff;
}

const bool kRegistered = [] {
  benchmark::RegisterBenchmark("proto/field_registers", BM_FieldProto);
  return true;
}();

}  // namespace
}  // namespace vlt::bench
