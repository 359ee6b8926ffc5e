// model/correlation.cc — see correlation.h.
// The correlation of a measurement setup's shared inputs (vlt/measurement_model.h): the one checker
// of a correlation matrix and the one place where correlation groups become the S x S matrix.
#include "model/correlation.h"

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "vlt/error.h"
#include "vlt/measurement_model.h"

namespace vlt::model_internal {

bool CorrelationFactor(const Eigen::MatrixXd& r, Eigen::MatrixXd& factor) {
  const Eigen::LLT<Eigen::MatrixXd> llt(r);
  if (llt.info() == Eigen::Success) {
    factor = llt.matrixL();
    return true;
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(r);
  if (eig.info() != Eigen::Success || eig.eigenvalues().minCoeff() < -1e-10) return false;
  factor = eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
  return true;
}

Eigen::MatrixXd CorrelationOfCovariance(const Eigen::MatrixXd& covariance) {
  const Eigen::Index n = covariance.rows();
  const Eigen::VectorXd sd = covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
  Eigen::MatrixXd r = Eigen::MatrixXd::Identity(n, n);
  for (Eigen::Index a = 0; a < n; ++a) {
    for (Eigen::Index b = 0; b < n; ++b) {
      if (a != b && sd(a) > 0.0 && sd(b) > 0.0) r(a, b) = covariance(a, b) / (sd(a) * sd(b));
    }
  }
  return r;
}

}  // namespace vlt::model_internal

namespace vlt {

void CheckCorrelationMatrix(const Eigen::MatrixXd& r, const std::string& where) {
  if (r.rows() != r.cols()) {
    throw InputError(where + ": expected a square matrix, got " + std::to_string(r.rows()) + " x " +
                     std::to_string(r.cols()));
  }
  const int m = static_cast<int>(r.rows());
  for (int i = 0; i < m; ++i) {
    for (int j = 0; j < m; ++j) {
      if (!std::isfinite(r(i, j))) throw InputError(where + ": not a finite number");
    }
  }
  for (int i = 0; i < m; ++i) {
    if (std::abs(r(i, i) - 1.0) > 1e-12) {
      throw InputError(where + ": diagonal element " + std::to_string(i + 1) + " is not 1");
    }
    for (int j = 0; j < m; ++j) {
      if (std::abs(r(i, j) - r(j, i)) > 1e-12) throw InputError(where + ": not symmetric");
      if (std::abs(r(i, j)) > 1.0) throw InputError(where + ": correlation coefficient outside [-1, 1]");
    }
  }
  // A correlation matrix must be positive semi-definite (JCGM 101 6.4.8.1), else no joint
  // distribution has it and the GUM variance can come out negative.
  if (m == 0) return;
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(r, Eigen::EigenvaluesOnly);
  const double smallest = eig.eigenvalues().minCoeff();
  if (eig.info() != Eigen::Success || smallest < -1e-10) {
    char value[32];
    std::snprintf(value, sizeof value, "%.6g", smallest);
    throw InputError(where + ": correlation matrix is not positive semi-definite (smallest eigenvalue " +
                     value + ")");
  }
}

Eigen::MatrixXd SharedCorrelation(const std::vector<std::string>& names,
                                  const std::vector<CorrelationGroup>& groups) {
  const int n = static_cast<int>(names.size());
  Eigen::MatrixXd full = Eigen::MatrixXd::Identity(n, n);
  std::vector<int> owner(n, -1);  // index of the group of each input
  for (std::size_t g = 0; g < groups.size(); ++g) {
    const CorrelationGroup& group = groups[g];
    const std::string label = "measurement setup: correlation group '" + group.name + "'";
    const std::string& where_inputs = group.where_inputs.empty() ? label : group.where_inputs;
    const std::string& where_matrix = group.where_matrix.empty() ? label : group.where_matrix;
    if (group.name.empty()) throw InputError(where_inputs + ": a correlation group needs a name");
    for (std::size_t h = 0; h < g; ++h) {
      if (groups[h].name == group.name) {
        throw InputError(where_inputs + ": correlation group name '" + group.name + "' is used twice");
      }
    }
    if (group.inputs.empty()) throw InputError(where_inputs + ": no inputs");
    std::vector<int> index;
    for (const std::string& name : group.inputs) {
      int k = 0;
      while (k < n && names[k] != name) ++k;
      if (k == n) {
        std::string list;
        for (const std::string& known : names) list += (list.empty() ? "" : ", ") + known;
        throw InputError(where_inputs + ": unknown input '" + name + "' (inputs: " + list + ")");
      }
      if (owner[k] == static_cast<int>(g)) {
        throw InputError(where_inputs + ": input '" + name + "' appears twice");
      }
      if (owner[k] >= 0) {
        throw InputError(where_inputs + ": input '" + name + "' is already in correlation group '" +
                         groups[owner[k]].name + "' (an input may be in one group only)");
      }
      owner[k] = static_cast<int>(g);
      index.push_back(k);
    }
    const int m = static_cast<int>(index.size());
    if (group.matrix.rows() != m || group.matrix.cols() != m) {
      throw InputError(where_matrix + ": expected " + std::to_string(m) + " x " + std::to_string(m) +
                       " (one row and column per input), got " + std::to_string(group.matrix.rows()) + " x " +
                       std::to_string(group.matrix.cols()));
    }
    CheckCorrelationMatrix(group.matrix, where_matrix);
    // Exactly symmetric with a unit diagonal (the checks allow 1e-12): what the Monte Carlo
    // copula requires.
    for (int i = 0; i < m; ++i) {
      for (int j = 0; j < m; ++j) {
        full(index[i], index[j]) = i == j ? 1.0 : 0.5 * (group.matrix(i, j) + group.matrix(j, i));
      }
    }
  }
  return full;
}

}  // namespace vlt
