// Per-point GUM propagation with three sources of the Jacobian, on the same templated generated
// model (generated/<model>.h) and the same law of propagation (bench_common.h):
//   gum/generated_*   the generated Jacobian kernels (NominalJacobians at the compensated
//                     estimates, ForwardJacobians at general parameter values) — the ceiling of
//                     the GUM engine, a tight loop without the engine's bookkeeping;
//   gum/autodiff      Eigen's forward-mode AutoDiffScalar with a fixed-size derivative vector
//                     (N = 3 readings + P parameters) through Forward<AutoDiffScalar>;
//   gum/finite_diff   central differences of Forward<double> (2 N + 1 evaluations).
// Each reports, besides points/s, its largest relative deviation from the generated Jacobian
// (J_rel_err, per column) and covariance (cov_rel_err, relative to the largest variance).
// Also: the generated kernels alone per model with their operation counts (jacobian/*, forward/*)
// and the scaling with the number of active parameters (scaling_params/*).
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Core>
#include <benchmark/benchmark.h>
#include <unsupported/Eigen/AutoDiff>  // after Eigen/Core, which it needs

#include "bench_common.h"
#include "bench_kernels.h"

namespace vlt::bench {
namespace {

// Central-difference step, relative to max(|x|, 1) in SI units: cbrt(eps) balances the
// truncation error O(h^2) against the rounding error O(eps / h).
const double kStep = std::cbrt(std::numeric_limits<double>::epsilon());

// --- The three Jacobian methods: value y (3) and J (3 x N column-major, readings first). ---

template <class K>
struct GeneratedNominal {
  static void Apply(const double* r, const double* /*params, all 0*/, double* y, double* j) {
    K::template NominalJacobians<double>(r, y, j, j + 9);
  }
};

template <class K>
struct GeneratedForwardJacobians {
  static void Apply(const double* r, const double* p, double* y, double* j) {
    K::template ForwardJacobians<double>(r, p, y, j, j + 9);
  }
};

template <class K>
struct AutoDiff {
  static constexpr int N = 3 + K::kParams;
  using AD = Eigen::AutoDiffScalar<Eigen::Matrix<double, N, 1>>;
  static void Apply(const double* r, const double* p, double* y, double* j) {
    AD ra[3], pa[K::kParams], out[3];
    for (int k = 0; k < 3; ++k) ra[k] = AD(r[k], N, k);
    for (int k = 0; k < K::kParams; ++k) pa[k] = AD(p[k], N, 3 + k);
    K::template Forward<AD>(ra, pa, out);
    for (int i = 0; i < 3; ++i) {
      y[i] = out[i].value();
      for (int k = 0; k < N; ++k) j[3 * k + i] = out[i].derivatives()(k);
    }
  }
};

template <class K>
struct FiniteDifferences {
  static constexpr int N = 3 + K::kParams;
  static void Apply(const double* r, const double* p, double* y, double* j) {
    double x[N];
    std::copy(r, r + 3, x);
    std::copy(p, p + K::kParams, x + 3);
    K::template Forward<double>(x, x + 3, y);
    for (int k = 0; k < N; ++k) {
      const double xk = x[k];
      const double h = kStep * std::max(std::abs(xk), 1.0);
      const double xp = xk + h, xm = xk - h;  // the steps actually taken (exact in binary)
      double fp[3], fm[3];
      x[k] = xp;
      K::template Forward<double>(x, x + 3, fp);
      x[k] = xm;
      K::template Forward<double>(x, x + 3, fm);
      x[k] = xk;
      const double inv = 1.0 / (xp - xm);
      for (int i = 0; i < 3; ++i) j[3 * k + i] = (fp[i] - fm[i]) * inv;
    }
  }
};

template <class K>
struct Batch {
  Batch()
      : model(TrackerSetup(K::kName)),
        readings(PanelReadings(model, kBatch)),
        params(model.shared_estimates()),
        y(kBatch),
        cov(kBatch) {}
  MeasurementModel model;
  std::vector<Eigen::Vector3d> readings;
  Eigen::VectorXd params;  // the estimates (0: a compensated tracker)
  std::vector<Eigen::Vector3d> y;
  std::vector<Eigen::Matrix3d> cov;
};

// Largest per-column relative deviation of method M's Jacobian, and largest deviation of the
// covariance relative to the largest variance, from the generated Jacobian over the batch.
template <class K, class M>
void SetAccuracy(benchmark::State& state, const Batch<K>& b) {
  constexpr int N = 3 + K::kParams;
  double j_err = 0.0, cov_err = 0.0;
  for (std::size_t i = 0; i < kBatch; ++i) {
    const double* r = b.readings[i].data();
    Eigen::Matrix<double, 3, N> jm, jg;
    Eigen::Vector3d ym, yg;
    M::Apply(r, b.params.data(), ym.data(), jm.data());
    GeneratedNominal<K>::Apply(r, b.params.data(), yg.data(), jg.data());
    for (int k = 0; k < N; ++k) {
      const double scale = jg.col(k).cwiseAbs().maxCoeff();
      const double d = (jm.col(k) - jg.col(k)).cwiseAbs().maxCoeff();
      j_err = std::max(j_err, scale > 0.0 ? d / scale : d);
    }
    Eigen::Matrix<double, N, 1> u = InputUncertainties<N>(b.model, r[0]);
    const Eigen::Matrix3d cm = PropagateCovariance<N>(jm, u), cg = PropagateCovariance<N>(jg, u);
    cov_err = std::max(cov_err, (cm - cg).cwiseAbs().maxCoeff() / cg.diagonal().maxCoeff());
  }
  state.counters["J_rel_err"] = j_err;
  state.counters["cov_rel_err"] = cov_err;
}

// Value + Jacobian + fused J U J^T per point, over a batch of different points.
template <class K, class M>
void BM_Propagate(benchmark::State& state) {
  constexpr int N = 3 + K::kParams;
  Batch<K> b;
  Eigen::Matrix<double, N, 1> u = InputUncertainties<N>(b.model, 1.0);
  for (auto _ : state) {
    for (std::size_t i = 0; i < kBatch; ++i) {
      const double* r = b.readings[i].data();
      Eigen::Matrix<double, 3, N> j;
      M::Apply(r, b.params.data(), b.y[i].data(), j.data());
      u.template head<3>() = b.model.reading_uncertainty(r[0]);
      b.cov[i] = PropagateCovariance<N>(j, u);
    }
    benchmark::DoNotOptimize(b.cov.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * kBatch));
  SetAccuracy<K, M>(state, b);
}

// --- The generated kernels alone, with their operation counts. ---

void SetOps(benchmark::State& state, int ops) {
  state.counters["ops"] = ops;
  state.counters["ops/s"] =
      benchmark::Counter(static_cast<double>(ops) * state.iterations() * kBatch, benchmark::Counter::kIsRate);
}

template <class K>
void BM_NominalJacobians(benchmark::State& state) {
  constexpr int N = 3 + K::kParams;
  Batch<K> b;
  Eigen::Matrix<double, 3, N> j;
  for (auto _ : state) {
    for (std::size_t i = 0; i < kBatch; ++i) {
      K::template NominalJacobians<double>(b.readings[i].data(), b.y[i].data(), j.data(), j.data() + 9);
      benchmark::DoNotOptimize(j.data());
    }
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * kBatch));
  SetOps(state, Model(K::kName).ops_nominal_jacobians);
}

template <class K>
void BM_ForwardJacobians(benchmark::State& state) {
  constexpr int N = 3 + K::kParams;
  Batch<K> b;
  Eigen::Matrix<double, 3, N> j;
  for (auto _ : state) {
    for (std::size_t i = 0; i < kBatch; ++i) {
      K::template ForwardJacobians<double>(b.readings[i].data(), b.params.data(), b.y[i].data(), j.data(),
                                           j.data() + 9);
      benchmark::DoNotOptimize(j.data());
    }
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * kBatch));
  SetOps(state, Model(K::kName).ops_forward_jacobians);
}

// The second-order check's Hessians at one point (gum/nonlinearity.cc): the generated exact kernel
// against what it replaced, Richardson-extrapolated central differences of ForwardJacobians (steps
// of 10^-3 and 5 10^-4 of each input's u: 4 (3 + P) Jacobians).
template <class K>
void BM_Hessians(benchmark::State& state) {
  constexpr int N = 3 + K::kParams;
  Batch<K> b;
  std::vector<double> h(3 * N * N);
  for (auto _ : state) {
    for (std::size_t i = 0; i < kBatch; ++i) {
      K::template Hessians<double>(b.readings[i].data(), b.params.data(), h.data());
      benchmark::DoNotOptimize(h.data());
    }
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * kBatch));
  SetOps(state, Model(K::kName).ops_hessians);
}

template <class K>
void BM_RichardsonHessians(benchmark::State& state) {
  constexpr int N = 3 + K::kParams;
  Batch<K> b;
  const Eigen::Matrix<double, N, 1> u = InputUncertainties<N>(b.model, 1.0);
  std::vector<double> h(3 * N * N);
  Eigen::Matrix<double, 3, N> j_plus, j_minus;
  Eigen::Vector3d y;
  Eigen::VectorXd p_plus = b.params, p_minus = b.params;
  auto central = [&](const Eigen::Vector3d& r0, int k, double step) {
    Eigen::Vector3d r_plus = r0, r_minus = r0;
    p_plus = b.params;
    p_minus = b.params;
    (k < 3 ? r_plus(k) : p_plus(k - 3)) += step;
    (k < 3 ? r_minus(k) : p_minus(k - 3)) -= step;
    K::template ForwardJacobians<double>(r_plus.data(), p_plus.data(), y.data(), j_plus.data(),
                                         j_plus.data() + 9);
    K::template ForwardJacobians<double>(r_minus.data(), p_minus.data(), y.data(), j_minus.data(),
                                         j_minus.data() + 9);
    return Eigen::Matrix<double, 3, N>((j_plus - j_minus) / (2.0 * step));
  };
  for (auto _ : state) {
    for (std::size_t i = 0; i < kBatch; ++i) {
      for (int k = 0; k < N; ++k) {
        const Eigen::Matrix<double, 3, N> d =
            (4.0 * central(b.readings[i], k, 5e-4 * u(k)) - central(b.readings[i], k, 1e-3 * u(k))) / 3.0;
        for (int a = 0; a < 3; ++a) {
          for (int l = 0; l < N; ++l) h[N * N * a + N * k + l] = d(a, l);
        }
      }
      benchmark::DoNotOptimize(h.data());
    }
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * kBatch));
}

template <class K>
void BM_Forward(benchmark::State& state) {
  Batch<K> b;
  for (auto _ : state) {
    for (std::size_t i = 0; i < kBatch; ++i) {
      K::template Forward<double>(b.readings[i].data(), b.params.data(), b.y[i].data());
    }
    benchmark::DoNotOptimize(b.y.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * kBatch));
  SetOps(state, Model(K::kName).ops_forward);
}

// --- Scaling with the number of active error parameters P (readings not propagated here):
// value + the P parameter columns + J_p U_p J_p^T, for genuine subsets (the first P parameters
// in spec order; the others are constants at their estimates). ---

template <int P>
void BM_ScalingGenerated(benchmark::State& state) {
  using K = MirrorKernels;
  Batch<K> b;
  const Eigen::Matrix<double, K::kParams + 3, 1> all = InputUncertainties<K::kParams + 3>(b.model, 1.0);
  const Eigen::Matrix<double, P, 1> u = all.template segment<P>(3);
  for (auto _ : state) {
    for (std::size_t i = 0; i < kBatch; ++i) {
      const double* r = b.readings[i].data();
      K::Forward<double>(r, b.params.data(), b.y[i].data());
      Eigen::Matrix<double, 3, P> j;
      for (int k = 0; k < P; ++k) K::kSensitivity[k](r, b.params.data(), j.data() + 3 * k);
      b.cov[i] = PropagateCovariance<P>(j, u);
    }
    benchmark::DoNotOptimize(b.cov.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * kBatch));
  // The ModelInfo carries the counts of the three main kernels only; those of the
  // Sensitivity_<p> kernels are read from the banner of generated/mirror.h.
  const std::vector<int> sensitivity_ops = BannerSensitivityOps(K::kName);
  int ops = Model(K::kName).ops_forward;
  for (int k = 0; k < P && k < static_cast<int>(sensitivity_ops.size()); ++k) {
    ops += sensitivity_ops[k];
  }
  SetOps(state, ops);
  state.counters["params"] = P;
}

template <int P>
void BM_ScalingAutoDiff(benchmark::State& state) {
  using K = MirrorKernels;
  using AD = Eigen::AutoDiffScalar<Eigen::Matrix<double, P, 1>>;
  Batch<K> b;
  const Eigen::Matrix<double, K::kParams + 3, 1> all = InputUncertainties<K::kParams + 3>(b.model, 1.0);
  const Eigen::Matrix<double, P, 1> u = all.template segment<P>(3);
  for (auto _ : state) {
    for (std::size_t i = 0; i < kBatch; ++i) {
      const double* r = b.readings[i].data();
      AD ra[3], pa[K::kParams], out[3];
      for (int k = 0; k < 3; ++k) ra[k] = AD(r[k]);
      for (int k = 0; k < K::kParams; ++k) {
        pa[k] = k < P ? AD(b.params[k], P, k) : AD(b.params[k]);
      }
      K::Forward<AD>(ra, pa, out);
      Eigen::Matrix<double, 3, P> j;
      for (int o = 0; o < 3; ++o) {
        b.y[i](o) = out[o].value();
        j.row(o) = out[o].derivatives().transpose();
      }
      b.cov[i] = PropagateCovariance<P>(j, u);
    }
    benchmark::DoNotOptimize(b.cov.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * kBatch));
  state.counters["params"] = P;
}

template <int P>
void BM_ScalingFiniteDiff(benchmark::State& state) {
  using K = MirrorKernels;
  Batch<K> b;
  const Eigen::Matrix<double, K::kParams + 3, 1> all = InputUncertainties<K::kParams + 3>(b.model, 1.0);
  const Eigen::Matrix<double, P, 1> u = all.template segment<P>(3);
  for (auto _ : state) {
    for (std::size_t i = 0; i < kBatch; ++i) {
      const double* r = b.readings[i].data();
      double p[K::kParams];
      std::copy(b.params.data(), b.params.data() + K::kParams, p);
      K::Forward<double>(r, p, b.y[i].data());
      Eigen::Matrix<double, 3, P> j;
      for (int k = 0; k < P; ++k) {
        const double pk = p[k];
        const double h = kStep * std::max(std::abs(pk), 1.0);
        const double xp = pk + h, xm = pk - h;
        double fp[3], fm[3];
        p[k] = xp;
        K::Forward<double>(r, p, fp);
        p[k] = xm;
        K::Forward<double>(r, p, fm);
        p[k] = pk;
        for (int o = 0; o < 3; ++o) j(o, k) = (fp[o] - fm[o]) / (xp - xm);
      }
      b.cov[i] = PropagateCovariance<P>(j, u);
    }
    benchmark::DoNotOptimize(b.cov.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * kBatch));
  state.counters["params"] = P;
}

const bool kRegistered = [] {
  using benchmark::RegisterBenchmark;
  RegisterBenchmark("gum/generated_nominal/mirror",
                    BM_Propagate<MirrorKernels, GeneratedNominal<MirrorKernels>>);
  RegisterBenchmark("gum/generated_forward_jacobians/mirror",
                    BM_Propagate<MirrorKernels, GeneratedForwardJacobians<MirrorKernels>>);
  RegisterBenchmark("gum/autodiff/mirror", BM_Propagate<MirrorKernels, AutoDiff<MirrorKernels>>);
  RegisterBenchmark("gum/finite_diff/mirror", BM_Propagate<MirrorKernels, FiniteDifferences<MirrorKernels>>);
  RegisterBenchmark("gum/generated_nominal/head", BM_Propagate<HeadKernels, GeneratedNominal<HeadKernels>>);
  RegisterBenchmark("gum/autodiff/head", BM_Propagate<HeadKernels, AutoDiff<HeadKernels>>);
  RegisterBenchmark("gum/finite_diff/head", BM_Propagate<HeadKernels, FiniteDifferences<HeadKernels>>);

  RegisterBenchmark("jacobian/nominal/mirror", BM_NominalJacobians<MirrorKernels>);
  RegisterBenchmark("jacobian/nominal/head", BM_NominalJacobians<HeadKernels>);
  RegisterBenchmark("jacobian/forward_jacobians/mirror", BM_ForwardJacobians<MirrorKernels>);
  RegisterBenchmark("jacobian/forward_jacobians/head", BM_ForwardJacobians<HeadKernels>);
  RegisterBenchmark("hessian/generated/mirror", BM_Hessians<MirrorKernels>);
  RegisterBenchmark("hessian/generated/head", BM_Hessians<HeadKernels>);
  RegisterBenchmark("hessian/richardson/mirror", BM_RichardsonHessians<MirrorKernels>);
  RegisterBenchmark("hessian/richardson/head", BM_RichardsonHessians<HeadKernels>);
  RegisterBenchmark("forward/mirror", BM_Forward<MirrorKernels>);
  RegisterBenchmark("forward/head", BM_Forward<HeadKernels>);

  RegisterBenchmark("scaling_params/generated/P:5", BM_ScalingGenerated<5>);
  RegisterBenchmark("scaling_params/generated/P:10", BM_ScalingGenerated<10>);
  RegisterBenchmark("scaling_params/generated/P:20", BM_ScalingGenerated<20>);
  RegisterBenchmark("scaling_params/autodiff/P:5", BM_ScalingAutoDiff<5>);
  RegisterBenchmark("scaling_params/autodiff/P:10", BM_ScalingAutoDiff<10>);
  RegisterBenchmark("scaling_params/autodiff/P:20", BM_ScalingAutoDiff<20>);
  RegisterBenchmark("scaling_params/finite_diff/P:5", BM_ScalingFiniteDiff<5>);
  RegisterBenchmark("scaling_params/finite_diff/P:10", BM_ScalingFiniteDiff<10>);
  RegisterBenchmark("scaling_params/finite_diff/P:20", BM_ScalingFiniteDiff<20>);
  return true;
}();

}  // namespace
}  // namespace vlt::bench
