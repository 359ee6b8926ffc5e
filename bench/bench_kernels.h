// bench_kernels.h — the generated kernels of each benchmarked model behind one interface, so
// that every Jacobian method (generated, automatic differentiation, finite differences) is
// timed on exactly the same templated model code (generated/<model>.h).
#pragma once

#include <array>

#include "generated/head.h"
#include "generated/mirror.h"

namespace vlt::bench {

using SensitivityKernel = void (*)(const double* readings, const double* params, double* column);

struct MirrorKernels {
  static constexpr const char* kName = "mirror";
  static constexpr int kParams = gen::mirror::kNumParams;
  template <typename S>
  static void Forward(const S* r, const S* p, S* out) {
    gen::mirror::Forward<S>(r, p, out);
  }
  template <typename S>
  static void ForwardJacobians(const S* r, const S* p, S* out, S* jr, S* jp) {
    gen::mirror::ForwardJacobians<S>(r, p, out, jr, jp);
  }
  template <typename S>
  static void NominalJacobians(const S* r, S* out, S* jr, S* jp) {
    gen::mirror::NominalJacobians<S>(r, out, jr, jp);
  }
  template <typename S>
  static void Hessians(const S* r, const S* p, S* h) {
    gen::mirror::Hessians<S>(r, p, h);
  }
  // Column k of d out / d params, in spec order.
  static constexpr std::array<SensitivityKernel, kParams> kSensitivity = {
      &gen::mirror::Sensitivity_a0<double>,  &gen::mirror::Sensitivity_eac<double>,
      &gen::mirror::Sensitivity_eas<double>, &gen::mirror::Sensitivity_e0<double>,
      &gen::mirror::Sensitivity_eec<double>, &gen::mirror::Sensitivity_ees<double>,
      &gen::mirror::Sensitivity_thv<double>, &gen::mirror::Sensitivity_rhv<double>,
      &gen::mirror::Sensitivity_rmv<double>, &gen::mirror::Sensitivity_tmv<double>,
      &gen::mirror::Sensitivity_tbw<double>, &gen::mirror::Sensitivity_tbv<double>,
      &gen::mirror::Sensitivity_rbh<double>, &gen::mirror::Sensitivity_rbv<double>,
      &gen::mirror::Sensitivity_R0<double>,  &gen::mirror::Sensitivity_mu<double>,
      &gen::mirror::Sensitivity_srr<double>, &gen::mirror::Sensitivity_srh<double>,
      &gen::mirror::Sensitivity_srv<double>, &gen::mirror::Sensitivity_sdh<double>,
  };
};

struct HeadKernels {
  static constexpr const char* kName = "head";
  static constexpr int kParams = gen::head::kNumParams;
  template <typename S>
  static void Forward(const S* r, const S* p, S* out) {
    gen::head::Forward<S>(r, p, out);
  }
  template <typename S>
  static void ForwardJacobians(const S* r, const S* p, S* out, S* jr, S* jp) {
    gen::head::ForwardJacobians<S>(r, p, out, jr, jp);
  }
  template <typename S>
  static void NominalJacobians(const S* r, S* out, S* jr, S* jp) {
    gen::head::NominalJacobians<S>(r, out, jr, jp);
  }
  template <typename S>
  static void Hessians(const S* r, const S* p, S* h) {
    gen::head::Hessians<S>(r, p, h);
  }
};

}  // namespace vlt::bench
