// bench_common.h — what every vlt benchmark shares: the measurement plan the points come from,
// the measurement setups, the law-of-propagation kernel used by the hand-written loops and the
// registry the summary (bench_main.cc) reads its ratios from. docs/performance.md explains the
// numbers.
//
// Every per-point benchmark works on a batch of DIFFERENT points along a realistic plan (the
// panel of the demo job: 4 m x 1.5 m, 0.8 m below the gimbal point, 3 m to 7 m away), never on
// one point repeated, so branch prediction and caches see what a real job gives them.
#pragma once

#include <cmath>
#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "vlt/measurement_model.h"
#include "vlt/model_info.h"

namespace vlt::bench {

// Points per batch of the per-point benchmarks (the demo job's map has ~2000 points).
inline constexpr std::size_t kBatch = 4096;

// Reading noise of the demo job: u(range) = 5 um + 0.5 um/m, 0.5 arcsec on both angles.
inline constexpr double kArcsec = 4.84813681109536e-6;  // rad
inline constexpr double kRangeA = 5e-6;                 // m
inline constexpr double kRangeB = 0.5e-6;               // m/m
inline constexpr double kAngleU = 0.5 * kArcsec;        // rad

// n nominal points (part frame = tracker frame, m) on a grid over the panel x in [3, 7] m,
// y in [-0.75, 0.75] m, z = -0.8 m; about 8/3 as many columns as rows.
std::vector<Eigen::Vector3d> PanelPoints(std::size_t n);

// The readings (range, azimuth, elevation) that measure those points with the setup's
// estimates (vlt::ReadingsForPartPoint, the offline plan mode).
std::vector<Eigen::Vector3d> PanelReadings(const MeasurementModel& model, std::size_t n);

// The setup of a tracker model with every error parameter active at its spec default
// (estimate, u, distribution), the demo job's reading noise and, if `environment`, the demo
// job's weather station (Ciddor, 20.5 degC +- 0.2 K, 1013.25 hPa +- 0.3 hPa, 45 % +- 5 %
// rectangular, 450 ppm +- 30 ppm).
MeasurementSetup TrackerSetup(const char* model_name, bool environment = false);
const ModelInfo& Model(const char* model_name);

// Operation counts of the Sensitivity_<p> kernels of a model, in parameter order, read from the
// banner of generated/<model>.h ("//   Sensitivity_a0    195"); empty if the file is missing.
std::vector<int> BannerSensitivityOps(const char* model_name);

// Standard uncertainties of [range, azimuth, elevation, params...] of one point (N = 3 + P).
template <int N>
Eigen::Matrix<double, N, 1> InputUncertainties(const MeasurementModel& model, double range) {
  Eigen::Matrix<double, N, 1> u;
  u.template head<3>() = model.reading_uncertainty(range);
  for (int k = 3; k < N; ++k) u(k) = model.shared_inputs()[k - 3].u;
  return u;
}

// The law of propagation of uncertainty for independent inputs (JCGM 100 5.1.2, matrix form
// JCGM 102 6.2.1.3): U_y = J diag(u)^2 J^T = (J diag(u)) (J diag(u))^T, fused: the six distinct
// entries as dot products of the rows of the 3 x N scaled Jacobian. (Eigen's a * a.transpose()
// sends 3 x 23 x 3 through its general matrix-matrix kernel, sizes above
// EIGEN_GEMM_TO_COEFFBASED_THRESHOLD, which costs more than the Jacobian itself.)
template <int N>
inline Eigen::Matrix3d PropagateCovariance(const Eigen::Matrix<double, 3, N>& j,
                                           const Eigen::Matrix<double, N, 1>& u) {
  const Eigen::Matrix<double, 3, N> a = j * u.asDiagonal();
  Eigen::Matrix3d c;
  c(0, 0) = a.row(0).squaredNorm();
  c(1, 1) = a.row(1).squaredNorm();
  c(2, 2) = a.row(2).squaredNorm();
  c(0, 1) = c(1, 0) = a.row(0).dot(a.row(1));
  c(0, 2) = c(2, 0) = a.row(0).dot(a.row(2));
  c(1, 2) = c(2, 1) = a.row(1).dot(a.row(2));
  return c;
}

}  // namespace vlt::bench
