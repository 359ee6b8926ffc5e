// mcm/sampling.cc — drawing the inputs of the Monte Carlo engine (JCGM 101 6.4, 6.4.8, C).
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include <Eigen/Cholesky>

#include "mcm/engine.h"
#include "model/correlation.h"
#include "vlt/error.h"

namespace vlt::mcm_internal {

namespace {

// Groups of 4 trials share one Philox call (random.h); trials outside [first, first + n) of the
// edge groups are computed and discarded. Up to KeyedStream::kBulkGroups groups at once; each
// block's normals z of trials first + i go to copy_out(z, i, count).
template <typename CopyOut>
void ForEachNormalsBlock(const KeyedStream& rng, std::uint64_t stream, std::int64_t first, int n,
                         CopyOut copy_out) {
  constexpr int kBulk = KeyedStream::kBulkGroups;
  const std::int64_t last = first + n;
  const std::int64_t group_end = (last + 3) >> 2;
  alignas(64) double z[4 * kBulk];
  for (std::int64_t g = first >> 2; g < group_end; g += kBulk) {
    const int groups = static_cast<int>(std::min<std::int64_t>(kBulk, group_end - g));
    rng.NormalsBulk(static_cast<std::uint64_t>(g), groups, stream, z);
    const std::int64_t t0 = std::max(first, 4 * g);
    const std::int64_t t1 = std::min(last, 4 * (g + groups));
    copy_out(z + (t0 - 4 * g), t0 - first, static_cast<int>(t1 - t0));
  }
}

}  // namespace

void DrawNormals(const KeyedStream& rng, std::uint64_t stream, std::int64_t first, int n, double* out) {
  ForEachNormalsBlock(rng, stream, first, n, [out](const double* z, std::int64_t i, int count) {
    std::copy(z, z + count, out + i);
  });
}

void DrawScaledNormals(const KeyedStream& rng, std::uint64_t stream, std::int64_t first, int n, double mean,
                       double u, double* out) {
  ForEachNormalsBlock(rng, stream, first, n, [out, mean, u](const double* z, std::int64_t i, int count) {
    double* x = out + i;
    for (int k = 0; k < count; ++k) x[k] = mean + u * z[k];
  });
}

namespace {

void DrawUniformInputs(const KeyedStream& rng, const Distribution& dist, std::uint64_t stream,
                       std::int64_t first, int n, double* out) {
  const std::int64_t last = first + n;
  const bool two = dist.kind() == DistributionKind::kCurvilinearTrapezoid;
  double u1[4], u2[4] = {0.5, 0.5, 0.5, 0.5};
  for (std::int64_t g = first >> 2; 4 * g < last; ++g) {
    rng.Uniforms(static_cast<std::uint64_t>(g), stream, 0, u1);
    if (two) rng.Uniforms(static_cast<std::uint64_t>(g), stream, 1, u2);
    for (int j = 0; j < 4; ++j) {
      const std::int64_t trial = 4 * g + j;
      if (trial >= first && trial < last) out[trial - first] = dist.SampleTwoUniforms(u1[j], u2[j]);
    }
  }
}

void DrawStudentT(const KeyedStream& rng, const Distribution& dist, std::uint64_t stream, std::int64_t first,
                  int n, double* out) {
  double u[4];
  for (int i = 0; i < n; ++i) {
    const std::uint64_t trial = static_cast<std::uint64_t>(first + i);
    for (std::uint64_t attempt = 0;; ++attempt) {
      rng.TrialUniforms(trial, stream, attempt, u);
      if (dist.SampleBailey(u[0], u[1], &out[i])) break;
      if (dist.SampleBailey(u[2], u[3], &out[i])) break;
    }
  }
}

}  // namespace

double DrawChiSquare(const KeyedStream& rng, std::uint64_t stream, std::uint64_t trial, double nu) {
  // Gamma(a), a = nu / 2: d = a' - 1/3, c = 1 / sqrt(9 d) with a' = a (a >= 1) or a + 1 (a < 1).
  const double a = 0.5 * nu;
  const double a1 = a < 1.0 ? a + 1.0 : a;
  const double d = a1 - 1.0 / 3.0, c = 1.0 / std::sqrt(9.0 * d);
  double u[4];
  for (std::uint64_t attempt = 0;; ++attempt) {
    rng.TrialUniforms(trial, stream, attempt, u);
    // One normal from (u0, u1) by Box-Muller, u2 for the acceptance test, u3 for the boost.
    const double z = std::sqrt(-2.0 * std::log(u[0])) * std::cos(2.0 * std::numbers::pi * u[1]);
    const double t = 1.0 + c * z;
    if (t <= 0.0) continue;
    const double v = t * t * t;
    if (std::log(u[2]) < 0.5 * z * z + d - d * v + d * std::log(v)) {
      double g = d * v;
      if (a < 1.0) g *= std::pow(u[3], 1.0 / a);
      return 2.0 * g;
    }
  }
}

InputSampler::InputSampler(std::vector<Distribution> inputs, std::vector<std::string> names,
                           const Eigen::MatrixXd& correlation, std::uint64_t first_stream,
                           std::string_view where, std::span<const MultivariateTGroup> t_groups)
    : inputs_(std::move(inputs)), first_stream_(first_stream) {
  const int n = size();
  const std::string at(where);
  if (correlation.size() != 0) {
    if (correlation.rows() != n || correlation.cols() != n) {
      throw InputError(at + ": correlation matrix is " + std::to_string(correlation.rows()) + "x" +
                       std::to_string(correlation.cols()) + ", expected " + std::to_string(n) + "x" +
                       std::to_string(n));
    }
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < n; ++j) {
        const double r = correlation(i, j);
        const bool ok =
            std::isfinite(r) && (i == j ? r == 1.0 : std::abs(r) <= 1.0) && r == correlation(j, i);
        if (!ok) {
          throw InputError(at + ": correlation matrix entry ('" + names[i] + "', '" + names[j] +
                           "') must be symmetric, in [-1, 1], and 1 on the diagonal");
        }
      }
    }
  }
  // Inputs with a non-zero correlation to another input, and the members of a multivariate t
  // group, go through the copula.
  std::vector<int> group_of(n, -1);
  for (std::size_t g = 0; g < t_groups.size(); ++g) {
    if (!(t_groups[g].dof > 0.0) || !std::isfinite(t_groups[g].dof)) {
      throw InputError(at + ": a multivariate t group needs finite degrees of freedom > 0");
    }
    for (int k : t_groups[g].inputs) {
      if (k < 0 || k >= n || group_of[k] != -1 || inputs_[k].kind() != DistributionKind::kNormal) {
        throw InputError(at + ": multivariate t group " + std::to_string(g) +
                         ": each member must be a distinct normal input");
      }
      group_of[k] = static_cast<int>(g);
    }
    t_dof_.push_back(t_groups[g].dof);
  }
  for (int i = 0; i < n; ++i) {
    bool correlated = group_of[i] != -1;
    if (correlation.size() != 0) {
      for (int j = 0; j < n && !correlated; ++j) correlated = j != i && correlation(i, j) != 0.0;
    }
    (correlated ? copula_ : independent_).push_back(i);
  }
  if (!copula_.empty()) {
    const int m = static_cast<int>(copula_.size());
    Eigen::MatrixXd r(m, m);
    for (int a = 0; a < m; ++a) {
      for (int b = 0; b < m; ++b) r(a, b) = correlation(copula_[a], copula_[b]);
    }
    // Gaussian copula through a factor L L^T = R (JCGM 101 6.4.8): Cholesky for a positive
    // definite R, the eigen factor for a singular one (r = +-1): model/correlation.h.
    if (!model_internal::CorrelationFactor(r, cholesky_)) {
      std::string list;
      for (int a = 0; a < m; ++a) list += (a ? ", '" : "'") + names[copula_[a]] + "'";
      throw InputError(at + ": the correlation matrix of " + list + " is not positive semi-definite");
    }
    factor_is_lower_ = cholesky_.isLowerTriangular(0.0);
    for (int a = 0; a < m; ++a) t_group_of_.push_back(group_of[copula_[a]]);
  }
}

void InputSampler::Draw(const KeyedStream& rng, std::int64_t first, int n, double* out, int stride,
                        double* scratch) const {
  for (int k : independent_) {
    const Distribution& dist = inputs_[k];
    double* row = out + static_cast<std::ptrdiff_t>(k) * stride;
    const std::uint64_t stream = first_stream_ + static_cast<std::uint64_t>(k);
    if (dist.u() == 0.0) {
      std::fill(row, row + n, dist.estimate());
      continue;
    }
    switch (dist.kind()) {
      case DistributionKind::kNormal: {
        DrawScaledNormals(rng, stream, first, n, dist.estimate(), dist.u(), row);
        break;
      }
      case DistributionKind::kStudentT: DrawStudentT(rng, dist, stream, first, n, row); break;
      default: DrawUniformInputs(rng, dist, stream, first, n, row); break;
    }
  }
  if (copula_.empty()) return;
  // Gaussian copula: independent standard normals z, correlated normals L z, then each marginal
  // through its inverse CDF at Phi(L z) (exact for normal marginals: mu + u (L z)).
  const int m = static_cast<int>(copula_.size());
  for (int a = 0; a < m; ++a) {
    DrawNormals(rng, first_stream_ + static_cast<std::uint64_t>(copula_[a]), first, n,
                scratch + static_cast<std::ptrdiff_t>(a) * n);
  }
  constexpr double kPmin = std::numeric_limits<double>::min();
  const double kPmax = std::nextafter(1.0, 0.0);
  double t_scale[8];
  std::vector<double> t_scale_heap;
  double* mix = t_scale;
  if (t_dof_.size() > 8) {
    t_scale_heap.resize(t_dof_.size());
    mix = t_scale_heap.data();
  }
  for (int i = 0; i < n; ++i) {
    // JCGM 102 6.5.3: X = x + L z / sqrt(w / nu), one w ~ chi2_nu per group and trial.
    for (std::size_t g = 0; g < t_dof_.size(); ++g) {
      const std::uint64_t trial = static_cast<std::uint64_t>(first + i);
      mix[g] = std::sqrt(t_dof_[g] / DrawChiSquare(rng, kChiSquareStream + g, trial, t_dof_[g]));
    }
    for (int a = 0; a < m; ++a) {
      double zc = 0.0;
      const int columns = factor_is_lower_ ? a + 1 : m;  // Cholesky: the same sums as always
      for (int b = 0; b < columns; ++b)
        zc += cholesky_(a, b) * scratch[static_cast<std::ptrdiff_t>(b) * n + i];
      if (!t_group_of_.empty() && t_group_of_[a] >= 0) zc *= mix[t_group_of_[a]];
      const Distribution& dist = inputs_[copula_[a]];
      double value;
      if (dist.kind() == DistributionKind::kNormal || dist.u() == 0.0) {
        value = dist.estimate() + dist.u() * zc;
      } else {
        value = dist.Quantile(std::clamp(StandardNormalCdf(zc), kPmin, kPmax));
      }
      out[static_cast<std::ptrdiff_t>(copula_[a]) * stride + i] = value;
    }
  }
}

}  // namespace vlt::mcm_internal
