// calibration/observations.h — the observation equations of a tracker calibration (internal to
// runtime/src/calibration/), shared by the Ceres cost functions (the solve) and the dense
// Jacobian (identifiability, covariance, residuals), so both see one definition.
//
// Unknowns: error parameters p (all of the model's, SI), target coordinates x_j (tracker frame,
// m), bar lengths L_b (m). Every residual is whitened (divided by its standard uncertainty).
#pragma once

#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "vlt/calibration.h"

namespace vlt::calibration_internal {

// A reading as an observation of its target: e = S^-1/2 J_r^-1 (f(m; p) - x_j), the residual of
// the three readings (range, azimuth, elevation) in units of their standard uncertainties. The
// whitening matrix W = S^-1/2 J_r^-1 is computed once at the prior estimates p0 (fixed weights).
struct ReadingObservation {
  int target = -1;
  Eigen::Vector3d readings = Eigen::Vector3d::Zero();
  Eigen::Matrix3d whitening = Eigen::Matrix3d::Identity();
  Eigen::Vector3d sigma = Eigen::Vector3d::Ones();  // u(range) [m], u(az), u(el) [rad]
};

// (|x_a - x_b| - length) / u, where `length` is a bar's unknown length (bar >= 0) or a fixed
// reference distance (bar = -1).
struct DistanceObservation {
  int a = -1, b = -1;
  int bar = -1;
  double length = 0.0;  // reference distance when bar < 0
  double u = 1.0;
  std::string label, where;
};

// The calibration problem with names resolved to indices.
struct IndexedProblem {
  const ModelInfo* model = nullptr;
  int num_params = 0;
  Eigen::VectorXd p0, u0;  // prior estimates and uncertainties (SI), model order
  std::vector<std::string> target_names;
  std::vector<int> target_reading_count;
  std::vector<ReadingObservation> readings;
  std::vector<DistanceObservation> distances;  // bar positions and reference distances
  std::vector<double> bar_length, bar_u;       // calibration of each bar: (L - L_cal) / u_cal
  int num_residuals() const {
    return 3 * static_cast<int>(readings.size()) + static_cast<int>(distances.size()) +
           static_cast<int>(bar_length.size());
  }
};

// Resolves names, computes the whitening at the prior; InputError for unknown targets, a
// non-tracker model, non-positive uncertainties.
IndexedProblem IndexProblem(const CalibrationData& data);

// e (3) and d e / d p (3 x P, column-major) of one reading at parameters p and target x.
// d e / d x = -W.
void ReadingResidual(const IndexedProblem& problem, const ReadingObservation& obs, const double* p,
                     const double* x, double* e, double* d_e_d_p);

// e, d e / d x_a (3), d e / d x_b (3) of one distance; d e / d L = -1/u for a bar.
double DistanceResidual(const DistanceObservation& obs, const double* xa, const double* xb, double length,
                        double* d_e_d_xa, double* d_e_d_xb);

// Dense whitened residuals and Jacobian at (p, targets, bars) with respect to
// [ p (all P) | targets (3T) | bars (B) ]; rows: readings (3 each), distances, bar calibrations.
void DenseSystem(const IndexedProblem& problem, const Eigen::VectorXd& p, const Eigen::VectorXd& targets,
                 const Eigen::VectorXd& bars, Eigen::VectorXd& e, Eigen::MatrixXd& jacobian);

}  // namespace vlt::calibration_internal
