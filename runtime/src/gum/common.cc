// GUM engine: sensitivity units, the factor of the shared-input covariance (the coverage factors
// are in stats/coverage.cc).
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
