// Internals shared by the GUM engine's source files (gum_*.cc). Not a public header.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "vlt/measurement_model.h"

namespace vlt::gum_internal {

// Factor F of the covariance of the shared inputs, U_s = F F^T = D R D with D = diag(u) and R =
// MeasurementModel::shared_correlation(). Up to a permutation R is block diagonal: a block is a set
// of inputs linked by non-zero correlations (a correlation group, or the part of one that is
// correlated), and it may span input groups (environment.temperature with thermal.temperature).
// F = diag(u) on the independent inputs and D_b L_b on each block b, R_b = L_b L_b^T
// (model/correlation.h: Cholesky, or the eigen factor for a singular R_b such as r = +-1).
// Column s of J F belongs to input s when s is independent, else to the block of s. Propagating
// J F instead of J U_s J^T keeps the per-point work at 3 x S (no correlation) or 3 x sum |b|^2.
struct SharedFactor {
  struct Block {
    std::vector<int> inputs;      // shared indices, increasing
    bool contiguous = false;      // inputs = inputs[0], inputs[0] + 1, ...
    Eigen::MatrixXd correlation;  // R_b
    Eigen::MatrixXd factor;       // D_b L_b
  };
  int num_shared = 0;
  bool diagonal = true;  // no block: every shared input independent
  Eigen::VectorXd u;     // standard uncertainty of every shared input
  std::vector<Block> blocks;

  // a = j F for a rows x S column-major j; a may not alias j.
  void Apply(const double* j, double* a, int rows) const;
  // True when no block has inputs both inside and outside `keep` (S flags): then the columns of
  // J F of the kept inputs are a factor of their covariance alone.
  bool Separates(const std::vector<bool>& keep) const;
  // Factor of the marginal covariance of the inputs in `keep`, the others at u = 0 (a block that
  // `keep` splits is refactored on its kept inputs): J F_keep (J F_keep)^T is the covariance due to
  // the kept inputs alone, with their correlations among themselves.
  SharedFactor Marginal(const std::vector<bool>& keep) const;
};

SharedFactor MakeSharedFactor(const MeasurementModel& model);

// Horizontal distance [m] below which a point is on the tracker's standing axis (as
// kVerticalAxisTolerance of vlt/job.h).
inline constexpr double kStandingAxisTolerance = 1e-6;

// "point '<name>': " or "point #<index>: " for messages.
std::string PointLabel(const std::string& name, std::size_t index);

// JCGM 100 5.1.2 note: the second-order variance 1/2 ||H||_F^2 of an output from its Hessian in z
// (symmetrised: central differences give it up to rounding), for points and custom models alike.
inline double SecondOrderVariance(const Eigen::MatrixXd& hz) {
  return 0.5 * (0.5 * (hz + hz.transpose())).squaredNorm();
}

}  // namespace vlt::gum_internal
