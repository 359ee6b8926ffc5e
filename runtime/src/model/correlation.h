// model/correlation.h — the factor of a correlation matrix that both engines use to correlate
// inputs (GUM: J L, Monte Carlo: the Gaussian copula, JCGM 101 6.4.8).
#pragma once

#include <Eigen/Core>

namespace vlt::model_internal {

// L with L L^T = R for a positive semi-definite correlation matrix R: the Cholesky factor when R
// is positive definite (so the Monte Carlo stream of such jobs is what it always was), else
// V sqrt(max(Lambda, 0)) from the eigendecomposition R = V Lambda V^T, which also serves singular
// matrices such as r = +-1 (JCGM 101 6.4.8.1 allows them). Returns false if R has an eigenvalue
// below -1e-10 (not a correlation matrix).
bool CorrelationFactor(const Eigen::MatrixXd& r, Eigen::MatrixXd& factor);

// The correlation matrix of a covariance matrix: r_ab = U_ab / (s_a s_b), s = sqrt(diag U);
// identity where a standard deviation is 0 (GUM custom outputs, Monte Carlo output vectors).
Eigen::MatrixXd CorrelationOfCovariance(const Eigen::MatrixXd& covariance);

}  // namespace vlt::model_internal
