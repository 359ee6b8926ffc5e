// Independent check of the physics inside the generated tracker models.
//
// The generator's own tests compare its Jacobians with finite differences and autodiff of the
// generated forward model, which cannot catch a wrong forward model. Here the two tracker models
// are re-implemented numerically, straight from their documented definitions (docs/models.md,
// reference README section 2 for the NPL chain), with Eigen rotations and an explicit
// line-plane intersection and reflection, and compared with the generated Forward at random
// error states of realistic and exaggerated magnitude.
#include <array>
#include <cmath>
#include <random>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "vlt/models.h"

namespace {

using Eigen::AngleAxisd;
using Eigen::Vector3d;

const Vector3d kX = Vector3d::UnitX(), kY = Vector3d::UnitY(), kZ = Vector3d::UnitZ();

// Looks up a parameter by name; the generated model may omit it (then it is zero).
struct Params {
  const vlt::ModelInfo& model;
  const std::vector<double>& values;
  double operator()(const char* name) const {
    const int k = vlt::FindParam(model, name);
    return k < 0 ? 0.0 : values[k];
  }
};

// The SMR: from the point the beam leaves (o), its unit direction (dr) and the length to the
// vertex (l), the sphere centre, with the dihedral-angle pointing error and the vertex offsets.
Vector3d ReflectorCentre(const Params& p, const Vector3d& o, const Vector3d& dr, double l) {
  const Vector3d eh = kZ.cross(dr).normalized();                     // horizontal, toward increasing azimuth
  const Vector3d ev = dr.cross(eh);                                  // toward increasing elevation
  const double psi = 0.5 * (4.0 * std::sqrt(6.0) / 3.0) * p("sdh");  // half the deviation
  const Vector3d line_of_sight = AngleAxisd(-psi, eh) * dr;          // rotated toward ev
  const Vector3d vertex = o + l * line_of_sight;
  return vertex - p("srr") * dr - p("srh") * eh - p("srv") * ev;
}

Vector3d MirrorRayTrace(const Params& p, double range, double azimuth, double elevation) {
  const double a = azimuth + p("a0") + p("eac") * std::cos(azimuth) + p("eas") * std::sin(azimuth);
  const double tau_r = elevation / 2;  // the mirror turns half the beam's elevation
  const double tau = tau_r + p("e0") + p("eec") * std::cos(tau_r) + p("ees") * std::sin(tau_r);
  const Eigen::Matrix3d body = AngleAxisd(a, kZ).toRotationMatrix();
  const Vector3d axis_point = body * (p("thv") * kX);
  const Eigen::Matrix3d transit = body * AngleAxisd(p("rhv"), kX).toRotationMatrix();
  const Vector3d normal_home =
      std::cos(p("rmv")) * Vector3d(1, 0, -1) / std::sqrt(2.0) + std::sin(p("rmv")) * kY;
  const Vector3d n = transit * (AngleAxisd(-tau, kY) * normal_home);
  const Vector3d beam_point(p("tbw"), p("tbv"), 0);
  const Vector3d ei = AngleAxisd(p("rbh"), kY) * (AngleAxisd(p("rbv"), kX) * kZ);
  // Line-plane intersection: n . (b0 + t ei - q) = tmv.
  const double t_hit = (p("tmv") - n.dot(beam_point - axis_point)) / n.dot(ei);
  const Vector3d hit = beam_point + t_hit * ei;
  const Vector3d dr = ei - 2 * ei.dot(n) * n;           // mirror reflection
  const double path = (1 + p("mu")) * range + p("R0");  // counted from z = 0 along the beam
  return ReflectorCentre(p, hit, dr.normalized(), path - t_hit);
}

// NPL chain, reference README section 2, with Z = pi/2 - elevation.
Vector3d HeadChain(const Params& p, double range, double azimuth, double elevation) {
  const double d = (1 + p("mu")) * range + p("lam");
  const double h = azimuth + p("aa1") * std::cos(azimuth) + p("ba1") * std::sin(azimuth) +
                   p("aa2") * std::cos(2 * azimuth) + p("ba2") * std::sin(2 * azimuth);
  const double z = M_PI / 2 - elevation;
  const double zp = z + p("ae0") + p("ae1") * std::cos(z) + p("be1") * std::sin(z) +
                    p("ae2") * std::cos(2 * z) + p("be2") * std::sin(2 * z);
  const double alpha = p("alpha");
  const Eigen::Matrix3d m =
      (AngleAxisd(h, kZ) * AngleAxisd(alpha, kX) * AngleAxisd(zp - M_PI / 2, kY) * AngleAxisd(-alpha, kX))
          .toRotationMatrix();
  const Vector3d b = AngleAxisd(h, kZ) * (p("ex") * kX) + m * Vector3d(-p("ex"), p("by"), p("bz"));
  const Vector3d n = m * (AngleAxisd(p("gamma"), kZ) * kX);
  return ReflectorCentre(p, b, n, d);
}

using Reference = Vector3d (*)(const Params&, double, double, double);

void CompareWithReference(const char* model_name, Reference reference) {
  const vlt::ModelInfo* model = vlt::FindModel(model_name);
  ASSERT_NE(model, nullptr) << model_name;
  std::mt19937_64 rng(20261121);
  std::uniform_real_distribution<double> unit(-1, 1);
  for (double scale : {1.0, 100.0}) {
    for (int trial = 0; trial < 200; ++trial) {
      std::vector<double> params(model->num_params);
      for (int k = 0; k < model->num_params; ++k) {
        params[k] = scale * 3 * model->params[k].default_u * unit(rng);
      }
      const double range = 0.5 + 39.5 * (0.5 + 0.5 * unit(rng));
      const double azimuth = M_PI * unit(rng);
      double elevation = 1.3 * unit(rng);
      if (trial % 2 == 1) elevation = M_PI - elevation;  // back face readings
      const std::array<double, 3> readings = {range, azimuth, elevation};
      std::array<double, 3> generated{};
      model->forward(readings.data(), params.data(), generated.data());
      const Vector3d expected = reference(Params{*model, params}, range, azimuth, elevation);
      for (int i = 0; i < 3; ++i) {
        EXPECT_NEAR(generated[i], expected[i], 1e-12 * (1 + range))
            << model_name << " scale " << scale << " trial " << trial << " axis " << i;
      }
    }
  }
}

TEST(ModelPhysics, MirrorMatchesIndependentRayTrace) { CompareWithReference("mirror", MirrorRayTrace); }

TEST(ModelPhysics, HeadMatchesNplChain) { CompareWithReference("head", HeadChain); }

// Sanity of the reference itself: with every error zero both give the ideal spherical point.
TEST(ModelPhysics, ReferencesAreIdealAtZeroErrors) {
  for (const char* name : {"mirror", "head"}) {
    const vlt::ModelInfo* model = vlt::FindModel(name);
    ASSERT_NE(model, nullptr);
    const std::vector<double> zero(model->num_params, 0.0);
    const Params p{*model, zero};
    const double range = 7.5, az = 0.7, el = -0.3;
    const Vector3d ideal =
        range * Vector3d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
    const Vector3d r =
        std::string(name) == "mirror" ? MirrorRayTrace(p, range, az, el) : HeadChain(p, range, az, el);
    EXPECT_LT((r - ideal).norm(), 1e-13) << name;
  }
}

}  // namespace
