// calibration/standard_tests.cc — the standard tests on a virtual tracker and simulated test data
// (vlt/calibration.h SimulateTests, SimulateCalibrationData; docs/calibration.md "Standard tests").
//
// A tracker with true error state p reads m = f^-1(x; p) at the true point x (vlt/inverse.h) and
// reports y = f(m; p_c) with its own compensation p_c (the model's default estimates). The
// derivatives of y with respect to p follow from the implicit function theorem:
//   d m / d p = -J_r(m; p)^-1 J_p(m; p),   d y / d p = J_r(m; p_c) d m / d p.
#include <algorithm>
#include <cmath>
#include <map>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include "mcm/random.h"
#include "vlt/calibration.h"
#include "vlt/error.h"
#include "vlt/gum.h"

namespace vlt {

const char* TestKindName(TestKind kind) {
  switch (kind) {
    case TestKind::kLength: return "length";
    case TestKind::kRanging: return "ranging";
    case TestKind::kTwoFace: return "two_face";
  }
  return "?";
}

namespace {

// One target as the tracker sees it: readings, reported point, d y / d readings (at p_c),
// d y / d p (true state), reading covariance.
struct Sighting {
  Eigen::Vector3d readings;
  Eigen::Vector3d reported;
  Eigen::Matrix3d d_y_d_readings;
  Eigen::MatrixXd d_y_d_params;  // 3 x P
  Eigen::Matrix3d reading_cov;
};

Eigen::VectorXd Estimates(const std::vector<UncertainInput>& inputs) {
  Eigen::VectorXd v(static_cast<Eigen::Index>(inputs.size()));
  for (std::size_t k = 0; k < inputs.size(); ++k) v(static_cast<Eigen::Index>(k)) = inputs[k].estimate;
  return v;
}

Eigen::VectorXd Compensation(const ModelInfo& model) {
  Eigen::VectorXd v(model.num_params);
  for (int k = 0; k < model.num_params; ++k) v(k) = model.params[k].default_estimate;
  return v;
}

Eigen::Vector3d ReadingSigma(const ReadingNoise& noise, double range) {
  return {noise.range_a + noise.range_b * range, noise.azimuth, noise.elevation};
}

Sighting See(const MeasurementSetup& tracker, const Eigen::VectorXd& p_true, const Eigen::VectorXd& p_comp,
             const Eigen::Vector3d& x, Face face, const std::string& where) {
  const ModelInfo& model = *tracker.model;
  const int P = model.num_params;
  if (std::hypot(x.x(), x.y()) < 1e-6) {
    throw NumericalError(where + ": the target lies on the tracker's standing axis (azimuth undefined)");
  }
  Sighting s;
  const std::array<double, 3> m = InverseReadings(model, p_true.data(), {x.x(), x.y(), x.z()}, face);
  s.readings = Eigen::Vector3d(m[0], m[1], m[2]);
  Eigen::Vector3d y;
  Eigen::Matrix3d jr_true;
  Eigen::MatrixXd jp_true(3, P), jp_comp(3, P);
  model.forward_jacobians(s.readings.data(), p_true.data(), y.data(), jr_true.data(), jp_true.data());
  model.forward_jacobians(s.readings.data(), p_comp.data(), s.reported.data(), s.d_y_d_readings.data(),
                          jp_comp.data());
  s.d_y_d_params = -s.d_y_d_readings * jr_true.fullPivLu().solve(jp_true);
  const Eigen::Vector3d sigma = ReadingSigma(tracker.noise, s.readings(0));
  s.reading_cov = sigma.cwiseAbs2().asDiagonal();
  return s;
}

// Covariance of the parameters (u and correlation of the tracker's parameters).
Eigen::MatrixXd ParamCovariance(const MeasurementSetup& tracker) {
  const int P = static_cast<int>(tracker.params.size());
  // The parameters' block of the shared correlation (the parameters come first).
  Eigen::MatrixXd c = SharedCorrelation(SharedInputNames(tracker), tracker.correlations).topLeftCorner(P, P);
  for (int i = 0; i < P; ++i)
    for (int j = 0; j < P; ++j) c(i, j) *= tracker.params[i].u * tracker.params[j].u;
  return c;
}

const ReferenceBar& FindBar(const TestLayout& layout, const StandardTest& test) {
  for (const ReferenceBar& bar : layout.bars) {
    if (bar.name == test.bar) return bar;
  }
  throw InputError(test.where + ": bar '" + test.bar + "' is not defined in the layout");
}

}  // namespace

std::vector<TestResult> SimulateTests(const MeasurementSetup& tracker, const TestLayout& layout,
                                      const TestSettings& settings) {
  const ModelInfo& model = *tracker.model;
  const int P = model.num_params;
  const Eigen::VectorXd p_true = Estimates(tracker.params);
  const Eigen::VectorXd p_comp = Compensation(model);
  const Eigen::MatrixXd cov_p = ParamCovariance(tracker);
  const double k = NormalCoverageFactor(settings.coverage_probability);
  std::vector<TestResult> out;
  for (const StandardTest& test : layout.tests) {
    TestResult r;
    r.name = test.name;
    r.kind = test.kind;
    r.k = k;
    r.sensitivity = Eigen::VectorXd::Zero(P);
    const Mpe* mpe = nullptr;
    if (test.kind == TestKind::kTwoFace) {
      const Sighting front = See(tracker, p_true, p_comp, test.a, Face::kFront, test.where);
      const Sighting back = See(tracker, p_true, p_comp, test.a, Face::kBack, test.where);
      r.range_max = std::max(front.readings(0), back.readings(0));
      r.two_face = back.reported - front.reported;
      r.error = r.two_face.norm();
      const Eigen::Vector3d radial = test.a.normalized();
      r.two_face_radial = r.two_face.dot(radial);
      r.two_face_transverse = (r.two_face - r.two_face_radial * radial).norm();
      const Eigen::Matrix3d cov =
          front.d_y_d_readings * front.reading_cov * front.d_y_d_readings.transpose() +
          back.d_y_d_readings * back.reading_cov * back.d_y_d_readings.transpose();
      const Eigen::MatrixXd d_delta = back.d_y_d_params - front.d_y_d_params;  // 3 x P
      // |Delta| is not differentiable at Delta = 0: use the direction of Delta, or the largest
      // axis of the covariance for an error-free tracker.
      Eigen::Vector3d g;
      if (r.error > 1e-15) {
        g = r.two_face / r.error;
      } else {
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
        g = eig.eigenvectors().col(2);
      }
      r.u = std::sqrt(g.dot(cov * g));
      r.u_noise = r.u;
      r.two_face_noise = cov;
      r.two_face_sensitivity = d_delta;
      const Eigen::RowVectorXd gp = g.transpose() * d_delta;
      r.u_parameters = std::sqrt(std::max(0.0, (gp * cov_p * gp.transpose())(0, 0)));
      for (int q = 0; q < P; ++q) r.sensitivity(q) = d_delta.col(q).norm();
      mpe = &settings.two_face;
    } else {
      const Sighting sa = See(tracker, p_true, p_comp, test.a, test.face, test.where);
      const Sighting sb = See(tracker, p_true, p_comp, test.b, test.face, test.where);
      r.range_max = std::max(sa.readings(0), sb.readings(0));
      r.reference = (test.b - test.a).norm();
      const Eigen::Vector3d d = sb.reported - sa.reported;
      r.error = d.norm() - r.reference;
      const Eigen::Vector3d unit = d / d.norm();
      double u_ref = test.reference_u;
      if (test.kind == TestKind::kLength) {
        // The bar's calibration and its reproducibility in this position (nests, sag, temperature).
        const ReferenceBar& bar = FindBar(layout, test);
        u_ref = std::hypot(bar.u, bar.u_position);
      }
      const Eigen::RowVector3d ga = -unit.transpose() * sa.d_y_d_readings;
      const Eigen::RowVector3d gb = unit.transpose() * sb.d_y_d_readings;
      const double var =
          (ga * sa.reading_cov * ga.transpose())(0, 0) + (gb * sb.reading_cov * gb.transpose())(0, 0);
      r.u = std::sqrt(var + u_ref * u_ref);
      r.u_noise = std::sqrt(var);
      r.sensitivity = (unit.transpose() * (sb.d_y_d_params - sa.d_y_d_params)).transpose();
      r.u_parameters = std::sqrt(std::max(0.0, r.sensitivity.dot(cov_p * r.sensitivity)));
      mpe = test.kind == TestKind::kLength ? &settings.length : &settings.ranging;
    }
    r.U = k * r.u;
    if (mpe->set) {
      r.mpe = mpe->a + mpe->b * r.range_max;
      r.verdict = std::abs(r.error) <= r.mpe ? "pass" : "fail";
    }
    if (!std::isfinite(r.error) || !std::isfinite(r.u) || !r.sensitivity.allFinite()) {
      throw NumericalError(test.where + ": test '" + test.name + "' has no finite result");
    }
    out.push_back(std::move(r));
  }
  return out;
}

CalibrationData SimulateCalibrationData(const MeasurementSetup& tracker, const TestLayout& layout,
                                        std::uint64_t seed) {
  const ModelInfo& model = *tracker.model;
  const Eigen::VectorXd p_true = Estimates(tracker.params);
  const mcm_internal::KeyedStream stream(seed);
  // Draw d of a quantity: (trial = index, input = stream) -> one standard normal. Streams:
  // 0..2 readings (range, azimuth, elevation), 3 bar calibration, 4 bar position, 5 reference.
  auto normal = [&](std::uint64_t index, std::uint64_t input) {
    double z[4];
    stream.Normals(index / 4, input, z);
    return z[index % 4];
  };
  CalibrationData data;
  data.model = &model;
  data.where = layout.where;
  data.noise = tracker.noise;
  for (int k = 0; k < model.num_params; ++k) {
    UncertainInput prior;
    const QuantityInfo& q = model.params[k];
    prior.name = q.name;
    prior.unit = q.unit;
    prior.group = "parameter";
    prior.estimate = q.default_estimate;
    prior.u = q.default_u;
    data.priors.push_back(prior);
  }
  std::uint64_t reading_index = 0;
  auto read = [&](const std::string& target, const Eigen::Vector3d& x, Face face, const std::string& where) {
    if (std::hypot(x.x(), x.y()) < 1e-6) {
      throw NumericalError(where + ": target '" + target + "' lies on the tracker's standing axis");
    }
    const std::array<double, 3> m = InverseReadings(model, p_true.data(), {x.x(), x.y(), x.z()}, face);
    TargetReading r;
    r.target = target;
    r.face = face;
    const Eigen::Vector3d sigma = ReadingSigma(tracker.noise, m[0]);
    for (int c = 0; c < 3; ++c)
      r.readings(c) = m[c] + sigma(c) * normal(reading_index, static_cast<std::uint64_t>(c));
    r.readings(1) = NormalizeAzimuth(r.readings(1));
    r.where = where;
    ++reading_index;
    data.readings.push_back(r);
  };
  // Bars: the calibrated value differs from the true length by the calibration error.
  std::map<std::string, std::size_t> bar_index;
  std::vector<double> bar_true;
  for (std::size_t b = 0; b < layout.bars.size(); ++b) {
    ReferenceBar bar = layout.bars[b];
    bar.positions.clear();
    bar_index[bar.name] = b;
    bar_true.push_back(bar.length);
    bar.length += bar.u * normal(b, 3);
    data.bars.push_back(bar);
  }
  std::uint64_t position_index = 0, reference_index = 0;
  for (const StandardTest& test : layout.tests) {
    if (test.kind == TestKind::kTwoFace) {
      read(test.name, test.a, Face::kFront, test.where);
      read(test.name, test.a, Face::kBack, test.where);
      continue;
    }
    const std::string a = test.name + ".a", b = test.name + ".b";
    Eigen::Vector3d xa = test.a, xb = test.b;
    if (test.kind == TestKind::kLength) {
      const ReferenceBar& bar = FindBar(layout, test);
      const std::size_t bi = bar_index[bar.name];
      // The bar in this position: true length plus the position's reproducibility, about its
      // centre along its axis.
      const double length = bar_true[bi] + bar.u_position * normal(position_index++, 4);
      const Eigen::Vector3d centre = 0.5 * (test.a + test.b);
      const Eigen::Vector3d axis = (test.b - test.a).normalized();
      xa = centre - 0.5 * length * axis;
      xb = centre + 0.5 * length * axis;
      data.bars[bi].positions.emplace_back(a, b);
    } else {
      ReferenceDistance ref;
      ref.from = a;
      ref.to = b;
      ref.u = test.reference_u;
      ref.length = (test.b - test.a).norm() + test.reference_u * normal(reference_index++, 5);
      ref.where = test.where;
      data.distances.push_back(ref);
    }
    read(a, xa, test.face, test.where);
    read(b, xb, test.face, test.where);
  }
  // Bars that no test uses would add an unknown without data.
  data.bars.erase(std::remove_if(data.bars.begin(), data.bars.end(),
                                 [](const ReferenceBar& bar) { return bar.positions.empty(); }),
                  data.bars.end());
  return data;
}

}  // namespace vlt
