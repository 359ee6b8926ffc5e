// model/correlation.cc — see correlation.h.
#include "model/correlation.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

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

}  // namespace vlt::model_internal
