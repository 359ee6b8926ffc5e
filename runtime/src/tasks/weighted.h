// tasks/weighted.h — fits weighted by the points' covariance (generalised least squares; internal
// to tasks/, docs/tasks.md "Fits weighted by the points' covariance").
//
// A fit's residuals r (one to three rows per point: the orthogonal distance of a plane point, the
// two perpendicular offsets of a line point, the three components of an aligned point) have, to
// first order, the covariance V_d = D V D^T with V the points' covariance and D = dr/dx (Forbes,
// Metrologia 43 (2006) S282: the generalised Gauss-Markov fit). The weighted fit minimises
//   F(theta) = r(theta, x)^T W r(theta, x),   W = V_d^-1,
// with W computed once, at the ordinary fit to the estimates, and held fixed (FitWeights): the
// estimator is then one function of the points, which the GUM engine differentiates and every Monte
// Carlo trial evaluates.
//
// A problem gives the residuals of point i in a chart theta = delta around its current fit
// (delta = 0 is the fit; Retract moves the fit by a step). Gauss-Newton steps with backtracking
// minimise F; the Jacobian follows from the implicit function theorem on g = J^T W r = 0:
//   dtheta/dx = -H^-1 dg/dx,   H = J^T W J + sum_i d2(lambda_i . r_i)/dtheta2,
//   dg/dx_i = (W J)_i^T D_i + d2(lambda_i . r_i)/dtheta dx_i,   lambda = W r,
// the FULL Hessian (residual terms included, by nested forward-mode automatic differentiation at
// delta = 0), so it is exact also where the residuals are not small.
#pragma once

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Dense>
#include <unsupported/Eigen/AutoDiff>

#include "tasks/fit_support.h"
#include "vlt/error.h"
#include "vlt/fits.h"

namespace vlt {

// W = V_d^-1 over the active residual rows, point by point (rows of point i: offsets()[i] ..
// offsets()[i + 1]). Woodbury's identity on V_d = Delta + M M^T (Delta: each point's own block,
// M = D shared) when every block is positive definite: O(rows r) per product; else (a dense point
// covariance, or points without their own noise) the Cholesky factor of V_d, up to kDenseRows rows.
class FitWeights {
 public:
  static constexpr long kDenseRows = 3000;
  // d[i]: the m_i x 3 derivative of point i's active rows with respect to the point; `reference`:
  // the vector that fixes the basis of residual rows that need one (a line's two offsets across its
  // direction e: u = normalise(reference - e (e . reference)), v = e x u), zero where none does;
  // every fit with these weights takes its rows in that basis. Throws NumericalError "<where>:
  // <kind>: ..." when V_d is singular or too large to factor densely.
  FitWeights(const PointCovariance& v, const std::vector<Eigen::MatrixXd>& d,
             const Eigen::Vector3d& reference, TaskKind kind, std::string_view where);
  // W a for a rows() x c matrix a.
  Eigen::MatrixXd Apply(const Eigen::MatrixXd& a) const;
  long rows() const { return offsets_.back(); }
  const std::vector<long>& offsets() const { return offsets_; }
  bool dense() const { return dense_; }
  const Eigen::Vector3d& reference() const { return reference_; }

 private:
  std::vector<long> offsets_;
  Eigen::Vector3d reference_;
  bool dense_ = false;
  Eigen::LLT<Eigen::MatrixXd> dense_factor_;
  std::vector<Eigen::MatrixXd> block_inverse_;  // Delta_i^-1
  Eigen::MatrixXd delta_inverse_m_;             // Delta^-1 M, rows x r
  Eigen::LLT<Eigen::MatrixXd> capacitance_;     // I + M^T Delta^-1 M
};

namespace tasks_internal {

// The covariance of the first k of its points.
PointCovariance LeadingPoints(const PointCovariance& v, long k);

// What a weighted fit found: its active residual rows (point by point), dtheta/dx (P x 3N, the
// chart at the solution; empty unless asked), the weights, r^T W r and the iterations.
struct WeightedSolution {
  Eigen::VectorXd residuals;
  std::vector<long> offsets;  // rows of point i: offsets[i] .. offsets[i + 1]
  Eigen::MatrixXd dtheta_dx;
  std::shared_ptr<const FitWeights> weights;
  double chi2 = 0.0;
  int iterations = 0;
  // d r / d theta (rows x P) and d r_i / d x_i (rows x 3, point i's rows) at the solution.
  Eigen::MatrixXd dr_dtheta;
  Eigen::MatrixXd dr_dx;
};

namespace weighted_detail {

template <int K>
using Dual = Eigen::AutoDiffScalar<Eigen::Matrix<double, K, 1>>;
template <int K>
using Dual2 = Eigen::AutoDiffScalar<Eigen::Matrix<Dual<K>, K, 1>>;

// Values and first derivatives of point i's M rows at delta = 0.
template <class Problem>
void Linearise(const Problem& problem, const Eigen::Vector3d& x, long i,
               Eigen::Matrix<double, Problem::kRows, 1>& r,
               Eigen::Matrix<double, Problem::kRows, Problem::kParams + 3>& j) {
  constexpr int P = Problem::kParams, K = P + 3;
  Dual<K> delta[P], xi[3], out[Problem::kRows];
  for (int a = 0; a < P; ++a) delta[a] = Dual<K>(0.0, K, a);
  for (int c = 0; c < 3; ++c) xi[c] = Dual<K>(x(c), K, P + c);
  problem.Residual(delta, i, xi, out);
  for (int m = 0; m < Problem::kRows; ++m) {
    r(m) = out[m].value();
    j.row(m) = out[m].derivatives().transpose();
  }
}

// The Hessian of lambda . r_i over (delta, x_i) at delta = 0 (nested forward mode).
template <class Problem>
Eigen::Matrix<double, Problem::kParams + 3, Problem::kParams + 3> Curvature(
    const Problem& problem, const Eigen::Vector3d& x, long i,
    const Eigen::Matrix<double, Problem::kRows, 1>& lambda) {
  constexpr int P = Problem::kParams, K = P + 3;
  using Outer = Dual2<K>;
  using InnerVector = Eigen::Matrix<Dual<K>, K, 1>;
  Outer variables[K];
  for (int a = 0; a < K; ++a) {
    const double value = a < P ? 0.0 : x(a - P);
    variables[a].value() = Dual<K>(value, K, a);
    variables[a].derivatives() = InnerVector::Constant(Dual<K>(0.0, Eigen::Matrix<double, K, 1>::Zero()));
    variables[a].derivatives()(a) = Dual<K>(1.0, Eigen::Matrix<double, K, 1>::Zero());
  }
  Outer out[Problem::kRows];
  problem.Residual(variables, i, variables + P, out);
  Eigen::Matrix<double, K, K> h = Eigen::Matrix<double, K, K>::Zero();
  for (int m = 0; m < Problem::kRows; ++m) {
    if (lambda(m) == 0.0) continue;
    for (int a = 0; a < K; ++a) h.row(a) += lambda(m) * out[m].derivatives()(a).derivatives().transpose();
  }
  return 0.5 * (h + h.transpose());
}

// The active rows of every point at the problem's current fit: residuals, d/dtheta, d/dx_i.
template <class Problem>
struct Linearisation {
  Eigen::VectorXd r;
  Eigen::MatrixXd j_theta;  // rows x P
  Eigen::MatrixXd j_x;      // rows x 3 (point i's rows)

  void Evaluate(const Problem& problem, const Eigen::Ref<const Eigen::Matrix3Xd>& x,
                const std::vector<long>& offsets) {
    constexpr int P = Problem::kParams, M = Problem::kRows;
    const long rows = offsets.back();
    r.resize(rows);
    j_theta.resize(rows, P);
    j_x.resize(rows, 3);
    Eigen::Matrix<double, M, 1> ri;
    Eigen::Matrix<double, M, P + 3> ji;
    for (long i = 0; i < x.cols(); ++i) {
      Linearise(problem, x.col(i), i, ri, ji);
      long row = offsets[static_cast<std::size_t>(i)];
      for (int m = 0; m < M; ++m) {
        if (!problem.Active(i, m)) continue;
        r(row) = ri(m);
        j_theta.row(row) = ji.row(m).template head<P>();
        j_x.row(row) = ji.row(m).template tail<3>();
        ++row;
      }
    }
  }
};

}  // namespace weighted_detail

// Minimises r^T W r for `problem` from its current fit (the ordinary one); on return the problem
// holds the weighted fit. Weights: options.weights, else made from options.covariance here.
template <class Problem>
WeightedSolution SolveWeighted(Problem& problem, const Eigen::Ref<const Eigen::Matrix3Xd>& x,
                               const FitOptions& options, TaskKind kind, std::string_view where) {
  constexpr int P = Problem::kParams, M = Problem::kRows;
  const long n = x.cols();
  WeightedSolution s;
  s.offsets.assign(static_cast<std::size_t>(n) + 1, 0);
  for (long i = 0; i < n; ++i) {
    int active = 0;
    for (int m = 0; m < M; ++m) active += problem.Active(i, m) ? 1 : 0;
    s.offsets[static_cast<std::size_t>(i) + 1] = s.offsets[static_cast<std::size_t>(i)] + active;
  }
  const long rows = s.offsets.back();
  if (rows < P) Fail(where, kind, "a weighted fit needs at least as many residuals as parameters");

  // A problem whose rows need a basis (a line) takes the one its weights were made in.
  constexpr bool kHasReference = requires { problem.reference; };
  if constexpr (kHasReference) {
    if (options.weights != nullptr) problem.reference = options.weights->reference();
  }
  weighted_detail::Linearisation<Problem> lin;
  lin.Evaluate(problem, x, s.offsets);
  s.weights = options.weights;
  if (s.weights == nullptr) {
    if (options.covariance == nullptr) throw std::logic_error("SolveWeighted: no covariance and no weights");
    std::vector<Eigen::MatrixXd> d(static_cast<std::size_t>(n));
    for (long i = 0; i < n; ++i) {
      const long b = s.offsets[static_cast<std::size_t>(i)], e = s.offsets[static_cast<std::size_t>(i) + 1];
      d[static_cast<std::size_t>(i)] = lin.j_x.middleRows(b, e - b);
    }
    Eigen::Vector3d reference = Eigen::Vector3d::Zero();
    if constexpr (kHasReference) reference = problem.reference;
    s.weights = std::make_shared<const FitWeights>(*options.covariance, d, reference, kind, where);
  } else if (s.weights->offsets() != s.offsets) {
    throw InputError(std::string(where) + ": " + std::string(TaskKindName(kind)) +
                     ": the weights were made for another set of points");
  }
  const FitWeights& w = *s.weights;

  // Gauss-Newton on F = r^T W r; a step is halved until F falls. Converged when the predicted
  // decrease g^T H^-1 g is below 1e-20 max(F, rows) (steps of 1e-10 standard uncertainties: F is
  // in their units), or when no step lowers F while the predicted decrease is below 1e-8 max(F,
  // rows) (the minimum to rounding); a stall above that is a failure, not a result.
  Eigen::LDLT<Eigen::Matrix<double, P, P>> normal;
  // W J and W r of the current fit; every exit from the loop leaves them at the solution, where the
  // Jacobian below uses them again.
  Eigen::MatrixXd wj;
  Eigen::VectorXd wr;
  for (;; ++s.iterations) {
    if (s.iterations >= 100) Fail(where, kind, "the weighted fit did not converge in 100 steps");
    wj = w.Apply(lin.j_theta);
    wr = w.Apply(lin.r);
    const double f = lin.r.dot(wr);
    const Eigen::Matrix<double, P, P> h = lin.j_theta.transpose() * wj;
    const Eigen::Matrix<double, P, 1> g = lin.j_theta.transpose() * wr;
    normal.compute(h);
    if (normal.info() != Eigen::Success ||
        !(normal.vectorD().minCoeff() > 1e-14 * normal.vectorD().maxCoeff())) {
      Fail(where, kind, "the weighted fit's normal equations are singular (the points do not determine it)");
    }
    const Eigen::Matrix<double, P, 1> step = -normal.solve(g);
    const double decrease = -g.dot(step);
    if (!(decrease > 1e-20 * std::max(f, static_cast<double>(rows)))) {
      s.chi2 = f;
      break;
    }
    bool accepted = false;
    for (double t = 1.0; t > 1e-9; t *= 0.5) {
      Problem trial = problem;
      trial.Retract(t * step);
      weighted_detail::Linearisation<Problem> next;
      next.Evaluate(trial, x, s.offsets);
      if (!next.r.allFinite()) continue;
      const Eigen::VectorXd w_next = w.Apply(next.r);
      const double f_next = next.r.dot(w_next);
      if (f_next < f) {
        problem = trial;
        lin = std::move(next);
        accepted = true;
        break;
      }
    }
    if (!accepted) {
      if (!(decrease <= 1e-8 * std::max(f, static_cast<double>(rows))))
        Fail(where, kind, "the weighted fit stalled short of its minimum (no step lowers r^T W r)");
      s.chi2 = f;
      break;
    }
  }
  s.residuals = lin.r;
  s.dr_dtheta = lin.j_theta;
  s.dr_dx = lin.j_x;
  if (!options.jacobian) return s;

  // Implicit function theorem with the full Hessian (header comment); lambda = W r.
  const Eigen::VectorXd& lambda = wr;
  Eigen::Matrix<double, P, P> h = lin.j_theta.transpose() * wj;
  Eigen::MatrixXd dg(P, 3 * n);
  for (long i = 0; i < n; ++i) {
    const long b = s.offsets[static_cast<std::size_t>(i)], e = s.offsets[static_cast<std::size_t>(i) + 1];
    Eigen::Matrix<double, M, 1> lambda_i = Eigen::Matrix<double, M, 1>::Zero();
    long row = b;
    for (int m = 0; m < M; ++m) {
      if (problem.Active(i, m)) lambda_i(m) = lambda(row++);
    }
    const auto c = weighted_detail::Curvature(problem, x.col(i), i, lambda_i);
    h += c.template topLeftCorner<P, P>();
    dg.middleCols<3>(3 * i) = wj.middleRows(b, e - b).transpose() * lin.j_x.middleRows(b, e - b) +
                              c.template topRightCorner<P, 3>();
  }
  const Eigen::LDLT<Eigen::Matrix<double, P, P>> full(h);
  if (full.info() != Eigen::Success || !(full.vectorD().minCoeff() > 0.0)) {
    Fail(where, kind, "the weighted fit is not a minimum its points determine (singular Hessian)");
  }
  s.dtheta_dx = -full.solve(dg);
  return s;
}

}  // namespace tasks_internal
}  // namespace vlt
