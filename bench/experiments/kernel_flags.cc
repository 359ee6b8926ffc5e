// kernel_flags.cc — compiler-flag experiment for docs/performance.md ("Flags"), NOT part of the
// build: the per-point GUM kernel of the mirror model (generated NominalJacobians + J U J^T) and
// Forward<double>, compiled by run_flags.sh with different flags (-O2/-O3, -march=native,
// -ffast-math, -fopenmp-simd + glibc libmvec). Each build writes its results for the same 4096
// plan points; run_flags.sh compares them with the portable -O3 build (bit-identity, relative
// deviation), because a flag that changes the numbers is not acceptable for the library.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <vector>

#include <benchmark/benchmark.h>

#include "generated/mirror.h"

namespace {

namespace m = vlt::gen::mirror;
constexpr int kN = 3 + m::kNumParams;
constexpr std::size_t kBatch = 4096;

struct Data {
  // SoA readings of the demo panel (x 3..7 m, y -0.75..0.75 m, z = -0.8 m), ideal inverse.
  std::vector<double> range, azimuth, elevation;
  double u[kN];
  Data() {
    const std::size_t nx = 105, ny = (kBatch + nx - 1) / nx;
    for (std::size_t i = 0; i < kBatch; ++i) {
      const double x = 3.0 + 4.0 * static_cast<double>(i % nx) / (nx - 1);
      const double y = -0.75 + 1.5 * static_cast<double>(i / nx) / (ny - 1);
      const double z = -0.8;
      range.push_back(std::sqrt(x * x + y * y + z * z));
      azimuth.push_back(std::atan2(y, x));
      elevation.push_back(std::atan2(z, std::hypot(x, y)));
    }
    u[0] = 0.0;
    u[1] = u[2] = 0.5 * 4.84813681109536e-6;
    const double params[m::kNumParams] = {2.42407e-06, 2.42407e-06, 2.42407e-06, 1.21203e-06, 1.21203e-06,
                                          1.21203e-06, 2e-06,       2.42407e-06, 1.21203e-06, 2e-06,
                                          2e-06,       2e-06,       2.42407e-06, 2.42407e-06, 5e-06,
                                          5e-07,       1.5e-06,     1.5e-06,     1.5e-06,     2.42407e-06};
    for (int k = 0; k < m::kNumParams; ++k) u[3 + k] = params[k];
  }
};

// One point: value, Jacobian, C = (J diag u)(J diag u)^T (6 unique entries).
inline void Point(const double* r, const double* u, double* y, double* c) {
  double j[3 * kN];
  m::NominalJacobians<double>(r, y, j, j + 9);
  const double ur = 5e-6 + 0.5e-6 * r[0];
  double a[3 * kN];
  for (int k = 0; k < kN; ++k) {
    const double s = k == 0 ? ur : u[k];
    for (int o = 0; o < 3; ++o) a[3 * k + o] = j[3 * k + o] * s;
  }
  constexpr int kPairs[6][2] = {{0, 0}, {1, 1}, {2, 2}, {0, 1}, {0, 2}, {1, 2}};
  for (int p = 0; p < 6; ++p) {
    double sum = 0.0;
    for (int k = 0; k < kN; ++k) sum += a[3 * k + kPairs[p][0]] * a[3 * k + kPairs[p][1]];
    c[p] = sum;
  }
}

// Scalar loop, one point after the other.
void Scalar(const Data& d, std::vector<double>& out) {
  for (std::size_t i = 0; i < kBatch; ++i) {
    const double r[3] = {d.range[i], d.azimuth[i], d.elevation[i]};
    Point(r, d.u, &out[9 * i], &out[9 * i + 3]);
  }
}

// The same work with an OpenMP SIMD loop (effective with -fopenmp-simd; vectorised only when the
// math calls have SIMD variants, i.e. glibc libmvec under -ffast-math): per block of 32 points,
// first the Jacobians into block-local SoA arrays (straight-line kernel, fully unrolled copies),
// then the covariance per point as in Point().
constexpr std::size_t kBlock = 32;
// flatten: the kernel must be inlined into the SIMD loop to be vectorised.
__attribute__((flatten)) void Simd(const Data& d, std::vector<double>& out) {
  constexpr int kPairs[6][2] = {{0, 0}, {1, 1}, {2, 2}, {0, 1}, {0, 2}, {1, 2}};
  for (std::size_t b = 0; b < kBatch; b += kBlock) {
    double jac[3 * kN][kBlock], val[3][kBlock];
    const double* range = d.range.data() + b;
    const double* azimuth = d.azimuth.data() + b;
    const double* elevation = d.elevation.data() + b;
#pragma omp simd
    for (std::size_t i = 0; i < kBlock; ++i) {
      const double r[3] = {range[i], azimuth[i], elevation[i]};
      double y[3], j[3 * kN];
      m::NominalJacobians<double>(r, y, j, j + 9);
#pragma GCC unroll 69
      for (int c = 0; c < 3 * kN; ++c) jac[c][i] = j[c];
#pragma GCC unroll 3
      for (int c = 0; c < 3; ++c) val[c][i] = y[c];
    }
    for (std::size_t i = 0; i < kBlock; ++i) {
      double* o = out.data() + 9 * (b + i);
      for (int c = 0; c < 3; ++c) o[c] = val[c][i];
      const double ur = 5e-6 + 0.5e-6 * range[i];
      double a[3 * kN];
      for (int k = 0; k < kN; ++k) {
        const double s = k == 0 ? ur : d.u[k];
        for (int c = 0; c < 3; ++c) a[3 * k + c] = jac[3 * k + c][i] * s;
      }
      for (int p = 0; p < 6; ++p) {
        double sum = 0.0;
        for (int k = 0; k < kN; ++k) sum += a[3 * k + kPairs[p][0]] * a[3 * k + kPairs[p][1]];
        o[3 + p] = sum;
      }
    }
  }
}

void BM_Scalar(benchmark::State& state) {
  Data d;
  std::vector<double> out(9 * kBatch);
  for (auto _ : state) {
    Scalar(d, out);
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * kBatch));
}
BENCHMARK(BM_Scalar);

void BM_Simd(benchmark::State& state) {
  Data d;
  std::vector<double> out(9 * kBatch);
  for (auto _ : state) {
    Simd(d, out);
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * kBatch));
}
BENCHMARK(BM_Simd);

void BM_Forward(benchmark::State& state) {
  Data d;
  std::vector<double> out(3 * kBatch);
  const double params[m::kNumParams] = {};
  for (auto _ : state) {
    for (std::size_t i = 0; i < kBatch; ++i) {
      const double r[3] = {d.range[i], d.azimuth[i], d.elevation[i]};
      m::Forward<double>(r, params, &out[3 * i]);
    }
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * kBatch));
}
BENCHMARK(BM_Forward);

// Writes (VLT_FLAGS_OUT) or compares with (VLT_FLAGS_REF) the results of both loops.
void CheckResults() {
  Data d;
  std::vector<double> scalar(9 * kBatch), simd(9 * kBatch);
  Scalar(d, scalar);
  Simd(d, simd);
  if (const char* path = std::getenv("VLT_FLAGS_OUT")) {
    std::ofstream(path, std::ios::binary)
        .write(reinterpret_cast<const char*>(scalar.data()), scalar.size() * sizeof(double));
  }
  if (const char* path = std::getenv("VLT_FLAGS_REF")) {
    std::vector<double> ref(9 * kBatch);
    std::ifstream(path, std::ios::binary)
        .read(reinterpret_cast<char*>(ref.data()), ref.size() * sizeof(double));
    for (const auto* v : {&scalar, &simd}) {
      std::size_t differ = 0;
      double rel = 0.0;
      for (std::size_t i = 0; i < ref.size(); ++i) {
        if ((*v)[i] != ref[i]) ++differ;
        // relative to the largest coordinate (values) or variance (covariances) of the point
        const std::size_t base = 9 * (i / 9) + (i % 9 < 3 ? 0 : 3);
        double scale = 0.0;
        for (int k = 0; k < 3; ++k) scale = std::max(scale, std::abs(ref[base + k]));
        rel = std::max(rel, std::abs((*v)[i] - ref[i]) / scale);
      }
      std::printf("%s loop vs portable -O3 scalar: %zu of %zu numbers differ, max relative %.3g\n",
                  v == &scalar ? "scalar" : "simd  ", differ, ref.size(), rel);
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  CheckResults();
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
