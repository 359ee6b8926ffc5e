// gum/nonlinearity.cc — where the first-order GUM is not reliable, without Monte Carlo
// (vlt/gum.h CheckSecondOrder; docs/gum.md "Non-linearity").
//
// JCGM 100 5.1.2 note: when the non-linearity of f is significant, the higher-order terms of the
// Taylor series must be considered; for independent normal inputs the leading one adds
//   u2^2(y) = 1/2 sum_i sum_j (d2f / dx_i dx_j)^2 u_i^2 u_j^2
// to u^2(y). With correlated inputs vlt writes x = x0 + F z, z independent standard normals (F the
// factor the GUM engine already uses: diag(u) with D_b L_b on each block of correlated inputs), so
//   u2^2(y_a) = 1/2 || H_a ||_F^2,   H_a = d2 y_a / dz dz^T = F^T (d2 y_a / dx dx^T) F,
// exact for the quadratic part of f. At the point itself H_a is exact: the tracker model's second
// derivatives come from vlt-gen (MeasurementModel::TrackerHessians); the columns of the
// environment, pose and thermal inputs, whose stages the runtime computes, are central differences
// of the exact Jacobians, Richardson-extrapolated (steps of 10^-3 and 5 10^-4 u: the exact
// derivatives to about 10^-12), as is every column of a model without a Hessians kernel. The ratio
// u2^2 / u^2 per coordinate says how much the linearisation leaves out; above the threshold the
// point is flagged "GUM not reliable".
// Second-order terms decide only where f is close to its quadratic over the inputs' spread
// (issue 31): H_a is also formed over +-1 u of each input, column k = (J_z(x0 + F e_k) -
// J_z(x0 - F e_k)) / 2; where those terms exceed a tenth of the threshold the two must agree
// (SecondOrderDecides); a pole or singular direction within one u makes them part, and the point
// is then "not reliable, by how much the second order cannot say": Monte Carlo.
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "gum/internal.h"
#include "parallel/pool.h"
#include "vlt/error.h"
#include "vlt/gum.h"

namespace vlt {

namespace {

// The second-order check of one point: buffers for one thread, and its two Hessians in z.
class PointCurvature {
 public:
  PointCurvature(const MeasurementModel& model, const Eigen::MatrixXd& f_shared)
      : model_(model),
        f_shared_(f_shared),
        s_(model.num_shared()),
        n_(3 + s_),
        f_is_diagonal_(f_shared.isDiagonal(0.0)),
        f_diagonal_(f_shared.diagonal()),
        s0_(model.shared_estimates()),
        js_(3, s_),
        js_minus_(3, s_),
        jz_plus_(3, n_),
        jz_minus_(3, n_),
        jx_plus_(3, n_),
        jx_minus_(3, n_),
        s_plus_(s_),
        s_minus_(s_),
        hx_(3, Eigen::MatrixXd(n_, n_)),
        tracker_(3 * static_cast<std::size_t>(3 + model.setup().model->num_params) *
                 (3 + model.setup().model->num_params)) {}

  // Column k of each output's Hessian in z from central differences of J_z at +-step standard
  // uncertainties of independent input k (step 1: the terms over the inputs' spread).
  void SpanHessians(const Eigen::Vector3d& r0, const Eigen::Vector3d& u_r, std::vector<Eigen::MatrixXd>& h) {
    for (int k = 0; k < n_; ++k) {
      Eigen::Vector3d r_plus = r0, r_minus = r0;
      s_plus_ = s0_;
      s_minus_ = s0_;
      if (k < 3) {
        r_plus(k) += u_r(k);
        r_minus(k) -= u_r(k);
      } else {
        s_plus_ += f_shared_.col(k - 3);
        s_minus_ -= f_shared_.col(k - 3);
      }
      if (f_is_diagonal_) {
        SpanColumnDiagonal(r_plus, r_minus, u_r, k, h);
        continue;
      }
      JacobianInZ(r_plus, s_plus_, u_r, jz_plus_);
      JacobianInZ(r_minus, s_minus_, u_r, jz_minus_);
      for (int a = 0; a < 3; ++a) h[a].col(k) = 0.5 * (jz_plus_.row(a) - jz_minus_.row(a)).transpose();
    }
  }

  // The Hessians in z at the point: H_z = F^T H_x F, H_x exact where the model has a Hessians
  // kernel (the readings' and error parameters' block), the other columns differenced.
  void LocalHessians(const Eigen::Vector3d& r0, const Eigen::Vector3d& u_r, std::vector<Eigen::MatrixXd>& h) {
    const int exact = model_.TrackerHessians(r0.data(), s0_.data(), tracker_.data())
                          ? 3 + model_.setup().model->num_params
                          : 0;
    const std::size_t stride = static_cast<std::size_t>(exact) * exact;
    for (int a = 0; a < 3; ++a) {
      hx_[a].setZero();
      if (exact > 0)
        hx_[a].topLeftCorner(exact, exact) =
            Eigen::Map<const Eigen::MatrixXd>(tracker_.data() + a * stride, exact, exact);
    }
    for (int k = exact; k < n_; ++k) DifferencedColumn(r0, u_r, k);
    // Symmetric: a differenced column k gives row k too (the exact block has no rows beyond it);
    // two differenced entries are averaged.
    for (int a = 0; a < 3; ++a) {
      for (int k = exact; k < n_; ++k) {
        for (int l = 0; l < n_; ++l) {
          const double v = l < exact ? hx_[a](l, k) : 0.5 * (hx_[a](l, k) + hx_[a](k, l));
          hx_[a](l, k) = hx_[a](k, l) = v;
        }
      }
      ToZ(u_r, hx_[a], h[a]);
    }
  }

 private:
  // J_z at x: [dy/dr diag(u_r) | dy/ds F].
  void JacobianInZ(const Eigen::Vector3d& r, const Eigen::VectorXd& shared, const Eigen::Vector3d& u_r,
                   Eigen::MatrixXd& out) {
    model_.EvaluateWithJacobian(r.data(), shared.data(), y_.data(), jr_.data(), js_.data());
    out.leftCols(3) = jr_ * u_r.asDiagonal();
    if (f_is_diagonal_) {
      out.rightCols(s_) = js_ * f_diagonal_.asDiagonal();
    } else {
      out.rightCols(s_).noalias() = js_ * f_shared_;
    }
  }

  // Column k of the Hessians over +-1 u with F diagonal (every job without correlated inputs: a
  // scan's 10^6 points): J_z = J_x diag(d), d = (u_r, F_ii), so column k of H_a is
  // 0.5 (J+(a, i) d_i - J-(a, i) d_i) over i, read from the kernel's column-major Jacobians. The
  // same operations, in the same order, as the general path's Eigen expressions (the same bits),
  // without its 3 x n temporaries.
  void SpanColumnDiagonal(const Eigen::Vector3d& r_plus, const Eigen::Vector3d& r_minus, const Eigen::Vector3d& u_r,
                          int k, std::vector<Eigen::MatrixXd>& h) {
    model_.EvaluateWithJacobian(r_plus.data(), s_plus_.data(), y_.data(), jr_.data(), js_.data());
    model_.EvaluateWithJacobian(r_minus.data(), s_minus_.data(), y_.data(), jr_minus_.data(),
                                js_minus_.data());
    for (int a = 0; a < 3; ++a) {
      double* column = h[a].col(k).data();
      for (int i = 0; i < 3; ++i) column[i] = 0.5 * (jr_(a, i) * u_r(i) - jr_minus_(a, i) * u_r(i));
      for (int s = 0; s < s_; ++s) {
        column[3 + s] = 0.5 * (js_(a, s) * f_diagonal_(s) - js_minus_(a, s) * f_diagonal_(s));
      }
    }
  }

  // J_x at x: [dy/dr | dy/ds].
  void JacobianInX(const Eigen::Vector3d& r, const Eigen::VectorXd& shared, Eigen::MatrixXd& out) {
    model_.EvaluateWithJacobian(r.data(), shared.data(), y_.data(), jr_.data(), js_.data());
    out.leftCols(3) = jr_;
    out.rightCols(s_) = js_;
  }

  // (J_x(x + h e_k) - J_x(x - h e_k)) / 2h for h = step u_k.
  Eigen::MatrixXd CentralInX(const Eigen::Vector3d& r0, double h, int k) {
    Eigen::Vector3d r_plus = r0, r_minus = r0;
    s_plus_ = s0_;
    s_minus_ = s0_;
    if (k < 3) {
      r_plus(k) += h;
      r_minus(k) -= h;
    } else {
      s_plus_(k - 3) += h;
      s_minus_(k - 3) -= h;
    }
    JacobianInX(r_plus, s_plus_, jx_plus_);
    JacobianInX(r_minus, s_minus_, jx_minus_);
    return (jx_plus_ - jx_minus_) / (2.0 * h);
  }

  // Column k of every output's H_x: Richardson-extrapolated central differences of the exact
  // Jacobians, (4 D(h/2) - D(h)) / 3 with h = 10^-3 u_k. An input with u = 0 has a zero row in F:
  // its column does not enter H_z.
  void DifferencedColumn(const Eigen::Vector3d& r0, const Eigen::Vector3d& u_r, int k) {
    const double u = k < 3 ? u_r(k) : model_.shared_inputs()[k - 3].u;
    if (!(u > 0.0)) return;
    const Eigen::MatrixXd d = (4.0 * CentralInX(r0, 5e-4 * u, k) - CentralInX(r0, 1e-3 * u, k)) / 3.0;
    for (int a = 0; a < 3; ++a) hx_[a].col(k) = d.row(a).transpose();
  }

  // H_z = F^T H_x F, F = diag(u_r) (+) F_shared. An input that does not vary (a zero row of F) has
  // no second-order term: its row and column of H_x are left out first, so that a second
  // derivative infinite at its estimate is not 0 inf.
  void ToZ(const Eigen::Vector3d& u_r, Eigen::MatrixXd& hx, Eigen::MatrixXd& hz) const {
    for (int k = 0; k < n_; ++k) {
      if (k < 3 ? u_r(k) == 0.0 : f_shared_.row(k - 3).isZero(0.0)) {
        hx.row(k).setZero();
        hx.col(k).setZero();
      }
    }
    Eigen::VectorXd d(n_);
    if (f_is_diagonal_) {
      d << u_r, f_diagonal_;
      hz = d.asDiagonal() * hx * d.asDiagonal();
      return;
    }
    Eigen::MatrixXd f = Eigen::MatrixXd::Zero(n_, n_);
    f.topLeftCorner(3, 3) = u_r.asDiagonal();
    f.bottomRightCorner(s_, s_) = f_shared_;
    hz.noalias() = f.transpose() * hx * f;
  }

  const MeasurementModel& model_;
  const Eigen::MatrixXd& f_shared_;
  const int s_, n_;
  const bool f_is_diagonal_;
  const Eigen::VectorXd f_diagonal_;
  const Eigen::VectorXd s0_;
  Eigen::Vector3d y_;
  Eigen::Matrix3d jr_, jr_minus_;
  Eigen::MatrixXd js_, js_minus_, jz_plus_, jz_minus_, jx_plus_, jx_minus_;
  Eigen::VectorXd s_plus_, s_minus_;
  std::vector<Eigen::MatrixXd> hx_;
  std::vector<double> tracker_;
};

}  // namespace

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
  parallel_internal::ForEachChunk(
      points.size(), 64, threads, [&](std::size_t, std::size_t begin, std::size_t end) {
        PointCurvature curvature(model, f_shared);
        std::vector<Eigen::MatrixXd> h(3, Eigen::MatrixXd(n, n));
        for (std::size_t i = begin; i < end; ++i) {
          const Eigen::Vector3d r0 = points[i].readings;
          const Eigen::Vector3d u_r = model.reading_uncertainty(r0(0));
          PointUncertainty& p = results[i];
          // Over +-1 u of each input (2 (3 + S) Jacobians). Where that already shows terms above a
          // tenth of the threshold, also at the point itself (exact), and the two must agree for
          // the second order to decide (SecondOrderDecides).
          curvature.SpanHessians(r0, u_r, h);
          Eigen::Vector3d v_span, v_local;
          for (int a = 0; a < 3; ++a) v_span(a) = gum_internal::SecondOrderVariance(h[a]);
          p.second_order_variance = v_span;
          p.second_order_decided = true;
          const Eigen::Vector3d var1 = p.cov_part.diagonal();
          // (A pole at +-1 u itself makes v_span infinite: then the local terms alone, undecided.)
          const bool span_finite = v_span.allFinite();
          if (!span_finite || (v_span.array() > 0.1 * threshold * var1.array()).any()) {
            curvature.LocalHessians(r0, u_r, h);
            for (int a = 0; a < 3; ++a) {
              v_local(a) = gum_internal::SecondOrderVariance(h[a]);
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
