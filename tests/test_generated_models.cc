// The kernels vlt-gen generated (generated/*.h) against independent references:
//  - zero errors: the tracker models reduce to the ideal spherical point rho*(cE cA, cE sA, sE)
//    on both faces (closed form);
//  - every Jacobian column (readings and parameters, general and nominal, every Sensitivity_*
//    function) against central finite differences of Forward (relative 1e-7) and against
//    Eigen's forward-mode automatic differentiation run through the templated Forward
//    (relative 1e-12), at random error states of realistic (default u) and 100x magnitude;
//  - every Hessian (vlt-gen's second pass, forward over forward) against Eigen's forward-mode AD
//    run through the templated ForwardJacobians (relative 1e-10; the derivative of each exact
//    first derivative, not the generator's second pass), symmetric bit for bit, and every
//    registered model's Hessians through its ModelInfo against central differences of its
//    ForwardJacobians (relative 1e-6);
//  - the double ModelInfo wrappers and forward_batch against the templates;
//  - the custom models against their published check values (GUM H.1, JCGM 101 9.2).
// "Relative" means relative to max(|reference column|, 1) for the tracker models (metres per
// metre or per radian) and to |reference column| for the custom models.
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <gtest/gtest.h>
#include <unsupported/Eigen/AutoDiff>

#include "generated/gum_h1_end_gauge.h"
#include "generated/head.h"
#include "generated/jcgm101_additive.h"
#include "generated/mirror.h"
#include "vlt/models.h"

namespace {

constexpr double kPi = 3.14159265358979323846;

// Compile-time view of one generated model (the templates of generated/<name>.h).
#define VLT_KERNELS(NAME)                                                                                    \
  struct NAME##_kernels {                                                                                    \
    static constexpr const char* kName = #NAME;                                                              \
    static constexpr int R = vlt::gen::NAME::kNumReadings;                                                   \
    static constexpr int P = vlt::gen::NAME::kNumParams;                                                     \
    static constexpr int O = vlt::gen::NAME::kNumOutputs;                                                    \
    template <typename S>                                                                                    \
    static void Forward(const S* r, const S* p, S* o) {                                                      \
      vlt::gen::NAME::Forward(r, p, o);                                                                      \
    }                                                                                                        \
    static void ForwardJacobians(const double* r, const double* p, double* o, double* jr, double* jp) {      \
      vlt::gen::NAME::ForwardJacobians(r, p, o, jr, jp);                                                     \
    }                                                                                                        \
    static void NominalJacobians(const double* r, double* o, double* jr, double* jp) {                       \
      vlt::gen::NAME::NominalJacobians(r, o, jr, jp);                                                        \
    }                                                                                                        \
    template <typename S>                                                                                    \
    static void ForwardJacobiansOf(const S* r, const S* p, S* o, S* jr, S* jp) {                             \
      vlt::gen::NAME::ForwardJacobians(r, p, o, jr, jp);                                                     \
    }                                                                                                        \
    static void Hessians(const double* r, const double* p, double* h) { vlt::gen::NAME::Hessians(r, p, h); } \
  };
VLT_KERNELS(mirror)
VLT_KERNELS(head)
VLT_KERNELS(gum_h1_end_gauge)
VLT_KERNELS(jcgm101_additive)
#undef VLT_KERNELS

const vlt::ModelInfo& Model(const char* name) {
  const vlt::ModelInfo* m = vlt::FindModel(name);
  if (!m) throw std::runtime_error(std::string("model not registered: ") + name);
  return *m;
}

// Jacobians of Forward by forward-mode AD: columns 0..R-1 readings, R..R+P-1 parameters.
template <typename K>
void AutoDiffJacobians(const double* r, const double* p, double* out, double* jr, double* jp) {
  constexpr int N = K::R + K::P;
  using Ad = Eigen::AutoDiffScalar<Eigen::Matrix<double, N, 1>>;
  std::array<Ad, (K::R > 0 ? K::R : 1)> ra;
  ra.fill(Ad(0.0));  // a model without readings is passed one zero it does not read
  std::array<Ad, K::P> pa;
  std::array<Ad, K::O> oa;
  for (int j = 0; j < K::R; ++j) ra[j] = Ad(r[j], N, j);
  for (int k = 0; k < K::P; ++k) pa[k] = Ad(p[k], N, K::R + k);
  K::Forward(ra.data(), pa.data(), oa.data());
  for (int i = 0; i < K::O; ++i) {
    out[i] = oa[i].value();
    for (int j = 0; j < K::R; ++j) jr[K::O * j + i] = oa[i].derivatives()[j];
    for (int k = 0; k < K::P; ++k) jp[K::O * k + i] = oa[i].derivatives()[K::R + k];
  }
}

// Central differences of Forward with steps h_readings / h_params.
template <typename K>
void FiniteDifferenceJacobians(const double* r, const double* p, const double* hr, const double* hp,
                               double* jr, double* jp) {
  std::array<double, (K::R > 0 ? K::R : 1)> rr{};
  std::array<double, K::P> pp{};
  std::array<double, K::O> plus{}, minus{};
  for (int j = 0; j < K::R; ++j) rr[j] = r[j];
  for (int k = 0; k < K::P; ++k) pp[k] = p[k];
  for (int j = 0; j < K::R; ++j) {
    rr[j] = r[j] + hr[j];
    K::Forward(rr.data(), p, plus.data());
    rr[j] = r[j] - hr[j];
    K::Forward(rr.data(), p, minus.data());
    rr[j] = r[j];
    for (int i = 0; i < K::O; ++i) jr[K::O * j + i] = (plus[i] - minus[i]) / (2 * hr[j]);
  }
  for (int k = 0; k < K::P; ++k) {
    pp[k] = p[k] + hp[k];
    K::Forward(r, pp.data(), plus.data());
    pp[k] = p[k] - hp[k];
    K::Forward(r, pp.data(), minus.data());
    pp[k] = p[k];
    for (int i = 0; i < K::O; ++i) jp[K::O * k + i] = (plus[i] - minus[i]) / (2 * hp[k]);
  }
}

// Every column of `actual` equals `reference` to `rel` x max(|reference column|, floor).
void ExpectColumnsNear(const double* actual, const double* reference, int rows, int cols, double rel,
                       double floor, const std::string& what) {
  for (int k = 0; k < cols; ++k) {
    double norm = 0;
    for (int i = 0; i < rows; ++i) norm = std::hypot(norm, reference[rows * k + i]);
    const double tol = rel * std::max(norm, floor);
    for (int i = 0; i < rows; ++i) {
      EXPECT_NEAR(actual[rows * k + i], reference[rows * k + i], tol)
          << what << " column " << k << " row " << i;
    }
  }
}

// Runs every Jacobian check at readings r and parameters p.
template <typename K>
void CheckJacobians(const double* r, const double* p, const double* hr, const double* hp, double floor,
                    const std::string& where) {
  const vlt::ModelInfo& model = Model(K::kName);
  constexpr int O = K::O, R = K::R, P = K::P;
  std::array<double, O> out{}, out_fwd{}, out_ad{};
  std::array<double, O*(R > 0 ? R : 1)> jr{}, jr_ad{}, jr_fd{};
  std::array<double, O * P> jp{}, jp_ad{}, jp_fd{};
  K::ForwardJacobians(r, p, out.data(), jr.data(), jp.data());
  K::Forward(r, p, out_fwd.data());
  AutoDiffJacobians<K>(r, p, out_ad.data(), jr_ad.data(), jp_ad.data());
  FiniteDifferenceJacobians<K>(r, p, hr, hp, jr_fd.data(), jp_fd.data());
  for (int i = 0; i < O; ++i) {
    EXPECT_NEAR(out[i], out_fwd[i], 1e-14 * std::max(1.0, std::abs(out_fwd[i]))) << where;
    EXPECT_NEAR(out_ad[i], out_fwd[i], 1e-14 * std::max(1.0, std::abs(out_fwd[i]))) << where;
  }
  ExpectColumnsNear(jr.data(), jr_ad.data(), O, R, 1e-12, floor, where + " d/dreadings vs AD");
  ExpectColumnsNear(jp.data(), jp_ad.data(), O, P, 1e-12, floor, where + " d/dparams vs AD");
  ExpectColumnsNear(jr.data(), jr_fd.data(), O, R, 1e-7, floor, where + " d/dreadings vs FD");
  ExpectColumnsNear(jp.data(), jp_fd.data(), O, P, 1e-7, floor, where + " d/dparams vs FD");
  // Sensitivity functions (through the ModelInfo dispatch) against AD, column by column.
  for (int k = 0; k < P; ++k) {
    std::array<double, O> column{};
    model.sensitivity(k, r, p, column.data());
    ExpectColumnsNear(column.data(), jp_ad.data() + O * k, O, 1, 1e-12, floor,
                      where + " Sensitivity_" + model.params[k].name + " vs AD");
  }
  // The double wrappers are the same kernels.
  std::array<double, O> out_info{};
  std::array<double, O*(R > 0 ? R : 1)> jr_info{};
  std::array<double, O * P> jp_info{};
  model.forward(r, p, out_info.data());
  model.forward_jacobians(r, p, out_info.data(), jr_info.data(), jp_info.data());
  for (int i = 0; i < O; ++i) EXPECT_EQ(out_info[i], out[i]) << where;
  for (int i = 0; i < O * P; ++i) EXPECT_EQ(jp_info[i], jp[i]) << where;
}

// Nominal Jacobians (all parameters 0, substituted symbolically) against AD at p = 0.
template <typename K>
void CheckNominal(const double* r, double floor, const std::string& where) {
  constexpr int O = K::O, R = K::R, P = K::P;
  std::array<double, P> zero{};
  std::array<double, O> out{}, out_ad{};
  std::array<double, O*(R > 0 ? R : 1)> jr{}, jr_ad{};
  std::array<double, O * P> jp{}, jp_ad{};
  K::NominalJacobians(r, out.data(), jr.data(), jp.data());
  AutoDiffJacobians<K>(r, zero.data(), out_ad.data(), jr_ad.data(), jp_ad.data());
  for (int i = 0; i < O; ++i) EXPECT_NEAR(out[i], out_ad[i], 1e-14 * std::max(1.0, std::abs(out_ad[i])));
  ExpectColumnsNear(jr.data(), jr_ad.data(), O, R, 1e-12, floor, where + " nominal d/dreadings");
  ExpectColumnsNear(jp.data(), jp_ad.data(), O, P, 1e-12, floor, where + " nominal d/dparams");
}

// Random readings on either face and random error states drawn from the default u x scale, for
// scales 1 and 100: check(r, p, scale, where) for each.
template <typename K, typename Check>
void ForRandomTrackerStates(std::uint64_t seed, int trials, Check check) {
  const vlt::ModelInfo& model = Model(K::kName);
  ASSERT_EQ(model.num_params, K::P);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> range(0.5, 40.0), az(-kPi, kPi), el(-0.7, 1.3);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (double scale : {1.0, 100.0}) {
    for (int trial = 0; trial < trials; ++trial) {
      double r[3] = {range(rng), az(rng), el(rng)};
      if (trial % 2) {  // back face of the same direction
        r[1] += kPi;
        r[2] = kPi - r[2];
      }
      std::array<double, K::P> p;
      for (int k = 0; k < K::P; ++k) p[k] = scale * model.params[k].default_u * normal(rng);
      check(r, p.data(), scale,
            std::string(K::kName) + " scale " + std::to_string(scale) + " trial " + std::to_string(trial));
    }
  }
}

template <typename K>
void TrackerJacobianSweep(std::uint64_t seed) {
  const std::array<double, 3> hr = {1e-5, 1e-5, 1e-5};
  std::array<double, K::P> hp;
  hp.fill(1e-5);
  ForRandomTrackerStates<K>(seed, 25,
                            [&](const double* r, const double* p, double scale, const std::string& where) {
                              CheckJacobians<K>(r, p, hr.data(), hp.data(), 1.0, where);
                              if (scale == 1.0) CheckNominal<K>(r, 1.0, where);
                            });
}

// Hessians at readings r and parameters p against AD through ForwardJacobians: entry (k, l) of
// output o is d/dx_k of the AD-differentiated d out_o / dx_l; x = (readings, parameters).
template <typename K>
void CheckHessians(const double* r, const double* p, double floor, const std::string& where) {
  constexpr int R = K::R, P = K::P, O = K::O, N = R + P;
  using Ad = Eigen::AutoDiffScalar<Eigen::Matrix<double, N, 1>>;
  std::array<Ad, (R > 0 ? R : 1)> ra;
  ra.fill(Ad(0.0));
  std::array<Ad, P> pa;
  std::array<Ad, O> oa;
  std::array<Ad, O*(R > 0 ? R : 1)> jra;
  std::array<Ad, O * P> jpa;
  for (int j = 0; j < R; ++j) ra[j] = Ad(r[j], N, j);
  for (int k = 0; k < P; ++k) pa[k] = Ad(p[k], N, R + k);
  K::ForwardJacobiansOf(ra.data(), pa.data(), oa.data(), jra.data(), jpa.data());
  std::vector<double> h(static_cast<std::size_t>(O) * N * N), reference(h.size());
  K::Hessians(r, p, h.data());
  for (int o = 0; o < O; ++o) {
    for (int l = 0; l < N; ++l) {
      const Ad& first = l < R ? jra[O * l + o] : jpa[O * (l - R) + o];
      for (int k = 0; k < N; ++k) {
        // An expression that does not depend on any input keeps an empty derivative vector.
        reference[N * N * o + N * l + k] = first.derivatives().size() == N ? first.derivatives()[k] : 0.0;
      }
    }
    ExpectColumnsNear(h.data() + N * N * o, reference.data() + N * N * o, N, N, 1e-10, floor,
                      where + " Hessian of output " + std::to_string(o) + " vs AD");
    for (int l = 0; l < N; ++l) {
      for (int k = 0; k < l; ++k) ASSERT_EQ(h[N * N * o + N * l + k], h[N * N * o + N * k + l]) << where;
    }
  }
}

template <typename K>
void TrackerHessianSweep(std::uint64_t seed) {
  ForRandomTrackerStates<K>(seed, 10, [](const double* r, const double* p, double, const std::string& where) {
    CheckHessians<K>(r, p, 1.0, where);
  });
}

TEST(GeneratedMirror, HessiansMatchAutoDiffOfTheJacobians) { TrackerHessianSweep<mirror_kernels>(11); }
TEST(GeneratedHead, HessiansMatchAutoDiffOfTheJacobians) { TrackerHessianSweep<head_kernels>(12); }
TEST(GeneratedCustomModels, HessiansMatchAutoDiffOfTheJacobians) {
  const vlt::ModelInfo& h1 = Model("gum_h1_end_gauge");
  std::vector<double> x;
  for (int k = 0; k < h1.num_params; ++k) x.push_back(h1.params[k].default_estimate + h1.params[k].default_u);
  CheckHessians<gum_h1_end_gauge_kernels>(nullptr, x.data(), 0.0, "gum_h1_end_gauge");
  const std::array<double, 4> additive = {0.3, -1.2, 2.0, 0.7};
  CheckHessians<jcgm101_additive_kernels>(nullptr, additive.data(), 1.0, "jcgm101_additive");
}

// Every registered model, through ModelInfo::hessians, against central differences of its
// ForwardJacobians (step 10^-4 of the input's scale; relative 1e-6 of the column), at the
// estimates moved by one default u (tracker models: a point 7 m away on the front face).
TEST(GeneratedModels, HessiansThroughModelInfoMatchDifferencesOfTheJacobians) {
  for (std::size_t m = 0; m < vlt::generated::kNumModels; ++m) {
    const vlt::ModelInfo& model = *vlt::generated::kModels[m];
    ASSERT_NE(model.hessians, nullptr) << model.name;
    const int R = model.num_readings, P = model.num_params, O = model.num_outputs, N = R + P;
    std::vector<double> x(N), scale(N);
    const double readings[3] = {7.0, 0.4, 0.3};
    for (int j = 0; j < R; ++j) x[j] = readings[j], scale[j] = j == 0 ? 7.0 : 1.0;
    for (int k = 0; k < P; ++k) {
      x[R + k] = model.params[k].default_estimate + model.params[k].default_u;
      scale[R + k] = std::max(std::abs(x[R + k]), model.params[k].default_u);
    }
    std::vector<double> h(static_cast<std::size_t>(O) * N * N), fd(h.size());
    model.hessians(x.data(), x.data() + R, h.data());
    std::vector<double> y(O), jr_plus(std::max(1, O * R)), jp_plus(O * P), jr_minus(jr_plus.size()),
        jp_minus(O * P);
    for (int k = 0; k < N; ++k) {
      const double step = 1e-4 * scale[k];
      std::vector<double> plus = x, minus = x;
      plus[k] += step;
      minus[k] -= step;
      model.forward_jacobians(plus.data(), plus.data() + R, y.data(), jr_plus.data(), jp_plus.data());
      model.forward_jacobians(minus.data(), minus.data() + R, y.data(), jr_minus.data(), jp_minus.data());
      for (int o = 0; o < O; ++o) {
        for (int l = 0; l < N; ++l) {
          const double d_plus = l < R ? jr_plus[O * l + o] : jp_plus[O * (l - R) + o];
          const double d_minus = l < R ? jr_minus[O * l + o] : jp_minus[O * (l - R) + o];
          fd[N * N * o + N * l + k] = (d_plus - d_minus) / (2.0 * step);
        }
      }
    }
    for (int o = 0; o < O; ++o) {
      // Columns scaled to the inputs' scales: d2 y / dx_k dx_l s_k s_l.
      std::vector<double> hs(N * N), fds(N * N);
      for (int l = 0; l < N; ++l) {
        for (int k = 0; k < N; ++k) {
          hs[N * l + k] = h[N * N * o + N * l + k] * scale[k] * scale[l];
          fds[N * l + k] = fd[N * N * o + N * l + k] * scale[k] * scale[l];
        }
      }
      ExpectColumnsNear(hs.data(), fds.data(), N, N, 1e-6, 1e-9 * (1.0 + std::abs(y[o])),
                        std::string(model.name) + " output " + std::to_string(o));
    }
  }
}

TEST(GeneratedMirror, JacobiansMatchAutoDiffAndFiniteDifferences) { TrackerJacobianSweep<mirror_kernels>(1); }
TEST(GeneratedHead, JacobiansMatchAutoDiffAndFiniteDifferences) { TrackerJacobianSweep<head_kernels>(2); }

// With every error zero both tracker models are the ideal spherical tracker, on both faces.
void CheckIdeal(const char* name) {
  const vlt::ModelInfo& model = Model(name);
  std::vector<double> zero(model.num_params, 0.0);
  for (double range : {0.5, 1.0, 2.5, 10.0, 40.0}) {
    for (double a = -3.0; a <= 3.2; a += 0.4) {
      for (double e = -1.4; e <= 1.45; e += 0.2) {
        const double ideal[3] = {range * std::cos(e) * std::cos(a), range * std::cos(e) * std::sin(a),
                                 range * std::sin(e)};
        const double front[3] = {range, a, e};
        const double back[3] = {range, a + kPi, kPi - e};
        for (const double* r : {front, back}) {
          double out[3], nominal[3], jr[9];
          std::vector<double> jp(3 * model.num_params);
          model.forward(r, zero.data(), out);
          model.nominal_jacobians(r, nominal, jr, jp.data());
          for (int i = 0; i < 3; ++i) {
            EXPECT_NEAR(out[i], ideal[i], 1e-12) << name << " range " << range << " a " << a << " e " << e;
            EXPECT_NEAR(nominal[i], ideal[i], 1e-12) << name;
          }
          // Ideal reading Jacobian: d/drange = direction; d/dA, d/dE from the closed form.
          const double s = r == back ? -1.0 : 1.0;  // back face: dE_b = -dE, dA_b = dA
          const double dir[3] = {std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e)};
          const double da[3] = {-ideal[1], ideal[0], 0.0};
          const double de[3] = {-range * std::sin(e) * std::cos(a), -range * std::sin(e) * std::sin(a),
                                range * std::cos(e)};
          for (int i = 0; i < 3; ++i) {
            EXPECT_NEAR(jr[i], dir[i], 1e-12) << name;
            EXPECT_NEAR(jr[3 + i], da[i], 1e-11) << name;
            EXPECT_NEAR(jr[6 + i], s * de[i], 1e-11) << name;
          }
        }
      }
    }
  }
}

TEST(GeneratedMirror, ZeroErrorsGiveTheIdealPointOnBothFaces) { CheckIdeal("mirror"); }
TEST(GeneratedHead, ZeroErrorsGiveTheIdealPointOnBothFaces) { CheckIdeal("head"); }

TEST(GeneratedModels, ForwardBatchEqualsForward) {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (const vlt::ModelInfo* m : vlt::AllModels()) {
    constexpr std::size_t n = 7;
    std::vector<std::vector<double>> r(m->num_readings, std::vector<double>(n));
    std::vector<std::vector<double>> p(m->num_params, std::vector<double>(n));
    std::vector<std::vector<double>> o(m->num_outputs, std::vector<double>(n));
    for (auto& v : r)
      for (auto& x : v) x = 1.0 + std::abs(normal(rng));
    for (int k = 0; k < m->num_params; ++k) {
      for (auto& x : p[k]) x = m->params[k].default_estimate + m->params[k].default_u * normal(rng);
    }
    std::vector<const double*> rp, pp;
    std::vector<double*> op;
    for (auto& v : r) rp.push_back(v.data());
    for (auto& v : p) pp.push_back(v.data());
    for (auto& v : o) op.push_back(v.data());
    m->forward_batch(n, rp.data(), pp.data(), op.data());
    for (std::size_t i = 0; i < n; ++i) {
      std::vector<double> ri(m->num_readings + 1), pi(m->num_params), oi(m->num_outputs);
      for (int j = 0; j < m->num_readings; ++j) ri[j] = r[j][i];
      for (int k = 0; k < m->num_params; ++k) pi[k] = p[k][i];
      m->forward(ri.data(), pi.data(), oi.data());
      for (int k = 0; k < m->num_outputs; ++k) EXPECT_EQ(o[k][i], oi[k]) << m->name;
    }
  }
}

// The SIMD batch (the template on Eigen::Array lanes) against the double kernel, bit for bit:
// tracker models over both faces, short and long ranges, the readings of 4 unrelated points per
// call; custom models have none (their nominal kernel has no readings).
TEST(GeneratedModels, NominalJacobiansBatchEqualsNominalJacobiansBitForBit) {
  constexpr int L = vlt::kNominalBatchLanes;
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> range(0.3, 60.0), azimuth(-3.5, 3.5), elevation(-1.5, 4.6);
  int trackers = 0;
  for (const vlt::ModelInfo* m : vlt::AllModels()) {
    if (std::string(m->kind) != "tracker") {
      EXPECT_EQ(m->nominal_jacobians_batch, nullptr) << m->name;
      continue;
    }
    ASSERT_NE(m->nominal_jacobians_batch, nullptr) << m->name;
    ++trackers;
    const int no = m->num_outputs, np = m->num_params;
    std::vector<double> r(3 * L), out(no * L), jr(3 * no * L), jp(no * np * L);
    for (int call = 0; call < 250; ++call) {
      for (int l = 0; l < L; ++l) {
        r[l] = range(rng);
        r[L + l] = azimuth(rng);
        r[2 * L + l] = elevation(rng);
      }
      m->nominal_jacobians_batch(r.data(), out.data(), jr.data(), jp.data());
      for (int l = 0; l < L; ++l) {
        const double ri[3] = {r[l], r[L + l], r[2 * L + l]};
        std::vector<double> o(no), j_r(3 * no), j_p(no * np);
        m->nominal_jacobians(ri, o.data(), j_r.data(), j_p.data());
        for (int q = 0; q < no; ++q) ASSERT_EQ(out[L * q + l], o[q]) << m->name << " output " << q;
        for (int q = 0; q < 3 * no; ++q) ASSERT_EQ(jr[L * q + l], j_r[q]) << m->name << " d/dreadings " << q;
        for (int q = 0; q < no * np; ++q) ASSERT_EQ(jp[L * q + l], j_p[q]) << m->name << " d/dparams " << q;
      }
    }
  }
  EXPECT_EQ(trackers, 3);  // mirror, head, total_station
}

// The Monte Carlo lanes (the template on vlt::base_internal::lanes::Double4, vlt's own sin/cos) against the
// double kernel: tracker models, both faces, short and long ranges, every error parameter drawn
// at up to 10x a typical size (1e-4 rad, 1e-4 m), 4 unrelated points per call. Outputs agree to
// 1e-13 m (a few ulp of coordinates up to 60 m). Custom models (their lanes kernel since
// 2026-11-28: CustomModelLanesEqualForward below) are skipped here.
TEST(GeneratedModels, ForwardLanesEqualsForwardToAFewUlp) {
  constexpr int L = vlt::kForwardLanes;
  std::mt19937_64 rng(12);
  std::uniform_real_distribution<double> range(0.3, 60.0), azimuth(-3.5, 3.5), elevation(-1.5, 4.6),
      param(-1e-4, 1e-4);
  int trackers = 0;
  double worst = 0.0;
  for (const vlt::ModelInfo* m : vlt::AllModels()) {
    if (std::string(m->kind) != "tracker") continue;
    ASSERT_NE(m->forward_lanes, nullptr) << m->name;
    ++trackers;
    const int no = m->num_outputs, np = m->num_params;
    std::vector<double> r(3 * L), p(np * L), out(no * L);
    for (int call = 0; call < 2000; ++call) {
      for (int l = 0; l < L; ++l) {
        r[l] = range(rng);
        r[L + l] = azimuth(rng);
        r[2 * L + l] = elevation(rng);
        for (int k = 0; k < np; ++k) p[L * k + l] = param(rng);
      }
      m->forward_lanes(r.data(), p.data(), out.data(), L, L);
      for (int l = 0; l < L; ++l) {
        const double ri[3] = {r[l], r[L + l], r[2 * L + l]};
        std::vector<double> pi(np), o(no);
        for (int k = 0; k < np; ++k) pi[k] = p[L * k + l];
        m->forward(ri, pi.data(), o.data());
        for (int q = 0; q < no; ++q) {
          ASSERT_NEAR(out[L * q + l], o[q], 1e-13) << m->name << " output " << q;
          worst = std::max(worst, std::fabs(out[L * q + l] - o[q]));
        }
      }
    }
  }
  EXPECT_EQ(trackers, 3);  // mirror, head, total_station
  EXPECT_GT(worst, 0.0);   // not libm's sin/cos: the comparison is not vacuous
}

// ForwardLanes's strides (vlt/model_info.h ForwardLanesFn): the engine passes its rows of a
// sub-batch in place (stride kSubBatch), blocks of kForwardLanes elsewhere. The same lanes laid out
// at other strides, the readings and outputs at one, the parameters at another, give the same bits,
// and nothing between the rows is read into a lane or written.
TEST(GeneratedModels, ForwardLanesReadsAndWritesAtItsStrides) {
  constexpr int L = vlt::kForwardLanes;
  std::mt19937_64 rng(15);
  std::uniform_real_distribution<double> range(0.3, 60.0), angle(-3.0, 3.0), param(-1e-4, 1e-4);
  int with_lanes = 0;
  for (const vlt::ModelInfo* m : vlt::AllModels()) {
    if (m->forward_lanes == nullptr) continue;
    ++with_lanes;
    const int nr = m->num_readings, np = m->num_params, no = m->num_outputs;
    for (const auto& [stride, params_stride] : {std::pair{5, 4}, std::pair{4, 7}, std::pair{256, 256}}) {
      const double sentinel = std::numeric_limits<double>::quiet_NaN();
      std::vector<double> r(std::max(nr, 1) * L), p(np * L), out(no * L);
      std::vector<double> r_rows(std::max(nr, 1) * stride, sentinel), p_rows(np * params_stride, sentinel),
          out_rows(no * stride, 7.25);
      for (int l = 0; l < L; ++l) {
        for (int j = 0; j < nr; ++j) r[L * j + l] = r_rows[stride * j + l] = j == 0 ? range(rng) : angle(rng);
        for (int k = 0; k < np; ++k) {
          p[L * k + l] = p_rows[params_stride * k + l] =
              std::string(m->kind) == "tracker" ? param(rng) : m->params[k].default_estimate + param(rng) * 1e3 * m->params[k].default_u;
        }
      }
      m->forward_lanes(nr > 0 ? r.data() : nullptr, p.data(), out.data(), L, L);
      m->forward_lanes(nr > 0 ? r_rows.data() : nullptr, p_rows.data(), out_rows.data(), stride, params_stride);
      for (int q = 0; q < no; ++q) {
        for (int l = 0; l < stride; ++l) {
          const double want = l < L ? out[L * q + l] : 7.25;
          ASSERT_EQ(std::bit_cast<std::uint64_t>(out_rows[stride * q + l]), std::bit_cast<std::uint64_t>(want))
              << m->name << " output " << q << " lane " << l << ", strides " << stride << ", " << params_stride;
        }
      }
    }
  }
  EXPECT_EQ(with_lanes, 4);  // mirror, head, total_station, gum_h2_impedance
}

// The custom models' lanes kernel (what their Monte Carlo runs since 2026-11-28 where Forward calls
// sin or cos: GUM H.2's impedance; the others, + - * / only, have none) against the double kernel,
// each input drawn within 5 u of its estimate, the phase over several turns too, 4 unrelated trials
// per call: within a few ulp (vlt's own sine and cosine there, the C library's here).
TEST(GeneratedModels, CustomModelLanesEqualForward) {
  constexpr int L = vlt::kForwardLanes;
  std::mt19937_64 rng(13);
  std::uniform_real_distribution<double> within(-5.0, 5.0), turns(-20.0, 20.0);
  int customs = 0;
  double worst_sin_cos = 0.0;
  for (const vlt::ModelInfo* m : vlt::AllModels()) {
    if (std::string(m->kind) != "custom") continue;
    const bool sin_cos = std::string(m->name) == "gum_h2_impedance";
    ++customs;
    if (!sin_cos) {
      EXPECT_EQ(m->forward_lanes, nullptr) << m->name;
      continue;
    }
    ASSERT_NE(m->forward_lanes, nullptr) << m->name;
    const int no = m->num_outputs, np = m->num_params;
    std::vector<double> p(np * L), out(no * L);
    for (int call = 0; call < 5000; ++call) {
      for (int l = 0; l < L; ++l) {
        for (int k = 0; k < np; ++k) p[L * k + l] = m->params[k].default_estimate + within(rng) * m->params[k].default_u;
        if (sin_cos && call % 2 == 1) p[L * 2 + l] = turns(rng);  // phi [rad]
      }
      m->forward_lanes(nullptr, p.data(), out.data(), L, L);
      for (int l = 0; l < L; ++l) {
        std::vector<double> pi(np), o(no);
        for (int k = 0; k < np; ++k) pi[k] = p[L * k + l];
        m->forward(nullptr, pi.data(), o.data());
        for (int q = 0; q < no; ++q) {
          const double scale = std::max(std::fabs(o[q]), 1.0);
          ASSERT_NEAR(out[L * q + l], o[q], 1e-14 * scale) << m->name << " output " << q;
          worst_sin_cos = std::max(worst_sin_cos, std::fabs(out[L * q + l] - o[q]) / scale);
        }
      }
    }
  }
  EXPECT_EQ(customs, 4);  // jcgm101_additive, jcgm101_mass, gum_h1_end_gauge, gum_h2_impedance
  EXPECT_GT(worst_sin_cos, 0.0);  // not libm's sin/cos: the comparison is not vacuous
}

TEST(GeneratedModels, RegistrySortedAndConsistent) {
  const auto models = vlt::AllModels();
  ASSERT_GE(models.size(), 4u);
  for (std::size_t i = 1; i < models.size(); ++i) {
    EXPECT_LT(std::string(models[i - 1]->name), std::string(models[i]->name));
  }
  for (const vlt::ModelInfo* m : models) {
    EXPECT_EQ(std::string(m->spec_file), std::string("models/") + m->name + ".toml");
    EXPECT_GT(m->ops_forward, 0) << m->name;
    EXPECT_GE(m->ops_forward_jacobians, m->ops_forward) << m->name;
  }
  EXPECT_EQ(Model("mirror").num_params, vlt::gen::mirror::kNumParams);
  EXPECT_EQ(vlt::FindParam(Model("mirror"), "tmv"), vlt::gen::mirror::param::tmv);
  EXPECT_EQ(vlt::FindParam(Model("head"), "lam"), vlt::gen::head::param::lam);
}

// GUM H.1: l = l_s + d - l_s (dalpha theta + alpha_s dtheta). Check values: l = 50.000838 mm,
// first-order u_c(l) = 32 nm (GUM H.1.6). Sensitivities at the estimates (GUM H.1.5):
// c_ls = 1, c_d = 1, c_alpha_s = -l_s dtheta = 0, c_theta = -l_s dalpha = 0,
// c_dalpha = -l_s theta = +5.0e-3 m K, c_dtheta = -l_s alpha_s = -5.75e-7 m/K.
TEST(GeneratedGumH1, ReproducesTheGumEndGaugeExample) {
  const vlt::ModelInfo& m = Model("gum_h1_end_gauge");
  ASSERT_EQ(m.num_params, 6);
  std::vector<double> x(6), u(6);
  for (int k = 0; k < 6; ++k) {
    x[k] = m.params[k].default_estimate;
    u[k] = m.params[k].default_u;
  }
  double l, dl[6];
  m.forward_jacobians(nullptr, x.data(), &l, nullptr, dl);
  EXPECT_NEAR(l, 50.000838e-3, 0.5e-9);  // printed to the nm
  EXPECT_NEAR(dl[0], 1.0, 1e-15);
  EXPECT_NEAR(dl[1], 1.0, 1e-15);
  EXPECT_EQ(dl[2], 0.0);
  EXPECT_EQ(dl[3], 0.0);
  EXPECT_NEAR(dl[4], 0.050000623 * 0.1, 1e-15);
  EXPECT_NEAR(dl[5], -0.050000623 * 11.5e-6, 1e-18);
  double u2 = 0;
  for (int k = 0; k < 6; ++k) u2 += dl[k] * dl[k] * u[k] * u[k];
  EXPECT_NEAR(std::sqrt(u2), 32e-9, 0.5e-9);  // GUM: 32 nm
  // Jacobians also against AD and FD at random input values (the model is linear in each
  // input separately, so central differences are exact up to rounding for any step).
  std::mt19937_64 rng(5);
  std::normal_distribution<double> normal(0.0, 1.0);
  const std::array<double, 6> h = {10.0, 10.0, 10.0, 10.0, 10.0, 10.0};
  for (double scale : {1.0, 100.0}) {
    for (int t = 0; t < 10; ++t) {
      std::array<double, 6> p;
      for (int k = 0; k < 6; ++k) p[k] = x[k] + scale * u[k] * normal(rng);
      CheckJacobians<gum_h1_end_gauge_kernels>(nullptr, p.data(), nullptr, h.data(), 1e-300, "gum_h1");
    }
  }
}

TEST(GeneratedJcgm101Additive, IsTheSumOfItsInputs) {
  const vlt::ModelInfo& m = Model("jcgm101_additive");
  ASSERT_EQ(m.num_params, 4);
  ASSERT_EQ(m.num_readings, 0);
  const double x[4] = {0.5, -1.25, 2.0, 3.5};
  double y, dy[4];
  m.forward_jacobians(nullptr, x, &y, nullptr, dy);
  EXPECT_EQ(y, 4.75);
  for (double d : dy) EXPECT_EQ(d, 1.0);
  double u2 = 0;
  for (int k = 0; k < 4; ++k) u2 += m.params[k].default_u * m.params[k].default_u;
  EXPECT_DOUBLE_EQ(std::sqrt(u2), 2.0);  // JCGM 101 9.2.2: u(y) = 2
  const std::array<double, 4> h = {0.1, 0.1, 0.1, 0.1};
  CheckJacobians<jcgm101_additive_kernels>(nullptr, x, nullptr, h.data(), 1e-300, "jcgm101");
}

}  // namespace

namespace vlt {
namespace {

// Custom models: NominalJacobians is the value and Jacobian at the spec's estimates (vlt-gen
// specialises there), i.e. ForwardJacobians evaluated at the default estimates. For GUM H.1 this
// is l = 50.000838 mm and the GUM's sensitivity coefficients.
TEST(GeneratedCustomModels, NominalJacobiansAreForwardJacobiansAtTheEstimates) {
  for (const ModelInfo* m : AllModels()) {
    if (std::string_view(m->kind) != "custom") continue;
    std::vector<double> p(m->num_params), out_n(m->num_outputs), out_f(m->num_outputs);
    std::vector<double> jp_n(m->num_outputs * m->num_params), jp_f(jp_n.size());
    for (int k = 0; k < m->num_params; ++k) p[k] = m->params[k].default_estimate;
    m->nominal_jacobians(nullptr, out_n.data(), nullptr, jp_n.data());
    m->forward_jacobians(nullptr, p.data(), out_f.data(), nullptr, jp_f.data());
    // The two differ by the rounding of the double evaluation (the nominal one is specialised
    // exactly): a few ulps of the largest term, |x_k dy/dx_k|, which for a difference such as
    // JCGM 101 9.3's (m_Rc + dm_Rc) - 100000 mg is far above the result.
    for (int i = 0; i < m->num_outputs; ++i) {
      double scale = std::abs(out_f[i]);
      for (int k = 0; k < m->num_params; ++k) {
        scale = std::max(scale, std::abs(p[k] * jp_f[static_cast<std::size_t>(k) * m->num_outputs + i]));
      }
      EXPECT_NEAR(out_n[i], out_f[i], 1e-14 * scale) << m->name;
      for (int k = 0; k < m->num_params; ++k) {
        const std::size_t j = static_cast<std::size_t>(k) * m->num_outputs + i;
        const double column_scale = p[k] != 0.0 ? scale / std::abs(p[k]) : std::abs(jp_f[j]);
        EXPECT_NEAR(jp_n[j], jp_f[j], 1e-14 * std::max(std::abs(jp_f[j]), column_scale) + 1e-300) << m->name;
      }
    }
  }
  const ModelInfo* h1 = FindModel("gum_h1_end_gauge");
  ASSERT_NE(h1, nullptr);
  double out = 0.0;
  std::vector<double> jp(h1->num_params);
  h1->nominal_jacobians(nullptr, &out, nullptr, jp.data());
  EXPECT_NEAR(out, 0.050000838, 1e-12);  // GUM H.1.5: l = 50.000 838 mm
}

}  // namespace
}  // namespace vlt
