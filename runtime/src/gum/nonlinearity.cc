// gum/nonlinearity.cc — where the first-order GUM is not reliable, without Monte Carlo
// (vlt/gum.h CheckSecondOrder; docs/gum.md "Non-linearity").
//
// JCGM 100 5.1.2 note: when the non-linearity of f is significant, the higher-order terms of the
// Taylor series must be considered; for independent normal inputs the leading one adds
//   u2^2(y) = 1/2 sum_i sum_j (d2f / dx_i dx_j)^2 u_i^2 u_j^2
// to u^2(y). With correlated inputs vlt writes x = x0 + F z, z independent standard normals (F the
// factor the GUM engine already uses: diag(u) with D_b L_b on each block of correlated inputs), so
//   u2^2(y_a) = 1/2 || H_a ||_F^2,   H_a = d2 y_a / dz dz^T = F^T (d2 y_a / dx dx^T) F,
// exact for the quadratic part of f. H_a comes from central differences of the exact generated
// Jacobians: column k of H_a = (J(x0 + F e_k) - J(x0 - F e_k)) F / 2 (a step of one standard
// uncertainty along each independent input). The ratio u2^2 / u^2 per coordinate says how much
// the linearisation leaves out; above the threshold the point is flagged "GUM not reliable".
// Second-order terms decide only where f is close to its quadratic over the inputs' spread
// (issue 31): where the terms over +-1 u exceed a tenth of the threshold they are also computed at
// the point itself, and the two must agree (SecondOrderDecides); a pole or singular direction
// within one u makes them part, and the point is then "not reliable, by how much the second order
// cannot say": Monte Carlo.
#include <algorithm>
#include <cmath>
#include <limits>

#include "gum/internal.h"
#include "parallel/pool.h"
#include "vlt/error.h"
#include "vlt/gum.h"

namespace vlt {

bool SecondOrderDecides(double v_local, double v_span, double var, double threshold) {
  const double larger = std::max(v_local, v_span), smaller = std::min(v_local, v_span);
  if (larger <= 0.01 * threshold * var) return true;  // both negligible (for var = 0: both 0)
  return larger <= 4.0 * smaller;                     // sqrt: within a factor 2
}

void CheckSecondOrder(const MeasurementModel& model, std::span<const PointReadings> points,
                      std::span<PointUncertainty> results, double threshold, int threads) {
  if (points.size() != results.size()) throw std::invalid_argument("CheckSecondOrder: sizes differ");
  const int S = model.num_shared();
  const int n = 3 + S;
  const gum_internal::SharedFactor factor = gum_internal::MakeSharedFactor(model);
  // F of the shared inputs, column by column: F = Apply(I).
  Eigen::MatrixXd f_shared(S, S);
  {
    const Eigen::MatrixXd identity = Eigen::MatrixXd::Identity(S, S);
    factor.Apply(identity.data(), f_shared.data(), S);
  }
  const Eigen::VectorXd s0 = model.shared_estimates();
  // Independent shared inputs (the usual case): F = diag(u), and J_s F is a column scaling, not a
  // 3 x S x S product per Jacobian (2 (3 + S) Jacobians per point).
  const bool f_is_diagonal = f_shared.isDiagonal(0.0);
  const Eigen::VectorXd f_diagonal = f_shared.diagonal();
  parallel_internal::ForEachChunk(
      points.size(), 64, threads, [&](std::size_t, std::size_t begin, std::size_t end) {
        Eigen::Matrix<double, 3, 3> jr;
        Eigen::Matrix<double, 3, Eigen::Dynamic> js(3, S);
        Eigen::Vector3d y;
        Eigen::VectorXd s(S);
        Eigen::MatrixXd jz_plus(3, n), jz_minus(3, n);
        Eigen::VectorXd s_plus(S), s_minus(S);
        std::vector<Eigen::MatrixXd> h(3, Eigen::MatrixXd(n, n)), h_half(3, Eigen::MatrixXd(n, n));
        for (std::size_t i = begin; i < end; ++i) {
          const Eigen::Vector3d r0 = points[i].readings;
          const Eigen::Vector3d u_r = model.reading_uncertainty(r0(0));
          // J_z at x: [dy/dr diag(u_r) | dy/ds F].
          auto jz = [&](const Eigen::Vector3d& r, const Eigen::VectorXd& shared, Eigen::MatrixXd& out) {
            model.EvaluateWithJacobian(r.data(), shared.data(), y.data(), jr.data(), js.data());
            out.leftCols(3) = jr * u_r.asDiagonal();
            if (f_is_diagonal) {
              out.rightCols(S) = js * f_diagonal.asDiagonal();
            } else {
              out.rightCols(S).noalias() = js * f_shared;
            }
          };
          // Column k of each output's Hessian in z from central differences of J_z at +-step
          // standard uncertainties of independent input k.
          auto hessians = [&](double step, std::vector<Eigen::MatrixXd>& out) {
            for (int k = 0; k < n; ++k) {
              Eigen::Vector3d r_plus = r0, r_minus = r0;
              s_plus = s0;
              s_minus = s0;
              if (k < 3) {
                r_plus(k) += step * u_r(k);
                r_minus(k) -= step * u_r(k);
              } else {
                s_plus += step * f_shared.col(k - 3);
                s_minus -= step * f_shared.col(k - 3);
              }
              jz(r_plus, s_plus, jz_plus);
              jz(r_minus, s_minus, jz_minus);
              for (int a = 0; a < 3; ++a)
                out[a].col(k) = (0.5 / step) * (jz_plus.row(a) - jz_minus.row(a)).transpose();
            }
          };
          PointUncertainty& p = results[i];
          // Over +-1 u of each input (2 (3 + S) Jacobians). Where that already shows terms above a
          // tenth of the threshold, also at the point itself (Richardson-extrapolated steps of
          // 10^-3 and 5 10^-4 u: the exact second derivatives to about 10^-12, 4 (3 + S) more), and
          // the two must agree for the second order to decide (SecondOrderDecides).
          hessians(1.0, h);
          Eigen::Vector3d v_span, v_local;
          for (int a = 0; a < 3; ++a) v_span(a) = gum_internal::SecondOrderVariance(h[a]);
          p.second_order_variance = v_span;
          p.second_order_decided = true;
          const Eigen::Vector3d var1 = p.cov_part.diagonal();
          // (A pole at +-1 u itself makes v_span infinite: then the local terms alone, undecided.)
          const bool span_finite = v_span.allFinite();
          if (!span_finite || (v_span.array() > 0.1 * threshold * var1.array()).any()) {
            hessians(1e-3, h);
            hessians(5e-4, h_half);
            for (int a = 0; a < 3; ++a) {
              v_local(a) = gum_internal::SecondOrderVariance((4.0 * h_half[a] - h[a]) / 3.0);
              p.second_order_decided = p.second_order_decided && span_finite &&
                                       SecondOrderDecides(v_local(a), v_span(a), var1(a), threshold);
            }
            // The note's term with exact derivatives; the one over +-1 u only decides.
            p.second_order_variance = v_local;
          }
          for (int a = 0; a < 3; ++a) {
            // A first-order variance of 0 with second-order terms: the ratio has no value (infinity here,
            // null in results.json, empty in the CSV files, "first-order u is 0" in words), never a
            // sentinel number (issue 31).
            p.second_order_ratio(a) = var1(a) > 0.0 ? p.second_order_variance(a) / var1(a)
                                      : p.second_order_variance(a) > 0.0
                                          ? std::numeric_limits<double>::infinity()
                                          : 0.0;
          }
          if (!p.second_order_variance.allFinite()) {
            throw NumericalError("point '" + p.name + "': the second-order check gives a non-finite result");
          }
          p.gum_reliable = p.second_order_decided && p.second_order_ratio.maxCoeff() <= threshold;
        }
      });
}

}  // namespace vlt
