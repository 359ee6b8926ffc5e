// vlt/model_info.h — the runtime's view of one generated model.
//
// vlt-gen emits, for every spec in models/, a header generated/<name>.h (templated kernels) and a
// source generated/<name>.cc that instantiates them for double and fills one ModelInfo; the
// registry generated/registry.cc lists them all. This header is the only thing the generated code
// and the runtime share, so it has no dependencies (no Eigen, no GiNaC).
//
// Conventions (docs/conventions.md):
//  - Tracker models: readings are (range [m], azimuth [rad], elevation [rad]); outputs are the
//    true reflector-centre coordinates (x, y, z) [m] in the tracker frame.
//  - Custom models: no readings; every input is a "parameter"; outputs as the spec names them.
//  - Jacobians are column-major: J[rows * k + i] = d output_i / d input_k, so the column of one
//    input is contiguous (Eigen::Map<Eigen::Matrix<double, rows, cols>> reads it directly).
#pragma once

#include <cstddef>

namespace vlt {

// One named scalar: a reading, an error parameter / custom input, or an output.
struct QuantityInfo {
  const char* name;                  // identifier used in specs, job files and reports, e.g. "tmv"
  const char* unit;                  // SI unit of the value: "m", "rad", "1" (dimensionless), "degC", ...
  const char* quantity;              // "length", "angle", "ratio", "temperature", "dimensionless", ...
  const char* description;           // physical meaning and sign convention, one sentence
  double default_estimate;           // SI; 0 for a compensated tracker
  double default_u;                  // default standard uncertainty, SI
  const char* default_distribution;  // "normal", "rectangular", ... (runtime/distributions)
  double default_shape;              // extra shape parameter where the distribution has one, else 0
};

// Kernels instantiated for double. All pointers are to caller-owned arrays; nothing allocates.
using ForwardFn = void (*)(const double* readings, const double* params, double* outputs);
using ForwardJacobiansFn = void (*)(const double* readings, const double* params, double* outputs,
                                    double* d_outputs_d_readings, double* d_outputs_d_params);
// Same as ForwardJacobiansFn with every parameter at its nominal value, specialised symbolically:
// 0 for tracker models (a compensated tracker), the spec's estimates for custom models.
using NominalJacobiansFn = void (*)(const double* readings, double* outputs, double* d_outputs_d_readings,
                                    double* d_outputs_d_params);
// Column k of d_outputs_d_params at general parameter values (k indexes params).
using SensitivityFn = void (*)(int param_index, const double* readings, const double* params, double* column);
// Structure-of-arrays batch: readings[j][i] is reading j of item i (num_readings arrays of n),
// params[k][i] likewise, outputs[o][i] likewise.
using ForwardBatchFn = void (*)(std::size_t n, const double* const* readings, const double* const* params,
                                double* const* outputs);
// NominalJacobiansFn for kNominalBatchLanes points at once, structure of arrays: quantity q of
// point (lane) l is at [kNominalBatchLanes * q + l] in every array (readings: 3 quantities,
// outputs: num_outputs, d_outputs_d_readings: 3 * num_outputs, d_outputs_d_params:
// num_outputs * num_params, each in the column-major order of NominalJacobiansFn). The same
// templated kernel instantiated on a SIMD lane type: every lane performs exactly the double
// kernel's operations (libm sin/cos per lane, IEEE sqrt, no FMA contraction in the portable
// build), so each point is bit for bit NominalJacobiansFn's (tests/test_generated_models.cc).
inline constexpr int kNominalBatchLanes = 4;
using NominalJacobiansBatchFn = void (*)(const double* readings, double* outputs,
                                         double* d_outputs_d_readings, double* d_outputs_d_params);

// Forward for kForwardLanes trials at once (the Monte Carlo engine's job kernel), structure of
// arrays: quantity q of lane l of the readings (num_readings quantities) and of the outputs
// (num_outputs) at [stride * q + l], of the params (num_params) at [params_stride * q + l]; both
// strides >= kForwardLanes. The engine hands the kernel its rows of a sub-batch's draws and
// outputs in place (stride kSubBatch: no copy of a trial's 20-odd parameters into a block), a
// padded last group in blocks of its own (stride kForwardLanes), and, where the air corrects the
// readings and the pose and thermal stages follow, the readings and outputs in blocks and the
// parameters in place. The templated kernel instantiated on
// vlt::base_internal::lanes::Double4 (base/lanes.h), compiled for AVX2 and for the baseline: +, -, *, / and sqrt
// are ForwardFn's operations lane by lane, sin and cos are vlt's own (within 2.4 ulp, libm's
// within 1), so a lane may differ from ForwardFn in the last bits, never by more (tests/
// test_generated_models.cc). Tracker models whose Forward calls only sin, cos and sqrt, and (since
// 2026-11-28) custom models whose Forward calls sin or cos and nothing but sqrt besides (vlt's own
// sine and cosine in their Monte Carlo, as on the GPU); never a model built at run time; nullptr
// otherwise (the engine then calls ForwardFn per trial).
inline constexpr int kForwardLanes = 4;
using ForwardLanesFn = void (*)(const double* readings, const double* params, double* outputs,
                                std::ptrdiff_t stride, std::ptrdiff_t params_stride);

// The second derivatives of every output in the inputs x = (readings, params), n = num_readings +
// num_params of them: hessians[n * n * o + n * l + k] = d2 out_o / dx_k dx_l, each output's n x n
// matrix symmetric and column-major. Exact: vlt-gen differentiates the Jacobian program once more
// (forward over forward mode, symbolic/graph.h HessianProgram); used by the GUM's second-order
// check (JCGM 100 5.1.2 note; docs/gum.md "Non-linearity").
using HessiansFn = void (*)(const double* readings, const double* params, double* hessians);

struct ModelInfo {
  const char* name;  // "mirror", "head", "jcgm101_additive", ...
  const char* kind;  // "tracker" or "custom"
  const char* description;
  const char* spec_file;  // e.g. "models/mirror.toml"
  int num_readings;       // 3 for trackers, 0 for custom models
  int num_params;
  int num_outputs;
  const QuantityInfo* readings;
  const QuantityInfo* params;
  const QuantityInfo* outputs;
  ForwardFn forward;
  ForwardJacobiansFn forward_jacobians;
  NominalJacobiansFn nominal_jacobians;
  SensitivityFn sensitivity;
  ForwardBatchFn forward_batch;
  NominalJacobiansBatchFn nominal_jacobians_batch;  // tracker models; nullptr for custom models
  ForwardLanesFn forward_lanes;                     // see ForwardLanesFn; else nullptr
  HessiansFn hessians;
  // Operation counts of the emitted kernels after common-subexpression elimination.
  int ops_forward;
  int ops_forward_jacobians;
  int ops_nominal_jacobians;
  int ops_hessians;
};

// The layout of ModelInfo and the kernels' signatures, as a model built at run time (`vlt model
// build`, vlt/models.h BuildModel) was compiled against: a plugin whose number differs from the
// running vlt's is refused ("rebuild it"). Raise it with any change to this header.
inline constexpr int kModelAbi = 2;  // 2: ModelInfo::hessians

// The entry point of a model plugin: extern "C" const ModelInfo* vlt_model_plugin(int* abi), which
// sets *abi = kModelAbi of the headers it was compiled with.
using ModelPluginFn = const ModelInfo* (*)(int* abi);

namespace generated {
// Defined in generated/registry.cc: every model vlt-gen found in models/, sorted by name.
extern const ModelInfo* const kModels[];
extern const std::size_t kNumModels;
}  // namespace generated

}  // namespace vlt
