// mcm/sums.cc — the running sums of a Monte Carlo run (sums.h).
#include "mcm/sums.h"

#include <cmath>

#include "vlt/error.h"

namespace vlt::mcm_internal {

void AddCrossSums(const OutputGroup& g, int gi, const SumLayout& layout, const double* out, int n,
                  const std::vector<double>& y0, double* part) {
  for (int a = 0; a < g.dim; ++a) {
    const double* xa = out + static_cast<std::size_t>(g.first + a) * kSubBatch;
    for (int b = a + 1; b < g.dim; ++b) {
      const double* xb = out + static_cast<std::size_t>(g.first + b) * kSubBatch;
      double s = 0.0;
      for (int i = 0; i < n; ++i) s += (xa[i] - y0[g.first + a]) * (xb[i] - y0[g.first + b]);
      part[layout.cross(gi, PairIndex(a, b, g.dim))] += s;
    }
  }
}

[[noreturn]] void NotFinite(std::int64_t trial, const std::string& output) {
  throw NumericalError("Monte Carlo trial " + std::to_string(trial) + ": output '" + output +
                       "' is not finite (a drawn input reached a singular point)");
}

void AccumulatePoint(int o, int gi, const SumLayout& layout, const double* out, int n,
                     const std::vector<double>& y0, float* const dst[3], double* part,
                     std::int64_t first_trial, const std::vector<std::string>& names) {
  const double* x = out + static_cast<std::size_t>(o) * kSubBatch;
  const double* y = x + kSubBatch;
  const double* z = y + kSubBatch;
  const double x0 = y0[o], y0_ = y0[o + 1], z0 = y0[o + 2];
  double sx = 0.0, sy = 0.0, sz = 0.0, sxx = 0.0, syy = 0.0, szz = 0.0, sxy = 0.0, sxz = 0.0, syz = 0.0;
  for (int i = 0; i < n; ++i) {
    if (!std::isfinite(x[i]) || !std::isfinite(y[i]) || !std::isfinite(z[i])) {
      const int bad = !std::isfinite(x[i]) ? 0 : (!std::isfinite(y[i]) ? 1 : 2);
      NotFinite(first_trial + i, names[o + bad]);
    }
    const double dx = x[i] - x0, dy = y[i] - y0_, dz = z[i] - z0;
    sx += dx;
    sy += dy;
    sz += dz;
    sxx += dx * dx;
    syy += dy * dy;
    szz += dz * dz;
    sxy += dx * dy;
    sxz += dx * dz;
    syz += dy * dz;
    dst[0][i] = static_cast<float>(dx);
    dst[1][i] = static_cast<float>(dy);
    dst[2][i] = static_cast<float>(dz);
  }
  part[layout.sum(o)] += sx;
  part[layout.sum2(o)] += sxx;
  part[layout.sum(o + 1)] += sy;
  part[layout.sum2(o + 1)] += syy;
  part[layout.sum(o + 2)] += sz;
  part[layout.sum2(o + 2)] += szz;
  part[layout.cross(gi, PairIndex(0, 1, 3))] += sxy;
  part[layout.cross(gi, PairIndex(0, 2, 3))] += sxz;
  part[layout.cross(gi, PairIndex(1, 2, 3))] += syz;
}

void GroupMoments(const std::vector<double>& sums, const SumLayout& layout, const OutputGroup& g, int gi,
                  const std::vector<double>& y0, std::int64_t n, Eigen::VectorXd* mean,
                  Eigen::MatrixXd* cov) {
  const double dn = static_cast<double>(n);
  const int d = g.dim;
  Eigen::VectorXd s1(d);
  for (int a = 0; a < d; ++a) s1(a) = sums[layout.sum(g.first + a)];
  mean->resize(d);
  cov->resize(d, d);
  for (int a = 0; a < d; ++a) (*mean)(a) = y0[g.first + a] + s1(a) / dn;
  for (int a = 0; a < d; ++a) {
    for (int b = 0; b < d; ++b) {
      const double sab = a == b ? sums[layout.sum2(g.first + a)] : sums[layout.cross(gi, PairIndex(a, b, d))];
      (*cov)(a, b) = (sab - s1(a) * s1(b) / dn) / (dn - 1.0);
    }
  }
}

}  // namespace vlt::mcm_internal
