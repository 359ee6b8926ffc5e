// GUM engine: coverage factors (computed, JCGM 100 G.1.3, JCGM 102 6.5.2.3), sensitivity
// units, the factor of the shared-input covariance and the deterministic chunked thread pool.
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Dense>

#include "gum/internal.h"
#include "model/correlation.h"
#include "vlt/error.h"
#include "vlt/distributions.h"
#include "vlt/gum.h"

namespace vlt {
namespace {

// Bisection of a monotonically increasing cdf on [lo, hi] to full double precision.
template <typename Cdf>
double InvertIncreasing(Cdf cdf, double p, double lo, double hi) {
  for (int i = 0; i < 2000 && hi - lo > 4 * std::numeric_limits<double>::epsilon() * hi; ++i) {
    const double mid = 0.5 * (lo + hi);
    (cdf(mid) < p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace

// Chi-square cdf with m (integer) degrees of freedom: regularized lower incomplete gamma
// P(m/2, x/2) by the exact recurrence P(a + 1, z) = P(a, z) - z^a e^-z / Gamma(a + 1), from
// P(1/2, z) = erf(sqrt z) and P(1, z) = 1 - e^-z (Abramowitz & Stegun 6.5.13, 26.4.4-5).
double ChiSquareCdf(double x, int m) {
  if (x <= 0.0) return 0.0;
  const double z = 0.5 * x;
  double a = (m % 2 == 1) ? 0.5 : 1.0;
  double p = (m % 2 == 1) ? std::erf(std::sqrt(z)) : -std::expm1(-z);
  while (a < 0.5 * m - 0.25) {
    p -= std::exp(a * std::log(z) - z - std::lgamma(a + 1.0));
    a += 1.0;
  }
  return p;
}

double NormalCoverageFactor(double p) {
  if (!(p > 0.0 && p < 1.0)) {
    throw std::invalid_argument("coverage probability must be in (0, 1)");
  }
  // P(|Z| <= k) = erf(k / sqrt 2) = p.
  return InvertIncreasing([](double k) { return std::erf(k / std::sqrt(2.0)); }, p, 0.0, 40.0);
}

double StudentTCoverageFactor(double p, double nu) {
  if (!(p > 0.0 && p < 1.0) || !(nu >= 1.0)) {
    throw std::invalid_argument("coverage probability must be in (0, 1), degrees of freedom >= 1");
  }
  // Above nu = 1e7 t_p(nu) equals the normal k to better than 1e-7 (k_t - k_n ~ (k^3 + k) / (4 nu)),
  // and the incomplete beta function loses its accuracy: use the normal one.
  if (nu > 1e7) return NormalCoverageFactor(p);
  // Closed forms where the tail is heavy: nu = 1 (Cauchy) k = tan(pi p / 2); nu = 2
  // k = p sqrt(2 / (1 - p^2)).
  if (nu == 1.0) return std::tan(0.5 * std::numbers::pi * p);
  if (nu == 2.0) return p * std::sqrt(2.0 / (1.0 - p * p));
  // P(|T| <= k) = 2 F(k) - 1 = p; k < 1e6 for nu >= 3 and p < 1 - 1e-15.
  const double k = InvertIncreasing([nu](double t) { return 2.0 * StudentTCdf(t, nu) - 1.0; }, p, 0.0, 1e6);
  if (!(k < 1e6)) throw std::invalid_argument("Student t coverage factor beyond 1e6");
  return k;
}

double WelchSatterthwaite(double u_c, const std::vector<double>& component_variances,
                          const std::vector<double>& component_dof) {
  double denominator = 0.0;
  for (std::size_t i = 0; i < component_variances.size(); ++i) {
    const double nu = component_dof[i];
    if (std::isfinite(nu) && nu > 0.0) {
      denominator += component_variances[i] * component_variances[i] / nu;
    }
  }
  const double u4 = u_c * u_c * u_c * u_c;
  if (!(denominator > 0.0) || !(u4 > 0.0)) return std::numeric_limits<double>::infinity();
  return u4 / denominator;
}

double ChiSquareCoverageFactor(double p, int m) {
  if (!(p > 0.0 && p < 1.0) || m < 1) {
    throw std::invalid_argument("coverage probability must be in (0, 1), dimension >= 1");
  }
  const double q = InvertIncreasing([m](double x) { return ChiSquareCdf(x, m); }, p, 0.0,
                                    1000.0 + 100.0 * m);
  return std::sqrt(q);
}

std::string SensitivityUnit(const std::string& output_unit, const std::string& input_unit) {
  const std::string out = output_unit.empty() ? "1" : output_unit;
  std::string in = input_unit.empty() ? "1" : input_unit;
  // A temperature enters a sensitivity as a difference: d y / d t per kelvin.
  if (in == "degC" || in == "K") in = "K";
  if (in == "1") return out;
  if (in.rfind("1/", 0) == 0) {  // d y / d (1/K) = y * K
    const std::string inverse = in.substr(2);
    return out == "1" ? inverse : out + "*" + inverse;
  }
  return out + "/" + in;
}

namespace gum_internal {

namespace {

// Adds the block of `inputs` (increasing) with correlation r to f; a single input stays diagonal.
void AddBlock(SharedFactor& f, std::vector<int> inputs, const Eigen::MatrixXd& r) {
  const int m = static_cast<int>(inputs.size());
  if (m < 2) return;
  SharedFactor::Block b;
  b.inputs = std::move(inputs);
  b.contiguous = b.inputs.back() - b.inputs.front() == m - 1;
  b.correlation = r;
  Eigen::MatrixXd l;
  if (!model_internal::CorrelationFactor(r, l)) {
    throw InputError("correlation matrix of the shared inputs is not positive semi-definite");
  }
  Eigen::VectorXd u(m);
  for (int a = 0; a < m; ++a) u(a) = f.u(b.inputs[a]);
  b.factor = u.asDiagonal() * l;
  f.blocks.push_back(std::move(b));
  f.diagonal = false;
}

}  // namespace

SharedFactor MakeSharedFactor(const MeasurementModel& model) {
  SharedFactor f;
  f.num_shared = model.num_shared();
  const int n = f.num_shared;
  f.u.resize(n);
  for (int k = 0; k < n; ++k) f.u(k) = model.shared_inputs()[k].u;
  const Eigen::MatrixXd& r = model.shared_correlation();
  // Blocks: connected components of the graph of non-zero correlations, in order of their first
  // input (each in increasing order).
  std::vector<int> component(n, -1);
  for (int start = 0; start < n; ++start) {
    if (component[start] >= 0) continue;
    std::vector<int> members{start}, stack{start};
    component[start] = start;
    while (!stack.empty()) {
      const int i = stack.back();
      stack.pop_back();
      for (int j = 0; j < n; ++j) {
        if (component[j] < 0 && j != i && r(i, j) != 0.0) {
          component[j] = start;
          members.push_back(j);
          stack.push_back(j);
        }
      }
    }
    std::sort(members.begin(), members.end());
    const int m = static_cast<int>(members.size());
    Eigen::MatrixXd rb(m, m);
    for (int a = 0; a < m; ++a)
      for (int c = 0; c < m; ++c) rb(a, c) = r(members[a], members[c]);
    AddBlock(f, std::move(members), rb);
  }
  return f;
}

void SharedFactor::Apply(const double* j, double* a, int rows) const {
  Eigen::Map<const Eigen::MatrixXd> jm(j, rows, num_shared);
  Eigen::Map<Eigen::MatrixXd> am(a, rows, num_shared);
  am = jm * u.asDiagonal();
  for (const Block& b : blocks) {
    const int m = static_cast<int>(b.inputs.size());
    if (b.contiguous) {
      am.middleCols(b.inputs.front(), m).noalias() = jm.middleCols(b.inputs.front(), m) * b.factor;
    } else {
      const Eigen::MatrixXd jb = jm(Eigen::all, b.inputs);
      am(Eigen::all, b.inputs) = jb * b.factor;
    }
  }
}

bool SharedFactor::Separates(const std::vector<bool>& keep) const {
  for (const Block& b : blocks) {
    for (int i : b.inputs) {
      if (keep[i] != keep[b.inputs.front()]) return false;
    }
  }
  return true;
}

SharedFactor SharedFactor::Marginal(const std::vector<bool>& keep) const {
  SharedFactor f;
  f.num_shared = num_shared;
  f.u = u;
  for (int k = 0; k < num_shared; ++k) {
    if (!keep[k]) f.u(k) = 0.0;
  }
  for (const Block& b : blocks) {
    std::vector<int> kept, at;
    for (int a = 0; a < static_cast<int>(b.inputs.size()); ++a) {
      if (keep[b.inputs[a]]) {
        kept.push_back(b.inputs[a]);
        at.push_back(a);
      }
    }
    if (kept.size() == b.inputs.size()) {
      f.blocks.push_back(b);
      f.diagonal = false;
      continue;
    }
    // A principal submatrix of a positive semi-definite matrix is one too.
    AddBlock(f, kept, b.correlation(at, at));
  }
  return f;
}

std::string PointLabel(const std::string& name, std::size_t index) {
  if (!name.empty()) return "point '" + name + "': ";
  return "point #" + std::to_string(index + 1) + ": ";
}

}  // namespace gum_internal
}  // namespace vlt
