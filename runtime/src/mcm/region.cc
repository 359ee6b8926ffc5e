// mcm/region.cc — the coverage factor k_p of the JCGM 102 coverage region (7.7.3) from the
// stored values of a run.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/LU>

#include "mcm/engine.h"
#include "mcm/order.h"
#include "mcm/storage.h"
#include "parallel/pool.h"

namespace vlt::mcm_internal {
namespace {

// d[r - begin] = |L^-1 (y_r - mean)| for the trials r in [begin, end) of one group of `dim` components
// (series[a]: component a's deviations from y0; rows: L^-1 row-major). kDim > 0 fixes the size at
// compile time (a point: 3), so that the rows' sums of a trial are computed side by side rather
// than one loop after another; the arithmetic, and so every bit, is the same as for kDim = 0.
template <int kDim>
void RegionDistances(int dim, const float* const* series, const double* mean_minus_y0, const double* rows,
                     std::size_t begin, std::size_t end, double* d) {
  const int n = kDim > 0 ? kDim : dim;
  constexpr int kBuffer = kDim > 0 ? kDim : 64;
  std::vector<double> heap(kDim > 0 || n <= kBuffer ? 0 : static_cast<std::size_t>(n));
  double buffer[kBuffer];
  double* dev = heap.empty() ? buffer : heap.data();
  for (std::size_t r = begin; r < end; ++r) {
    for (int a = 0; a < n; ++a) dev[a] = static_cast<double>(series[a][r]) - mean_minus_y0[a];
    double sum2 = 0.0;
    for (int a = 0; a < n; ++a) {
      double w = 0.0;
      for (int b = 0; b < n; ++b) w += rows[a * n + b] * dev[b];
      sum2 += w * w;
    }
    d[r - begin] = std::sqrt(sum2);
  }
}

}  // namespace

// k_p of JCGM 102 7.7.3 from the deviations (float, relative to y0) of n trials of one group:
// the q-th smallest |L^-1 (y_r - mean)|. series[a] holds component a. Returns false when the
// covariance is not positive definite. The distances are computed block by block on the threads
// (each on its own: the same bits for any thread count) and only those beyond the sample's
// threshold kept (mcm/order.h GatherHighTail); where that does not apply, into one array of n
// distances, then the pass of the order statistic (GatherTails).
bool GatherRegionTail(const std::vector<const float*>& series, std::int64_t n,
                      const Eigen::VectorXd& mean_minus_y0, const Eigen::MatrixXd& cov, double p, int threads,
                      Tails<double>* tails) {
  const int dim = static_cast<int>(series.size());
  Eigen::LLT<Eigen::MatrixXd> llt(cov);
  if (llt.info() != Eigen::Success || !(cov.diagonal().minCoeff() > 0.0)) return false;
  const Eigen::MatrixXd l_inv = Eigen::MatrixXd(llt.matrixL()).inverse();
  if (!l_inv.allFinite()) return false;
  // Row-major copy of L^-1; |w| with w_a = sum_b (L^-1)_ab dev_b summed in b order (RegionDistances).
  const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> rows = l_inv;
  auto distances = [&](std::int64_t begin, std::int64_t end, double* out) {
    const auto b = static_cast<std::size_t>(begin), e = static_cast<std::size_t>(end);
    if (dim == 3) {
      RegionDistances<3>(3, series.data(), mean_minus_y0.data(), rows.data(), b, e, out);
    } else {
      RegionDistances<0>(dim, series.data(), mean_minus_y0.data(), rows.data(), b, e, out);
    }
  };
  // The q-th smallest distance is the smallest of the n - q + 1 largest.
  const std::int64_t high = n - CoverageCount(n, p) + 1;
  if (GatherHighTail(n, high, distances, threads, tails)) return true;
  std::vector<double, UninitializedAllocator<double>> d(static_cast<std::size_t>(n));
  parallel_internal::ForEachChunk(static_cast<std::size_t>(n), kPassChunk, threads,
                                  [&](std::size_t, std::size_t begin, std::size_t end) {
                                    distances(static_cast<std::int64_t>(begin), static_cast<std::int64_t>(end),
                                              d.data() + begin);
                                  });
  GatherTails(std::span<const double>(d.data(), d.size()), 0, high, tails, threads);
  return true;
}

bool RegionFactor(const std::vector<const float*>& series, std::int64_t n,
                  const Eigen::VectorXd& mean_minus_y0, const Eigen::MatrixXd& cov, double p, int threads,
                  double* k) {
  Tails<double> tails;
  if (!GatherRegionTail(series, n, mean_minus_y0, cov, p, threads, &tails)) return false;
  *k = SmallestOfHighTail(&tails);
  return true;
}

}  // namespace vlt::mcm_internal
