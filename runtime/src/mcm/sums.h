// mcm/sums.h — the running sums of a Monte Carlo run (internal): per output Σd and Σd², per
// output group the cross sums, d = y - y(estimates), for a chunk, a batch and the whole run
// (JCGM 101 7.6, JCGM 102 7.6: mean and covariance from them).
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "mcm/engine.h"

namespace vlt::mcm_internal {

// Layout of the partial sums of one chunk / batch / run: per output sum d and sum d^2, then per
// output group (a point's x, y, z; a custom model's output vector) the cross sums of every pair
// (a < b, in the order (0,1), (0,2), ..., (1,2), ...) of the deviations d = y - y(estimates).
struct SumLayout {
  int outputs;
  std::vector<int> cross_offset;  // first cross sum of each group
  int cross_total = 0;
  int tolerances = 0;  // then one count per tolerance (McmSettings::tolerances)
  SumLayout(int num_outputs, const std::vector<OutputGroup>& groups, int num_tolerances)
      : outputs(num_outputs), tolerances(num_tolerances) {
    for (const OutputGroup& g : groups) {
      cross_offset.push_back(2 * outputs + cross_total);
      cross_total += g.dim * (g.dim - 1) / 2;
    }
  }
  int stride() const { return 2 * outputs + cross_total + tolerances; }
  int count(int t) const { return 2 * outputs + cross_total + t; }
  int sum(int o) const { return 2 * o; }
  int sum2(int o) const { return 2 * o + 1; }
  int cross(int g, int pair) const { return cross_offset[g] + pair; }
};

// Index of the pair (a, b), a < b, among the pairs of a group of dimension dim.
inline int PairIndex(int a, int b, int dim) {
  if (a > b) std::swap(a, b);
  return a * dim - a * (a + 1) / 2 + (b - a - 1);
}

// Adds the cross sums of group g over n trials (out: outputs[o * kSubBatch + i]) to part.
void AddCrossSums(const OutputGroup& g, int gi, const SumLayout& layout, const double* out, int n,
                  const std::vector<double>& y0, double* part);

// Throws the NumericalError of a trial whose output is not finite.
[[noreturn]] void NotFinite(std::int64_t trial, const std::string& output);

// The sums of a point (a group of three outputs from `o`) over the n trials of a sub-batch: per
// component the sum and the sum of squares of d = y - y(estimates), the three cross sums, and d
// stored as float (dst[a][i]). The nine running sums advance side by side, each still adding its
// trials in order from zero (the bits of one sum after another, as AddCrossSums does), so that
// they overlap instead of each waiting for the previous addition.
void AccumulatePoint(int o, int gi, const SumLayout& layout, const double* out, int n,
                     const std::vector<double>& y0, float* const dst[3], double* part,
                     std::int64_t first_trial, const std::vector<std::string>& names);

// Mean and covariance of group g (dim outputs from g.first) from the sums of n trials.
void GroupMoments(const std::vector<double>& sums, const SumLayout& layout, const OutputGroup& g, int gi,
                  const std::vector<double>& y0, std::int64_t n, Eigen::VectorXd* mean, Eigen::MatrixXd* cov);

}  // namespace vlt::mcm_internal
