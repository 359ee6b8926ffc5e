// calibration/prior.cc — error-parameter priors from a datasheet's MPE statements (vlt/calibration.h
// DerivePrior; docs/profiles.md). The standard tests of a layout are simulated at the tracker's
// compensation; each test with an MPE gives one linear constraint on the parameters' variances;
// the widest independent normal prior that meets them all (maximum entropy) is the answer.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include <Eigen/Eigenvalues>
#include <nlopt.hpp>

#include "vlt/calibration.h"
#include "vlt/error.h"
#include "vlt/gum.h"
#include "vlt/units.h"

#include "base/format.h"

namespace vlt {

const char* PriorStatusName(PriorStatus status) {
  switch (status) {
    case PriorStatus::kFromMpe: return "from_mpe";
    case PriorStatus::kAtBound: return "at_bound";
    case PriorStatus::kNotConstrained: return "not_constrained";
    case PriorStatus::kFixed: return "fixed";
  }
  return "?";
}

namespace {

// Gauss-Legendre nodes and weights on [0, 1] (Newton on P_n from the Chebyshev-like start).
struct Quadrature {
  std::vector<double> node, weight;
  explicit Quadrature(int n) {
    for (int i = 0; i < n; ++i) {
      double x = std::cos(M_PI * (i + 0.75) / (n + 0.5));
      double dp = 0.0;
      for (int it = 0; it < 100; ++it) {
        double p0 = 1.0, p1 = x;
        for (int k = 2; k <= n; ++k) {
          const double p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
          p0 = p1;
          p1 = p2;
        }
        dp = n * (x * p1 - p0) / (x * x - 1.0);
        const double dx = p1 / dp;
        x -= dx;
        if (std::abs(dx) < 1e-16) break;
      }
      if (x < 0.0) continue;  // the integrand is even in t: nodes on [0, 1] with doubled weights
      node.push_back(x);
      weight.push_back(2.0 / ((1.0 - x * x) * dp * dp));
    }
  }
};

// The chi-square cdf with 3 degrees of freedom, closed form.
double ChiSquare3Cdf(double x) {
  if (!(x > 0.0)) return 0.0;
  if (std::isinf(x)) return 1.0;
  return std::erf(std::sqrt(0.5 * x)) - std::sqrt(2.0 * x / M_PI) * std::exp(-0.5 * x);
}

}  // namespace

// x = R w with R^2 ~ chi-square(3) and w uniform on the unit sphere is N(0, I); for N(0, C) in C's
// eigenframe, |x| <= r along w when R^2 <= r^2 / (w^T diag(variances) w). The sphere's area element
// is dt dphi (t = w_z): P = (1 / 4 pi) int_{-1}^{1} int_0^{2 pi} F3(r^2 / q(t, phi)) dphi dt. The
// integrand is even in t and in each coordinate: t in [0, 1] by Gauss-Legendre, phi in [0, pi/2]
// by the trapezoid rule (a whole period of an even, pi-periodic function: exponential convergence).
double ProbabilityWithinSphere(const Eigen::Vector3d& variances, double r) {
  if (!(r > 0.0)) return 0.0;
  static const Quadrature kT(64);
  constexpr int kPhi = 32;
  double sum = 0.0;
  for (std::size_t i = 0; i < kT.node.size(); ++i) {
    const double t = kT.node[i], s2 = 1.0 - t * t;
    double inner = 0.0;
    for (int j = 0; j <= kPhi; ++j) {
      const double phi = 0.5 * M_PI * j / kPhi, c = std::cos(phi), s = std::sin(phi);
      const double q = s2 * (c * c * variances(0) + s * s * variances(1)) + t * t * variances(2);
      const double f = q > 0.0 ? ChiSquare3Cdf(r * r / q) : 1.0;
      inner += (j == 0 || j == kPhi ? 0.5 : 1.0) * f;
    }
    sum += kT.weight[i] * inner / kPhi;
  }
  return std::clamp(sum, 0.0, 1.0);
}

namespace {

// One test as a constraint: variance = noise + sum_k a_k v_k (length, ranging: E's variance;
// two-face: the trace of Delta's covariance), limit: (MPE / c)^2.
struct Constraint {
  std::size_t test = 0;  // index into the simulated tests
  Eigen::VectorXd a;     // per parameter
  double noise = 0.0;
  double mpe = 0.0;
  double c = 0.0;  // z, or for a two-face test the p-quantile factor of its shape
};

// The two-face vector's covariance under variances v: sum_k v_k g_k g_k^T + noise.
Eigen::Matrix3d TwoFaceCovariance(const TestResult& t, const Eigen::VectorXd& v) {
  Eigen::Matrix3d c = t.two_face_noise;
  for (Eigen::Index k = 0; k < v.size(); ++k)
    c += v(k) * t.two_face_sensitivity.col(k) * t.two_face_sensitivity.col(k).transpose();
  return c;
}

Eigen::Vector3d Eigenvalues(const Eigen::Matrix3d& c) {
  return Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(c, Eigen::EigenvaluesOnly).eigenvalues().cwiseMax(0.0);
}

// The p-quantile of |Delta| / sqrt(tr C) for Delta ~ N(0, C): the root of P(f sqrt(tr C)) - p,
// bracketed around `hint` (the factor of the previous round) and found by the Illinois variant of
// regula falsi (superlinear on this smooth, increasing function; the bracket keeps it safe) to
// 1e-13 relative.
double TwoFaceFactor(const Eigen::Matrix3d& c, double p, double hint) {
  const Eigen::Vector3d lambda = Eigenvalues(c);
  const double trace = lambda.sum();
  if (!(trace > 0.0)) return NormalCoverageFactor(p);
  auto g = [&](double f) { return ProbabilityWithinSphere(lambda, f * std::sqrt(trace)) - p; };
  // A hint of 0 (or below the bracket's floor) would never grow: start the bracket at 1e-6.
  double lo = std::max(0.98 * hint, 1e-6), hi = std::max(1.02 * hint, 2e-6);
  double glo = g(lo), ghi = g(hi);
  while (glo >= 0.0 && lo > 1e-6) glo = g(lo *= 0.5);
  while (ghi < 0.0 && hi < 1e3) ghi = g(hi *= 2.0);
  if (glo >= 0.0 || ghi < 0.0)
    throw NumericalError("the p-quantile of a two-face error could not be bracketed (p = " + std::to_string(p) + ")");
  int side = 0;
  for (int it = 0; it < 200 && hi - lo > 1e-13 * hi; ++it) {
    const double f = (lo * ghi - hi * glo) / (ghi - glo);
    const double gf = g(f);
    if (gf < 0.0) {
      lo = f;
      glo = gf;
      if (side == -1) ghi *= 0.5;  // Illinois: halve the stale end's value
      side = -1;
    } else {
      hi = f;
      ghi = gf;
      if (side == 1) glo *= 0.5;
      side = 1;
    }
    if (gf == 0.0) return f;
  }
  return hi;
}

// Maximises sum_k y_k over the free parameters, v_k = bound_k^2 exp(y_k), y_k <= 0, subject to
// sum_k a_tk v_k <= budget_t for every constraint (NLopt SLSQP; the problem is convex, its optimum
// unique). Returns v for the free parameters.
struct SolveOutcome {
  Eigen::VectorXd v;
  int evaluations = 0;
};

// y = log(v / bound^2) >= kLowest: u down to e^-100 (1e-44) of its bound, far below any datasheet.
constexpr double kLowest = -200.0;

SolveOutcome MaximiseEntropy(const Eigen::MatrixXd& a, const Eigen::VectorXd& budget, const Eigen::VectorXd& bound2,
                             const std::string& where) {
  const int n = static_cast<int>(bound2.size());
  // Scaled coefficients: constraint t is sum_k b_tk e^{y_k} <= 1.
  Eigen::MatrixXd b(a.rows(), n);
  for (Eigen::Index t = 0; t < a.rows(); ++t) b.row(t) = a.row(t).cwiseProduct(bound2.transpose()) / budget(t);
  // A feasible start: every parameter takes at most 1/(2n) of any budget.
  std::vector<double> y(n);
  for (int k = 0; k < n; ++k) {
    const double largest = b.col(k).maxCoeff();
    y[k] = largest > 0.0 ? std::clamp(std::log(1.0 / (2.0 * n * largest)), kLowest, 0.0) : 0.0;
  }
  nlopt::opt opt(nlopt::LD_SLSQP, static_cast<unsigned>(n));
  int evaluations = 0;
  auto objective = [](unsigned m, const double* x, double* grad, void* data) {
    ++*static_cast<int*>(data);
    double s = 0.0;
    for (unsigned k = 0; k < m; ++k) {
      s += x[k];
      if (grad) grad[k] = 1.0;
    }
    return s;
  };
  opt.set_max_objective(objective, &evaluations);
  struct Row {
    const Eigen::MatrixXd* b;
    Eigen::Index t;
  };
  std::vector<Row> rows;
  for (Eigen::Index t = 0; t < b.rows(); ++t) rows.push_back({&b, t});
  auto constraint = [](unsigned m, const double* x, double* grad, void* data) {
    const Row& row = *static_cast<Row*>(data);
    double s = 0.0;
    for (unsigned k = 0; k < m; ++k) {
      const double term = (*row.b)(row.t, k) * std::exp(x[k]);
      s += term;
      if (grad) grad[k] = term;
    }
    return s - 1.0;
  };
  for (Row& row : rows) opt.add_inequality_constraint(constraint, &row, 1e-13);
  opt.set_lower_bounds(std::vector<double>(n, kLowest));
  opt.set_upper_bounds(std::vector<double>(n, 0.0));
  opt.set_xtol_abs(1e-11);
  opt.set_ftol_abs(1e-13);
  opt.set_maxeval(20000);
  double best = 0.0;
  try {
    opt.optimize(y, best);
  } catch (const nlopt::roundoff_limited&) {
    // SLSQP at the limit of double precision: y is the best point found (checked below).
  } catch (const std::exception& e) {
    throw NumericalError(where + ": the prior's optimiser (NLopt SLSQP) failed: " + e.what());
  }
  // Exactly feasible: scale every variance down by the largest excess (at most a rounding).
  double worst = 0.0;
  for (Eigen::Index t = 0; t < b.rows(); ++t) {
    double s = 0.0;
    for (int k = 0; k < n; ++k) s += b(t, k) * std::exp(y[k]);
    worst = std::max(worst, s);
  }
  SolveOutcome out;
  out.v.resize(n);
  const double scale = worst > 1.0 ? 1.0 / worst : 1.0;
  for (int k = 0; k < n; ++k) out.v(k) = bound2(k) * std::exp(y[k]) * scale;
  out.evaluations = evaluations;
  return out;
}

// The constraints of the tests with an MPE, from the tests simulated at the compensation. A
// two-face test starts with the factor of its noise's shape, so that "the noise alone breaks the
// statement" is decided exactly.
std::vector<Constraint> MpeConstraints(const std::vector<TestResult>& simulated, const PriorJob& job, double z) {
  const double p = job.settings.conformance_probability;
  std::vector<Constraint> out;
  for (std::size_t i = 0; i < simulated.size(); ++i) {
    const TestResult& t = simulated[i];
    if (t.mpe <= 0.0) continue;
    Constraint c;
    c.test = i;
    c.mpe = t.mpe;
    c.c = z;
    if (t.kind == TestKind::kTwoFace) {
      c.a = t.two_face_sensitivity.colwise().squaredNorm().transpose();
      c.noise = t.two_face_noise.trace();
      c.c = TwoFaceFactor(t.two_face_noise, p, z);
    } else {
      c.a = t.sensitivity.cwiseAbs2();
      c.noise = t.u_noise * t.u_noise;
    }
    if (c.c * c.c * c.noise >= c.mpe * c.mpe) {
      throw InputError(job.file + ": tests.mpe." + TestKindName(t.kind) + ": test '" + t.name +
                       "': the reading noise alone (" +
                       FormatQuantity(c.c * std::sqrt(c.noise), Dimension::kLength, "µm", 3) + " at p = " +
                       base_internal::Sig(p, 6) + ") exceeds its MPE (" + FormatQuantity(c.mpe, Dimension::kLength, "µm", 3) +
                       "): no prior can meet the statement; check [tracker.noise] against the datasheet");
    }
    out.push_back(std::move(c));
  }
  if (out.empty()) throw InputError(job.file + ": tests.mpe: no test of the layout has an MPE to meet");
  return out;
}

// A parameter is one the statements do not constrain when, even at its bound, it would take less
// than this share of every test's budget: no statement can then tell its size (docs/profiles.md).
constexpr double kUnconstrainedShare = 1e-6;

// Every parameter with its generic u, bound and status: fixed (u0 = 0), not constrained, or free
// (from_mpe until the solve says at_bound).
std::vector<PriorParameter> ClassifyParameters(const PriorJob& job, const std::vector<Constraint>& constraints) {
  const ModelInfo& model = *job.tracker.model;
  std::vector<PriorParameter> out;
  for (int k = 0; k < model.num_params; ++k) {
    PriorParameter q;
    q.name = model.params[k].name;
    q.unit = model.params[k].unit;
    q.quantity = model.params[k].quantity;
    q.estimate = job.tracker.params[k].estimate;
    q.u0 = job.tracker.params[k].u;
    q.bound = job.settings.bound * q.u0;
    q.u = q.u0;
    q.status = PriorStatus::kFixed;
    if (q.u0 > 0.0) {
      double largest_share = 0.0;
      for (const Constraint& c : constraints) {
        const double budget = c.mpe * c.mpe / (c.c * c.c) - c.noise;
        largest_share = std::max(largest_share, c.a(k) * q.bound * q.bound / budget);
      }
      q.status = largest_share < kUnconstrainedShare ? PriorStatus::kNotConstrained : PriorStatus::kFromMpe;
    }
    out.push_back(q);
  }
  return out;
}

// The variances of the free parameters for fixed factors c_t (the linear constraints), the others
// at u0^2 (not constrained) or 0 (fixed).
Eigen::VectorXd SolveForFactors(const PriorJob& job, const std::vector<TestResult>& simulated,
                                const std::vector<Constraint>& constraints, const std::vector<PriorParameter>& params,
                                int& evaluations) {
  const int P = static_cast<int>(params.size());
  Eigen::VectorXd v = Eigen::VectorXd::Zero(P);
  std::vector<int> free;
  for (int k = 0; k < P; ++k) {
    if (params[k].status == PriorStatus::kNotConstrained) v(k) = params[k].u0 * params[k].u0;
    if (params[k].status == PriorStatus::kFromMpe) free.push_back(k);
  }
  if (free.empty()) return v;
  Eigen::MatrixXd a(constraints.size(), free.size());
  Eigen::VectorXd budget(constraints.size()), bound2(free.size());
  for (std::size_t i = 0; i < free.size(); ++i) bound2(i) = params[free[i]].bound * params[free[i]].bound;
  for (std::size_t t = 0; t < constraints.size(); ++t) {
    const Constraint& c = constraints[t];
    budget(t) = c.mpe * c.mpe / (c.c * c.c) - c.noise - c.a.dot(v);  // v: the parameters kept at u0
    if (!(budget(t) > 0.0)) {
      const TestResult& r = simulated[c.test];
      throw InputError(job.file + ": tests.mpe." + TestKindName(r.kind) + ": test '" + r.name +
                       "': the reading noise and the parameters the statements do not constrain use its whole MPE");
    }
    for (std::size_t i = 0; i < free.size(); ++i) a(t, i) = c.a(free[i]);
  }
  const SolveOutcome solved = MaximiseEntropy(a, budget, bound2, job.file + ": tests.mpe");
  evaluations += solved.evaluations;
  for (std::size_t i = 0; i < free.size(); ++i) v(free[i]) = solved.v(i);
  return v;
}

double Conformance(const TestResult& t, const Constraint& c, const Eigen::VectorXd& v) {
  if (t.kind == TestKind::kTwoFace) return ProbabilityWithinSphere(Eigenvalues(TwoFaceCovariance(t, v)), c.mpe);
  const double u = std::sqrt(c.noise + c.a.dot(v));
  return u > 0.0 ? std::erf(c.mpe / (u * std::sqrt(2.0))) : 1.0;
}

// The fixed point of the two-face factors: solve with the factors, recompute each from its test's
// covariance at the solution, until no factor moves by 1e-9 (relative). Then, should rounding leave
// a test a hair below p, the free variances are scaled down (bisection) until every test meets it.
Eigen::VectorXd SolveWithTwoFaceFactors(const PriorJob& job, const std::vector<TestResult>& simulated,
                                        std::vector<Constraint>& constraints,
                                        const std::vector<PriorParameter>& params, int& evaluations) {
  const double p = job.settings.conformance_probability;
  Eigen::VectorXd v;
  for (int round = 0;; ++round) {
    v = SolveForFactors(job, simulated, constraints, params, evaluations);
    double moved = 0.0;
    for (Constraint& c : constraints) {
      if (simulated[c.test].kind != TestKind::kTwoFace) continue;
      const double factor = TwoFaceFactor(TwoFaceCovariance(simulated[c.test], v), p, c.c);
      moved = std::max(moved, std::abs(factor - c.c) / c.c);
      c.c = factor;
    }
    if (moved < 1e-9) break;
    if (round == 200)
      throw NumericalError(job.file + ": tests.mpe.two_face: the two-face factors did not settle in 200 rounds");
  }
  auto meets = [&](const Eigen::VectorXd& w) {
    for (const Constraint& c : constraints)
      if (Conformance(simulated[c.test], c, w) < p) return false;
    return true;
  };
  if (meets(v)) return v;
  Eigen::VectorXd free = Eigen::VectorXd::Zero(v.size());
  for (Eigen::Index k = 0; k < v.size(); ++k)
    if (params[k].status == PriorStatus::kFromMpe) free(k) = 1.0;
  auto scaled = [&](double s) { return Eigen::VectorXd(v.cwiseProduct(Eigen::VectorXd::Ones(v.size()) - (1.0 - s) * free)); };
  double lo = 0.5, hi = 1.0;  // meets at lo, not at hi
  if (!meets(scaled(lo))) throw NumericalError(job.file + ": tests.mpe: the prior could not be brought within every MPE");
  for (int it = 0; it < 60 && hi - lo > 1e-15; ++it) {
    const double mid = 0.5 * (lo + hi);
    (meets(scaled(mid)) ? lo : hi) = mid;
  }
  return scaled(lo);
}

}  // namespace

PriorResult DerivePrior(const PriorJob& job) {
  const double p = job.settings.conformance_probability;
  PriorResult result;
  result.model = job.tracker.model->name;
  result.z = NormalCoverageFactor(p);
  // 1. The tests at the compensation (the prior's mean): sensitivities and the noise's part.
  TestSettings settings = job.mpe;
  settings.coverage_probability = p;
  const std::vector<TestResult> simulated = SimulateTests(job.tracker, job.layout, settings);
  std::vector<Constraint> constraints = MpeConstraints(simulated, job, result.z);
  // 2. Which parameters the statements can size.
  result.parameters = ClassifyParameters(job, constraints);
  // 3. The maximum-entropy variances, the two-face factors at their fixed point.
  const Eigen::VectorXd v = SolveWithTwoFaceFactors(job, simulated, constraints, result.parameters, result.evaluations);
  // 4. The parameters' u and status, the tests' budgets, shares and conformance.
  for (std::size_t k = 0; k < result.parameters.size(); ++k) {
    PriorParameter& q = result.parameters[k];
    if (q.status != PriorStatus::kFromMpe) continue;
    q.u = std::sqrt(v(static_cast<Eigen::Index>(k)));
    if (q.u >= q.bound * (1.0 - 1e-6)) q.status = PriorStatus::kAtBound;
  }
  for (const Constraint& c : constraints) {
    const TestResult& t = simulated[c.test];
    PriorTest r;
    r.name = t.name;
    r.kind = t.kind;
    r.range_max = t.range_max;
    r.mpe = c.mpe;
    r.u_noise = std::sqrt(c.noise);
    const double params = c.a.dot(v);
    r.u_parameters = std::sqrt(params);
    r.u = std::sqrt(c.noise + params);
    r.share = c.noise + params > 0.0 ? Eigen::VectorXd(c.a.cwiseProduct(v) / (c.noise + params))
                                     : Eigen::VectorXd::Zero(c.a.size());
    r.conformance = Conformance(t, c, v);
    r.binding = c.c * r.u >= c.mpe * (1.0 - 1e-6);
    result.tests.push_back(std::move(r));
  }
  return result;
}

}  // namespace vlt
