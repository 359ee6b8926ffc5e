// GUM engine, per point (vlt/gum.h, docs/gum.md): U_y = J_r U_r J_r^T + (J_s F)(J_s F)^T
// (JCGM 100 5.1.2 / 5.2.2 in matrix form, JCGM 102 6.2.1.3), expanded uncertainty (JCGM 100
// 6.2.1), coverage ellipsoid (JCGM 102 6.5.2.3), line-of-sight split, budget (JCGM 100 8).
#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "gum/internal.h"
#include "parallel/memory.h"
#include "parallel/pool.h"
#include "vlt/error.h"
#include "vlt/gum.h"
#include "vlt/inverse.h"

namespace vlt {
namespace {

using gum_internal::PointLabel;
using gum_internal::SharedFactor;

// Points per item of the worker pool: ~12 us of work at 10 M points/s, fine enough that two
// threads stay even (with 1024, a 4096-point map was four items and a worker that started late
// left three of them to the other: 1.3x instead of 2x; 256: 1.75x; 128: 1.96x, docs/performance.md
// 5). Per-point results do not depend on it (a multiple of MeasurementModel::kLanes, so the SIMD
// lanes group alike).
constexpr std::size_t kChunk = 128;
const char* const kReadingNames[3] = {"range", "azimuth", "elevation"};
const char* const kReadingUnits[3] = {"m", "rad", "rad"};

// What CheckReadings requires of a reading triple: finite, positive range.
bool ReadingsValid(const Eigen::Vector3d& r) { return r.allFinite() && r(0) > 0.0; }

void CheckReadings(const Eigen::Vector3d& r, const std::string& name, std::size_t index) {
  if (ReadingsValid(r)) return;
  if (!r.allFinite()) {
    throw NumericalError(PointLabel(name, index) + "readings are not finite");
  }
  if (!(r(0) > 0.0)) {
    throw NumericalError(PointLabel(name, index) + "range reading " + std::to_string(r(0)) +
                         " m: the range must be positive (zero range is singular)");
  }
}

// Radial, horizontal and vertical unit vectors (columns) at tracker-frame point x.
Eigen::Matrix3d LineOfSight(const Eigen::Vector3d& x, const std::string& name, std::size_t index) {
  const double horizontal = std::hypot(x(0), x(1));
  if (horizontal < gum_internal::kStandingAxisTolerance) {
    throw NumericalError(PointLabel(name, index) +
                         "on the standing (vertical) axis of the tracker: the azimuth and the "
                         "transverse directions are undefined");
  }
  const double a = std::atan2(x(1), x(0));
  const double e = std::atan2(x(2), horizontal);
  Eigen::Matrix3d d;
  d.col(0) << std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e);
  d.col(1) << -std::sin(a), std::cos(a), 0.0;
  d.col(2) << -std::sin(e) * std::cos(a), -std::sin(e) * std::sin(a), std::cos(e);
  return d;
}

LineOfSightSplit Split(const Eigen::Matrix3d& directions, const Eigen::Matrix3d& cov) {
  LineOfSightSplit s;
  s.directions = directions;
  const Eigen::Vector3d var = (directions.transpose() * cov * directions).diagonal();
  s.u_radial = std::sqrt(std::max(0.0, var(0)));
  s.u_horizontal = std::sqrt(std::max(0.0, var(1)));
  s.u_vertical = std::sqrt(std::max(0.0, var(2)));
  return s;
}

CoverageEllipsoid Ellipsoid(const Eigen::Matrix3d& cov, double k3) {
  CoverageEllipsoid e;
  e.k = k3;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  // Eigen sorts ascending; report descending.
  for (int j = 0; j < 3; ++j) {
    e.semi_axes(j) = k3 * std::sqrt(std::max(0.0, eig.eigenvalues()(2 - j)));
    e.directions.col(j) = eig.eigenvectors().col(2 - j);
  }
  return e;
}

std::string CorrelationHandling(const MeasurementModel& model, const SharedFactor& f) {
  if (f.diagonal) {
    return "all inputs uncorrelated: each row is (c u)^2, the shares of each axis sum to 100 %";
  }
  std::string groups;
  for (const CorrelationGroup& g : model.setup().correlations) {
    groups += (groups.empty() ? "" : ", ") + g.name;
  }
  return "shared inputs correlated (correlation groups: " + groups +
         "): each row is (c u)^2 of one input; the cross terms 2 sum_{i<j} c_i c_j u_i u_j r_ij "
         "are the row 'correlations' (may be negative); the shares of each axis, that row "
         "included, sum to 100 %";
}

// One input's numbers in a point's budget (BudgetRow without its names and units).
struct BudgetTerm {
  double estimate = 0.0, u = 0.0, share_total = 0.0;
  Eigen::Vector3d sensitivity = Eigen::Vector3d::Zero(), contribution = Eigen::Vector3d::Zero(),
                  variance = Eigen::Vector3d::Zero();
};

// Per-thread scratch space, allocated once per chunk, not per point.
struct Scratch {
  explicit Scratch(int num_shared) : js(3 * num_shared), a(3 * num_shared), instrument(3 * num_shared) {}
  std::vector<double> js, a, instrument;
  std::vector<BudgetTerm> terms;  // the budget's, in input order
  std::vector<int> order;         // the budget's rows, largest share first
};

// The factors of a job's shared covariance: all of it, and that of the instrument inputs
// (parameters, environment: the first num_instrument) for the tracker-frame covariance.
struct Factors {
  SharedFactor all;
  int num_instrument = 0;
  // When a correlation links instrument inputs with station or part inputs (pose, thermal), the
  // columns of J F do not split by group: the instrument's own factor (its marginal covariance).
  std::optional<SharedFactor> instrument;
  std::string correlation_handling;
};

void PropagateOne(const MeasurementModel& model, const Factors& factors, const Eigen::VectorXd& x,
                  const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation, double scale,
                  const PointReadings& point, std::size_t index, double k, double k3,
                  const std::vector<BudgetRow>* templates_or_null, Scratch& scratch, PointUncertainty& out) {
  const SharedFactor& factor = factors.all;
  const int num_instrument = factors.num_instrument;
  const int num_shared = model.num_shared();
  CheckReadings(point.readings, point.name, index);
  out.name = point.name;
  out.readings = point.readings;
  Eigen::Matrix3d jr;
  model.EvaluateWithJacobian(point.readings.data(), x.data(), out.part.data(), jr.data(), scratch.js.data());
  // x_t = R^T (y / s - t) at the estimates (saves a second model evaluation).
  out.tracker = rotation.transpose() * (out.part / scale - translation);
  const Eigen::Matrix3d los = LineOfSight(out.tracker, point.name, index);

  const Eigen::Vector3d ur = model.reading_uncertainty(point.readings(0));
  const Eigen::Matrix3d jr_u = jr * ur.asDiagonal();
  factor.Apply(scratch.js.data(), scratch.a.data(), 3);
  Eigen::Map<const Eigen::MatrixXd> a(scratch.a.data(), 3, num_shared);
  // Instrument part (readings, parameters, environment) and station/part part (pose, thermal):
  // without a correlation between the two, the column blocks of J F are independent.
  Eigen::Matrix3d cov_instrument = jr_u * jr_u.transpose();
  if (!factors.instrument) {
    cov_instrument.noalias() += a.leftCols(num_instrument) * a.leftCols(num_instrument).transpose();
    out.cov_part = cov_instrument;
    const int rest = num_shared - num_instrument;
    out.cov_part.noalias() += a.rightCols(rest) * a.rightCols(rest).transpose();
  } else {
    out.cov_part = cov_instrument;
    out.cov_part.noalias() += a * a.transpose();
    Eigen::Map<Eigen::MatrixXd> ai(scratch.instrument.data(), 3, num_shared);
    factors.instrument->Apply(scratch.js.data(), ai.data(), 3);
    cov_instrument.noalias() += ai.leftCols(num_instrument) * ai.leftCols(num_instrument).transpose();
  }
  // y = s (R x_t + t) at the estimates: d x_t = R^T d y / s for the instrument inputs.
  out.cov_tracker = rotation.transpose() * cov_instrument * rotation / (scale * scale);

  if (!out.part.allFinite() || !out.tracker.allFinite() || !out.cov_part.allFinite() ||
      !out.cov_tracker.allFinite()) {
    throw NumericalError(PointLabel(point.name, index) + "the model gives a non-finite result");
  }
  out.u_part = out.cov_part.diagonal().cwiseMax(0.0).cwiseSqrt();
  out.u_tracker = out.cov_tracker.diagonal().cwiseMax(0.0).cwiseSqrt();
  out.k = k;
  out.U_part = k * out.u_part;
  out.los_tracker = Split(los, out.cov_tracker);
  out.los_part = Split(rotation * los, out.cov_part);
  out.ellipsoid = Ellipsoid(out.cov_part, k3);
  out.correlation_handling = factors.correlation_handling;
  // A reused record (PropagatePoints into an array): what CheckSecondOrder fills, as new.
  out.second_order_variance.setZero();
  out.second_order_ratio.setZero();
  out.gum_reliable = true;
  out.second_order_decided = true;
  if (templates_or_null == nullptr) {
    out.budget.clear();
    return;
  }
  const std::vector<BudgetRow>& templates = *templates_or_null;

  // Budget (JCGM 100 8 step 5-6): c_i, c_i u_i per axis, share of u^2(y_axis).
  const Eigen::Vector3d var = out.cov_part.diagonal();
  const double trace = var.sum();
  auto share = [&](const Eigen::Vector3d& v) {
    Eigen::Vector3d s;
    for (int i = 0; i < 3; ++i) s(i) = var(i) > 0.0 ? v(i) / var(i) : 0.0;
    return s;
  };
  // Each input's numbers first, in input order (the sum of squares too), then the rows built once
  // in budget order: the rows hold four strings each, and sorting 24 of them per point was a tenth
  // of a scan's time (issue 33).
  const int num_inputs = 3 + num_shared;
  Eigen::Map<const Eigen::MatrixXd> js(scratch.js.data(), 3, num_shared);
  std::vector<BudgetTerm>& terms = scratch.terms;
  terms.resize(static_cast<std::size_t>(num_inputs));
  Eigen::Vector3d sum_of_squares = Eigen::Vector3d::Zero();
  for (int i = 0; i < num_inputs; ++i) {
    BudgetTerm& term = terms[static_cast<std::size_t>(i)];
    const bool reading = i < 3;
    term.estimate = reading ? point.readings(i) : templates[i].estimate;
    term.u = reading ? ur(i) : templates[i].u;
    term.sensitivity = (reading ? Eigen::Vector3d(jr.col(i)) : Eigen::Vector3d(js.col(i - 3))).array() + 0.0;
    term.contribution = (term.sensitivity * term.u).array() + 0.0;  // + 0.0: no "-0" in reports
    term.variance = term.contribution.cwiseAbs2();
    sum_of_squares += term.variance;
    term.share_total = trace > 0.0 ? term.variance.sum() / trace : 0.0;
  }
  // With correlated inputs, the row of the cross terms: total minus the sum of the squares.
  std::optional<BudgetTerm> correlations;
  if (!factor.diagonal) {
    BudgetTerm& term = correlations.emplace();
    term.variance = var - sum_of_squares;
    for (int i = 0; i < 3; ++i) {
      term.contribution(i) = std::copysign(std::sqrt(std::abs(term.variance(i))), term.variance(i));
    }
    term.share_total = trace > 0.0 ? term.variance.sum() / trace : 0.0;
  }
  // Largest share of trace(U_y) first; equal shares keep the input order (a stable sort).
  std::vector<int>& order = scratch.order;
  order.resize(static_cast<std::size_t>(num_inputs) + (correlations ? 1 : 0));
  std::iota(order.begin(), order.end(), 0);
  auto share_of = [&](int i) { return i < num_inputs ? terms[static_cast<std::size_t>(i)].share_total : correlations->share_total; };
  std::stable_sort(order.begin(), order.end(), [&](int l, int r) { return share_of(l) > share_of(r); });
  out.budget.clear();
  out.budget.reserve(order.size());
  for (const int i : order) {
    if (i == num_inputs) {
      BudgetRow& row = out.budget.emplace_back();
      row.input = "correlations";
      row.group = "correlation";
      row.variance = correlations->variance;
      row.contribution = correlations->contribution;
      row.share = share(row.variance);
      row.share_total = correlations->share_total;
      continue;
    }
    const BudgetTerm& term = terms[static_cast<std::size_t>(i)];
    BudgetRow& row = out.budget.emplace_back(templates[i]);
    row.estimate = term.estimate;
    row.u = term.u;
    row.sensitivity = term.sensitivity;
    row.contribution = term.contribution;
    row.variance = term.variance;
    row.share = share(row.variance);
    row.share_total = term.share_total;
  }
}

// One row per input with everything that does not depend on the point.
std::vector<BudgetRow> BudgetTemplates(const MeasurementModel& model) {
  std::vector<BudgetRow> rows;
  for (int j = 0; j < 3; ++j) {
    BudgetRow row;
    row.input = kReadingNames[j];
    row.group = "reading";
    row.input_unit = kReadingUnits[j];
    row.sensitivity_unit = SensitivityUnit("m", row.input_unit);
    rows.push_back(row);
  }
  for (const UncertainInput& in : model.shared_inputs()) {
    BudgetRow row;
    row.input = in.name;
    row.group = in.group;
    row.input_unit = in.unit;
    row.estimate = in.estimate;
    row.u = in.u;
    row.sensitivity_unit = SensitivityUnit("m", in.unit);
    rows.push_back(row);
  }
  return rows;
}

// var + sum_s (c_s u_s)^2 per axis for the 3 x S column-major sensitivities c (diagonal shared
// covariance), the additions in the order s = 0, 1, ... In its own non-inlined function so that
// the three sums stay in registers (inlined into the field's loop, GCC 12 kept them in a stack
// slot: a store-to-load forward per addition, a third of the field's time).
[[gnu::noinline]] Eigen::Vector3d AddSharedVariances(const Eigen::Vector3d& var, const double* u,
                                                     const double* c, int num_shared) {
  double v0 = var(0), v1 = var(1), v2 = var(2);
  for (int s = 0; s < num_shared; ++s, c += 3) {
    const double us = u[s];
    v0 += (c[0] * us) * (c[0] * us);
    v1 += (c[1] * us) * (c[1] * us);
    v2 += (c[2] * us) * (c[2] * us);
  }
  return {v0, v1, v2};
}

// acc (the six distinct entries 00, 11, 22, 01, 02, 12) += a a^T for one column a = (a0, a1, a2);
// T is double or a SIMD lane array (CovarianceField reduces four points at once).
template <typename T>
inline void AddOuterProduct(const T& a0, const T& a1, const T& a2, T* acc) {
  acc[0] += a0 * a0;
  acc[1] += a1 * a1;
  acc[2] += a2 * a2;
  acc[3] += a0 * a1;
  acc[4] += a0 * a2;
  acc[5] += a1 * a2;
}

// The six distinct entries of sum_k (c_k u_k)(c_k u_k)^T for n columns c_k of 3 rows
// (column-major), added to acc in the order k = 0, 1, ... in six local sums (for the reason
// AddSharedVariances gives); the matrix is symmetric by construction.
[[gnu::noinline]] void AddOuterProducts(const double* c, const double* u, int n, double* acc) {
  double sums[6] = {acc[0], acc[1], acc[2], acc[3], acc[4], acc[5]};
  for (int k = 0; k < n; ++k, c += 3) AddOuterProduct(c[0] * u[k], c[1] * u[k], c[2] * u[k], sums);
  for (int e = 0; e < 6; ++e) acc[e] = sums[e];
}

// Shared inputs of the instrument (parameters, environment) come first in the shared vector.
int NumInstrument(const MeasurementModel& model) {
  if (model.pose_offset() >= 0) return model.pose_offset();
  if (model.thermal_offset() >= 0) return model.thermal_offset();
  return model.num_shared();
}

}  // namespace

std::vector<PointUncertainty> PropagatePoints(const MeasurementModel& model,
                                              std::span<const PointReadings> points,
                                              const GumOptions& options) {
  std::vector<PointUncertainty> results;
  PropagatePoints(model, points, options, results);
  return results;
}

void PropagatePoints(const MeasurementModel& model, std::span<const PointReadings> points,
                     const GumOptions& options, std::vector<PointUncertainty>& results) {
  const double k = NormalCoverageFactor(options.coverage_probability);
  const double k3 = ChiSquareCoverageFactor(options.coverage_probability, 3);
  Factors factors;
  factors.all = gum_internal::MakeSharedFactor(model);
  factors.num_instrument = NumInstrument(model);
  std::vector<bool> instrument(model.num_shared(), false);
  for (int s = 0; s < factors.num_instrument; ++s) instrument[s] = true;
  if (!factors.all.Separates(instrument)) factors.instrument = factors.all.Marginal(instrument);
  factors.correlation_handling = CorrelationHandling(model, factors.all);
  const Eigen::VectorXd x = model.shared_estimates();
  const Eigen::Matrix3d rotation = model.PoseRotation(x.data());
  const Eigen::Vector3d translation = model.PoseTranslation(x.data());
  const double scale = model.ThermalScale(x.data());
  const std::vector<BudgetRow> templates = BudgetTemplates(model);
  const std::vector<BudgetRow>* budget_templates = options.budgets ? &templates : nullptr;
  // A scan's block of records is paged in side by side first (parallel/memory.h).
  parallel_internal::ReserveMapped(results, points.size(), options.threads);
  results.resize(points.size());
  parallel_internal::ForEachChunk(points.size(), kChunk, options.threads,
                         [&](std::size_t, std::size_t begin, std::size_t end) {
                           Scratch scratch(model.num_shared());
                           for (std::size_t i = begin; i < end; ++i) {
                             PropagateOne(model, factors, x, rotation, translation, scale, points[i], i, k,
                                          k3, budget_templates, scratch, results[i]);
                           }
                         });
}

namespace {

// Calls body(i, J_r, u_r, scratch) with scratch.js = J_s for every reading triple, evaluated at the
// shared estimates, in parallel chunks (the lean map paths below; a throw names the index).
template <typename Body>
void ForEachMapJacobian(const MeasurementModel& model, std::span<const Eigen::Vector3d> readings, int threads,
                        Body&& body) {
  const Eigen::VectorXd x = model.shared_estimates();
  const int num_shared = model.num_shared();
  parallel_internal::ForEachChunk(
      readings.size(), kChunk, threads, [&](std::size_t, std::size_t begin, std::size_t end) {
        Scratch scratch(num_shared);
        for (std::size_t i = begin; i < end; ++i) {
          const Eigen::Vector3d& r = readings[i];
          CheckReadings(r, "", i);
          Eigen::Vector3d y;
          Eigen::Matrix3d jr;
          model.EvaluateWithJacobian(r.data(), x.data(), y.data(), jr.data(), scratch.js.data());
          if (!y.allFinite()) throw NumericalError(PointLabel("", i) + "the model gives a non-finite result");
          body(i, jr, model.reading_uncertainty(r(0)), scratch);
        }
      });
}

}  // namespace

std::vector<Eigen::Vector3d> ExpandedUncertaintyField(const MeasurementModel& model,
                                                      std::span<const Eigen::Vector3d> readings,
                                                      double coverage_probability, int threads) {
  const double k = NormalCoverageFactor(coverage_probability);
  const SharedFactor factor = gum_internal::MakeSharedFactor(model);
  const int num_shared = model.num_shared();
  std::vector<Eigen::Vector3d> field(readings.size());
  ForEachMapJacobian(
      model, readings, threads,
      [&](std::size_t i, const Eigen::Matrix3d& jr, const Eigen::Vector3d& ur, Scratch& scratch) {
        // Only the diagonal of J U J^T: sum of squares of the rows of [J_r U_r^1/2, J_s F].
        const Eigen::Vector3d var_readings = (jr * ur.asDiagonal()).rowwise().squaredNorm();
        Eigen::Vector3d var;
        if (factor.diagonal) {
          // Accumulated in three scalars, in the same order as var(i) += ... (bit-identical): with an
          // Eigen::Vector3d accumulator GCC keeps the sums in memory and every addition waits for a
          // store-to-load forward (docs/performance.md 6.1).
          var = AddSharedVariances(var_readings, factor.u.data(), scratch.js.data(), num_shared);
        } else {
          factor.Apply(scratch.js.data(), scratch.a.data(), 3);
          var = var_readings +
                Eigen::Map<const Eigen::MatrixXd>(scratch.a.data(), 3, num_shared).rowwise().squaredNorm();
        }
        field[i] = k * var.cwiseSqrt();
        if (!field[i].allFinite())
          throw NumericalError(PointLabel("", i) + "the model gives a non-finite result");
      });
  return field;
}

std::vector<Eigen::Matrix3d> CovarianceField(const MeasurementModel& model,
                                             std::span<const Eigen::Vector3d> readings, int threads) {
  constexpr int kLanes = MeasurementModel::kLanes;
  using Lanes = Eigen::Array<double, kLanes, 1>;
  const SharedFactor factor = gum_internal::MakeSharedFactor(model);
  const int num_shared = model.num_shared();
  const int num_params = model.setup().model->num_params;
  const double* u = factor.u.data();
  const Eigen::VectorXd x = model.shared_estimates();
  const std::vector<double> ones(num_shared, 1.0);  // unit weights: the columns of J F are scaled
  std::vector<Eigen::Matrix3d> field(readings.size());
  parallel_internal::ForEachChunk(
      readings.size(), kChunk, threads, [&](std::size_t, std::size_t begin, std::size_t end) {
        Scratch scratch(num_shared);
        std::vector<double> js(static_cast<std::size_t>(3 * num_shared * kLanes));
        std::vector<double> jp(static_cast<std::size_t>(3 * num_params * kLanes));
        for (std::size_t i = begin; i < end;) {
          // Up to kLanes points with valid readings; an invalid one is reported by its own index.
          int count = 0;
          while (count < kLanes && i + count < end && ReadingsValid(readings[i + count])) ++count;
          if (count == 0) CheckReadings(readings[i], "", i);  // throws
          Eigen::Matrix<double, 3, kLanes> y;
          Eigen::Matrix<double, 9, kLanes> jr;
          Eigen::Matrix3d m;
          // SIMD lanes at the nominal parameters when the inputs are independent (the parameters'
          // part then separates: sum_p (M c_p u_p)(M c_p u_p)^T = M (sum_p c_p c_p^T u_p^2) M^T).
          const bool lanes =
              factor.diagonal && model.EvaluateNominalLanes(count, readings[i].data(), x.data(), y.data(),
                                                            jr.data(), js.data(), jp.data(), m);
          Lanes params[6];  // the parameters' sum_p c_p c_p^T u_p^2, entries 00 11 22 01 02 12
          for (Lanes& e : params) e.setZero();
          if (lanes) {
            for (int p = 0; p < num_params; ++p) {
              const double* c = jp.data() + kLanes * 3 * p;  // d x_t / d p, quantity r at c + kLanes r
              AddOuterProduct<Lanes>(Eigen::Map<const Lanes>(c) * u[p],
                                     Eigen::Map<const Lanes>(c + kLanes) * u[p],
                                     Eigen::Map<const Lanes>(c + 2 * kLanes) * u[p], params);
            }
          } else {
            for (int l = 0; l < count; ++l) {
              model.EvaluateWithJacobian(readings[i + l].data(), x.data(), y.col(l).data(), jr.col(l).data(),
                                         js.data() + 3 * num_shared * l);
            }
          }
          for (int l = 0; l < count; ++l, ++i) {
            if (!y.col(l).allFinite())
              throw NumericalError(PointLabel("", i) + "the model gives a non-finite result");
            // U_y = J_r U_r J_r^T + (J_s F)(J_s F)^T, column by column of [J_r U_r^1/2 | J_s F].
            const Eigen::Vector3d ur = model.reading_uncertainty(readings[i](0));
            const double* js_l = js.data() + 3 * num_shared * l;
            double acc[6] = {0, 0, 0, 0, 0, 0};
            AddOuterProducts(jr.col(l).data(), ur.data(), 3, acc);
            if (lanes) {
              Eigen::Matrix3d p;
              p << params[0](l), params[3](l), params[4](l), params[3](l), params[1](l), params[5](l),
                  params[4](l), params[5](l), params[2](l);
              const Eigen::Matrix3d mp = m * p;  // M P M^T, its six entries (symmetric)
              acc[0] += mp.row(0).dot(m.row(0));
              acc[1] += mp.row(1).dot(m.row(1));
              acc[2] += mp.row(2).dot(m.row(2));
              acc[3] += mp.row(0).dot(m.row(1));
              acc[4] += mp.row(0).dot(m.row(2));
              acc[5] += mp.row(1).dot(m.row(2));
              AddOuterProducts(js_l + 3 * num_params, u + num_params, num_shared - num_params, acc);
            } else if (factor.diagonal) {
              AddOuterProducts(js_l, u, num_shared, acc);
            } else {
              factor.Apply(js_l, scratch.a.data(), 3);
              AddOuterProducts(scratch.a.data(), ones.data(), num_shared, acc);
            }
            Eigen::Matrix3d& cov = field[i];
            cov << acc[0], acc[3], acc[4], acc[3], acc[1], acc[5], acc[4], acc[5], acc[2];
            if (!cov.allFinite())
              throw NumericalError(PointLabel("", i) + "the model gives a non-finite result");
          }
        }
      });
  return field;
}

namespace {

// The sources of UncertaintySources and, for every column of [J_r U_r^1/2 | J_s F], the source it
// belongs to (-1: an independent input with u = 0, which contributes nothing).
struct SourceColumns {
  std::vector<UncertaintySource> sources;
  std::vector<int> source_of_column;  // 3 + S
};

SourceColumns MakeSourceColumns(const MeasurementModel& model, const SharedFactor& factor) {
  SourceColumns sc;
  const int num_shared = model.num_shared();
  sc.source_of_column.assign(3 + num_shared, -1);
  for (int r = 0; r < 3; ++r) {
    sc.source_of_column[r] = r;
    sc.sources.push_back({kReadingNames[r], "reading"});
  }
  std::vector<int> block_of(num_shared, -1);
  for (std::size_t b = 0; b < factor.blocks.size(); ++b) {
    for (int s : factor.blocks[b].inputs) block_of[s] = static_cast<int>(b);
  }
  const std::vector<std::string> names = SharedInputNames(model.setup());
  std::vector<int> block_source(factor.blocks.size(), -1);
  for (int s = 0; s < num_shared; ++s) {
    const int b = block_of[s];
    if (b < 0) {
      if (!(factor.u(s) > 0.0)) continue;
      sc.source_of_column[3 + s] = static_cast<int>(sc.sources.size());
      sc.sources.push_back({names[s], model.shared_inputs()[s].group});
      continue;
    }
    if (block_source[b] < 0) {
      // Named after the correlation group that holds the block's inputs (an input is in one group).
      std::string name = "correlations";
      for (const CorrelationGroup& g : model.setup().correlations) {
        if (std::find(g.inputs.begin(), g.inputs.end(), names[s]) != g.inputs.end()) name += "." + g.name;
      }
      std::string unique = name;
      for (int n = 2; std::any_of(sc.sources.begin(), sc.sources.end(),
                                  [&](const UncertaintySource& u) { return u.name == unique; });
           ++n) {
        unique = name + "#" + std::to_string(n);
      }
      block_source[b] = static_cast<int>(sc.sources.size());
      sc.sources.push_back({unique, "correlation"});
    }
    sc.source_of_column[3 + s] = block_source[b];
  }
  return sc;
}

}  // namespace

std::vector<UncertaintySource> UncertaintySources(const MeasurementModel& model) {
  return MakeSourceColumns(model, gum_internal::MakeSharedFactor(model)).sources;
}

Eigen::MatrixXd ExpandedUncertaintyBySource(const MeasurementModel& model,
                                            std::span<const Eigen::Vector3d> readings,
                                            double coverage_probability, int threads) {
  const double k = NormalCoverageFactor(coverage_probability);
  const SharedFactor factor = gum_internal::MakeSharedFactor(model);
  const SourceColumns sc = MakeSourceColumns(model, factor);
  const int num_shared = model.num_shared();
  const Eigen::Index num_sources = static_cast<Eigen::Index>(sc.sources.size());
  Eigen::MatrixXd by_source = Eigen::MatrixXd::Zero(num_sources, static_cast<Eigen::Index>(readings.size()));
  ForEachMapJacobian(
      model, readings, threads,
      [&](std::size_t i, const Eigen::Matrix3d& jr, const Eigen::Vector3d& ur, Scratch& scratch) {
        const Eigen::Index col = static_cast<Eigen::Index>(i);
        // trace(U_y) = |U|^2 / k^2 column by column of [J_r U_r^1/2 | J_s F], summed per source.
        for (int c = 0; c < 3; ++c) by_source(c, col) = (jr.col(c) * ur(c)).squaredNorm();
        factor.Apply(scratch.js.data(), scratch.a.data(), 3);
        const Eigen::Map<const Eigen::MatrixXd> a(scratch.a.data(), 3, num_shared);
        for (int s = 0; s < num_shared; ++s) {
          const int source = sc.source_of_column[3 + s];
          if (source >= 0) by_source(source, col) += a.col(s).squaredNorm();
        }
        by_source.col(col) = k * by_source.col(col).cwiseSqrt();
        if (!by_source.col(col).allFinite())
          throw NumericalError(PointLabel("", i) + "the model gives a non-finite result");
      });
  return by_source;
}

Eigen::Vector3d ReadingsForPartPoint(const MeasurementModel& model, const Eigen::Vector3d& part,
                                     bool back_face, const std::string& name) {
  const Eigen::VectorXd x = model.shared_estimates();
  // Undo thermal (y = s x_p) and the pose (x_p = R x_t + t) at the estimates.
  const Eigen::Vector3d x_p = part / model.ThermalScale(x.data());
  const Eigen::Vector3d x_t =
      model.PoseRotation(x.data()).transpose() * (x_p - model.PoseTranslation(x.data()));
  const double horizontal = std::hypot(x_t(0), x_t(1));
  if (!x_t.allFinite() || horizontal < gum_internal::kStandingAxisTolerance) {
    throw NumericalError(PointLabel(name, 0) +
                         "on the standing (vertical) axis of the tracker: no readings can be "
                         "planned (azimuth undefined)");
  }
  // Newton inverse of the tracker model with the error parameters at their estimates
  // (vlt/inverse.h); the air at its estimates gives mu_env = 0, so the range reading equals the
  // model's range.
  std::array<double, 3> readings;
  try {
    readings = InverseReadings(*model.setup().model, x.data(), {x_t(0), x_t(1), x_t(2)},
                               back_face ? Face::kBack : Face::kFront);
  } catch (const NumericalError& e) {
    throw NumericalError(PointLabel(name, 0) + e.what());
  }
  return {readings[0], readings[1], readings[2]};
}

}  // namespace vlt
