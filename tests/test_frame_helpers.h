// Shared by the tests of alignments and weighted fits: the rotation of vlt's alignment outputs.
#pragma once

#include <Eigen/Geometry>

namespace vlt::test {

// R = Rz(rz) Ry(ry) Rx(rx): the fixed-axis angles rx, ry, rz of a best_fit's outputs (vlt/fits.h).
inline Eigen::Matrix3d Rotation(double rx, double ry, double rz) {
  return (Eigen::AngleAxisd(rz, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(ry, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(rx, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

}  // namespace vlt::test
