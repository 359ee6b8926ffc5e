// Internals shared by the GUM engine's source files (gum_*.cc). Not a public header.
#pragma once

#include <cstddef>
#include <functional>
#include <string>

#include <Eigen/Core>

#include "vlt/measurement_model.h"

namespace vlt::gum_internal {

// Factor F of the covariance of the shared inputs, U_s = F F^T. The only correlated block is
// the parameter block: F = blockdiag(D_p L_p, diag(u_rest)) with R_p = L_p L_p^T (LDLT, so that
// a positive semi-definite correlation matrix, e.g. with r = +-1, works too). Propagating J F
// instead of J U_s J^T keeps the per-point work at 3 x S (diagonal case) or 3 x P x P / 2.
struct SharedFactor {
  int num_params = 0;
  int num_shared = 0;
  bool diagonal = true;
  Eigen::VectorXd u;              // standard uncertainty of every shared input
  Eigen::MatrixXd param_factor;   // P x P (only when !diagonal): D_p L_p

  // a = j F for a 3 x S (rows x S) column-major j; a may not alias j.
  void Apply(const double* j, double* a, int rows) const;
};

SharedFactor MakeSharedFactor(const MeasurementModel& model);

// Runs body(chunk_index, begin, end) over [0, n) in chunks of `chunk` items on up to `threads`
// threads (0: hardware concurrency). Chunks are fixed by n and chunk alone, so results that are
// combined per chunk in chunk order do not depend on the thread count. An exception thrown by a
// body is rethrown after all threads have joined: the one of the lowest chunk index.
void ParallelChunks(std::size_t n, std::size_t chunk, int threads,
                    const std::function<void(std::size_t, std::size_t, std::size_t)>& body);

// Horizontal distance [m] below which a point is on the tracker's standing axis (as
// kVerticalAxisTolerance of vlt/job.h).
inline constexpr double kStandingAxisTolerance = 1e-6;

// "point '<name>': " or "point #<index>: " for messages.
std::string PointLabel(const std::string& name, std::size_t index);

}  // namespace vlt::gum_internal
