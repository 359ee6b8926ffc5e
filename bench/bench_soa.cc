// Prototype: structure-of-arrays batches through the SAME templated generated kernel, with
// Scalar = Eigen::Array<double, L, 1> (L points per call). Arithmetic runs on SIMD packets
// (SSE2 in the portable build); sin/cos/sqrt stay the scalar libm calls per lane (Eigen has no
// vectorised double sin/cos without EIGEN_FAST_MATH), and no FMA contraction exists on
// baseline x86-64, so every lane performs exactly the operations of the scalar kernel:
// max_abs_diff_vs_scalar (value and Jacobian over the batch) must be exactly 0.
// Timed like gum/generated_nominal/mirror: value + 3x23 Jacobian + J U J^T per point.
#include <algorithm>
#include <cmath>
#include <vector>

#include <benchmark/benchmark.h>

#include "bench_common.h"
#include "bench_kernels.h"

namespace vlt::bench {
namespace {

template <int L>
void BM_SoaNominal(benchmark::State& state) {
  using K = MirrorKernels;
  using A = Eigen::Array<double, L, 1>;
  constexpr int N = 3 + K::kParams;
  static_assert(kBatch % L == 0);
  const MeasurementModel model(TrackerSetup(K::kName));
  const std::vector<Eigen::Vector3d> points = PanelReadings(model, kBatch);
  // SoA readings and outputs: row j holds quantity j of every point.
  std::vector<double> readings(3 * kBatch), values(3 * kBatch), cov(6 * kBatch);
  for (std::size_t i = 0; i < kBatch; ++i) {
    for (int j = 0; j < 3; ++j) readings[j * kBatch + i] = points[i](j);
  }
  const Eigen::Matrix<double, N, 1> u0 = InputUncertainties<N>(model, 0.0);
  const Eigen::Vector3d noise = model.reading_uncertainty(0.0);
  const double range_b = model.reading_uncertainty(1.0)(0) - noise(0);
  constexpr int kPairs[6][2] = {{0, 0}, {1, 1}, {2, 2}, {0, 1}, {0, 2}, {1, 2}};

  auto run = [&](std::size_t i, A* jac) {
    A r[3], y[3];
    for (int j = 0; j < 3; ++j) r[j] = Eigen::Map<const A>(&readings[j * kBatch + i]);
    K::NominalJacobians<A>(r, y, jac, jac + 9);
    for (int j = 0; j < 3; ++j) {
      Eigen::Map<A> value(&values[j * kBatch + i]);
      value = y[j];
    }
    return r[0];
  };
  for (auto _ : state) {
    for (std::size_t i = 0; i < kBatch; i += L) {
      A jac[3 * N];
      const A range = run(i, jac);
      // a = J diag(u), C_ab = sum_k a_ak a_bk (JCGM 100 5.1.2), lane-wise.
      const A u_range = noise(0) + range_b * range.abs();
      for (int o = 0; o < 3; ++o) jac[o] *= u_range;
      for (int k = 1; k < N; ++k) {
        for (int o = 0; o < 3; ++o) jac[3 * k + o] *= u0(k);
      }
      for (int p = 0; p < 6; ++p) {
        A c = A::Zero();
        for (int k = 0; k < N; ++k) c += jac[3 * k + kPairs[p][0]] * jac[3 * k + kPairs[p][1]];
        Eigen::Map<A> entry(&cov[p * kBatch + i]);
        entry = c;
      }
    }
    benchmark::DoNotOptimize(cov.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * kBatch));

  // Bit-identity with the scalar kernel.
  double diff = 0.0;
  for (std::size_t i = 0; i < kBatch; i += L) {
    A jac[3 * N];
    run(i, jac);
    for (int l = 0; l < L; ++l) {
      double y[3], j[3 * N];
      K::NominalJacobians<double>(points[i + l].data(), y, j, j + 9);
      for (int o = 0; o < 3; ++o) diff = std::max(diff, std::abs(values[o * kBatch + i + l] - y[o]));
      for (int c = 0; c < 3 * N; ++c) diff = std::max(diff, std::abs(jac[c](l) - j[c]));
    }
  }
  state.counters["max_abs_diff_vs_scalar"] = diff;
  state.counters["lanes"] = L;
}

const bool kRegistered = [] {
  benchmark::RegisterBenchmark("gum/generated_nominal_soa/mirror/L:2", BM_SoaNominal<2>);
  benchmark::RegisterBenchmark("gum/generated_nominal_soa/mirror/L:4", BM_SoaNominal<4>);
  benchmark::RegisterBenchmark("gum/generated_nominal_soa/mirror/L:8", BM_SoaNominal<8>);
  return true;
}();

}  // namespace
}  // namespace vlt::bench
