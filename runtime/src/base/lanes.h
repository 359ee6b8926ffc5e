// base/lanes.h — the SIMD lane type of the generated Monte Carlo kernel (ModelInfo::forward_lanes).
//
// Double4 holds one double per trial for kForwardLanes = 4 trials. Its arithmetic is lane by lane
// (+, -, *, / and sqrt: IEEE correctly rounded; the project compiles with -ffp-contract=off, so
// nothing is fused), written as loops over the lanes that the compiler turns into SIMD
// instructions. sin and cos are vlt's own (SinCos below), branch-free per lane so that they vectorise:
// unlike the libm sin/cos of the double kernel they may differ from the correctly rounded value
// by about one unit in the last place (tests/test_lanes.cc measures it against long double). Each
// lane depends only on its own inputs, so a trial's value does not depend on which lane or batch
// it was computed in.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>

#include "base/portable_math.h"

// A generated ForwardLanes is compiled twice (GCC target_clones: AVX2 and the x86-64 baseline; the
// loader picks one), with the kernel inlined into each (flatten). The operations are the same in
// both: -ffp-contract=off, no FMA.
// VLT_ARRAY_CLONES: the same for loops over arrays, whose vector width the compiler chooses: an
// AVX-512 clone too (the Box-Muller transform of mcm/normals.cc: 1.5x faster than AVX2 on this
// machine, where the 4-lane kernels gain nothing from it). Still the same IEEE operations.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define VLT_LANES_CLONES __attribute__((target_clones("avx2", "default"), flatten))
#define VLT_ARRAY_CLONES __attribute__((target_clones("avx512f", "avx2", "default"), flatten))
#else
#define VLT_LANES_CLONES
#define VLT_ARRAY_CLONES
#endif

// 32-byte vectors cross inline functions here; with AVX2 off GCC notes that the ABI for passing
// them differs from an AVX2 build's (Clang likewise). The kernels instantiated on Double4 are inline, so no call
// crosses that boundary; the note comes when the includer's functions are compiled, after this
// header, so it stays off for the rest of the includer.
#if defined(__clang__)
#pragma clang diagnostic ignored "-Wunknown-warning-option"
#pragma clang diagnostic ignored "-Wpsabi"
#elif defined(__GNUC__)
#pragma GCC diagnostic ignored "-Wpsabi"
#endif

namespace vlt::base_internal::lanes {

inline constexpr int kWidth = 4;

// GCC/Clang vector types: each operator is one vector operation (two SSE2 or one AVX2
// instruction), whatever the instruction set the including function is compiled for.
using Vector = double __attribute__((vector_size(32)));
using Mask = std::int64_t __attribute__((vector_size(32)));  // all bits set where true

struct Double4 {
  Vector v;
  Double4() = default;
  Double4(Vector x) : v(x) {}  // NOLINT(google-explicit-constructor)
  // Implicit from a constant of the generated code (0.5 * elevation, 1.0 + mu).
  Double4(double x) : v{x, x, x, x} {}  // NOLINT(google-explicit-constructor)
  double operator[](int lane) const { return v[lane]; }
};

inline Double4 operator+(const Double4& a, const Double4& b) { return a.v + b.v; }
inline Double4 operator-(const Double4& a, const Double4& b) { return a.v - b.v; }
inline Double4 operator*(const Double4& a, const Double4& b) { return a.v * b.v; }
inline Double4 operator/(const Double4& a, const Double4& b) { return a.v / b.v; }
inline Double4 operator-(const Double4& a) { return -a.v; }

inline Double4 sqrt(const Double4& a) {
  Vector r;
  for (int l = 0; l < kWidth; ++l) r[l] = __builtin_sqrt(a.v[l]);
  return r;
}

// Four consecutive doubles (any alignment) to lanes and back.
inline Double4 Load(const double* from) {
  Vector v;
  std::memcpy(&v, from, sizeof v);
  return v;
}
inline void Store(double* to, const Double4& x) { std::memcpy(to, &x.v, sizeof x.v); }

// sin r and cos r for |r| <= pi/4, the Taylor series of base/portable_math.h (on lanes here).
using portable::SinCosTaylor;

// where ? a : b, lane by lane, by bits.
inline Vector Select(Mask where, Vector a, Vector b) {
  return reinterpret_cast<Vector>((where & reinterpret_cast<Mask>(a)) | (~where & reinterpret_cast<Mask>(b)));
}

// base/portable_math.h SinCos in lanes: the same operations and constants, so each lane has the
// scalar's bits (tests/test_lanes.cc, tests/test_gpu_kernel.cc).
using portable::kSinCosReduced;

// SinCos past kSmallAngle, branch-free for |x| <= kSinCosReduced: the reduction to the nearest
// quarter turn, the full series, the quadrant applied by selects. Beyond kSinCosReduced, and for
// infinities and NaN, the lane is libm's.
inline void SinCosReduced(const Double4& x_in, Vector x_abs, Double4* sine, Double4* cosine) {
  const Mask in = x_abs <= kSinCosReduced;  // false for NaN
  const Vector zero = {0.0, 0.0, 0.0, 0.0};
  const Vector x = Select(in, x_in.v, zero);
  // Nearest integer to x 2/pi for |x 2/pi| < 2^51 (round to nearest even, default mode).
  const Vector k = (x * portable::kTwoOverPi + portable::kRoundingShift) - portable::kRoundingShift;
  const Vector r = ((x - k * portable::kPiOverTwo1) - k * portable::kPiOverTwo2) - k * portable::kPiOverTwo3;
  Vector sin_r, cos_r;
  SinCosTaylor(r, &sin_r, &cos_r);
  // Quadrant q = k mod 4: (sin, cos) = (s, c), (c, -s), (-s, -c), (-c, s). k + 1.5 2^52 holds
  // k's two's-complement low bits in its mantissa.
  const Mask q = reinterpret_cast<Mask>(k + portable::kRoundingShift);
  const Mask odd = (q & 1) != 0;
  const Mask sign_bit = Mask{} + INT64_MIN;
  const Mask sin_flip = ((q & 2) != 0) & sign_bit;
  const Mask cos_flip = (((q + 1) & 2) != 0) & sign_bit;
  Vector s = Select(odd, cos_r, sin_r);
  Vector c = Select(odd, sin_r, cos_r);
  s = reinterpret_cast<Vector>(reinterpret_cast<Mask>(s) ^ sin_flip);
  c = reinterpret_cast<Vector>(reinterpret_cast<Mask>(c) ^ cos_flip);
  for (int l = 0; l < kWidth; ++l) {
    if (!in[l]) {  // rare: |x| > 2^19, infinite or NaN
      s[l] = std::sin(x_in.v[l]);
      c[l] = std::cos(x_in.v[l]);
    }
  }
  sine->v = s;
  cosine->v = c;
}

// sin x and cos x, lane by lane. Lanes with |x| <= kSmallAngle take SinCosSmall, as the scalar
// does: when every lane does (a tracker's error angles), only it is computed; when some do, both,
// and a select per lane.
inline void SinCos(const Double4& x_in, Double4* sine, Double4* cosine) {
  const Vector x_abs = reinterpret_cast<Vector>(reinterpret_cast<Mask>(x_in.v) & (Mask{} + INT64_MAX));
  const Mask small = x_abs <= portable::kSmallAngle;  // false for NaN
  bool all = true, any = false;
  for (int l = 0; l < kWidth; ++l) {
    all = all && small[l] != 0;
    any = any || small[l] != 0;
  }
  if (all) {
    portable::SinCosSmall(x_in.v, &sine->v, &cosine->v);
    return;
  }
  SinCosReduced(x_in, x_abs, sine, cosine);
  if (any) {
    Vector s, c;
    portable::SinCosSmall(x_in.v, &s, &c);
    sine->v = Select(small, s, sine->v);
    cosine->v = Select(small, c, cosine->v);
  }
}

inline Double4 sin(const Double4& x) {
  Double4 s, c;
  SinCos(x, &s, &c);
  return s;
}

inline Double4 cos(const Double4& x) {
  Double4 s, c;
  SinCos(x, &s, &c);
  return c;
}

}  // namespace vlt::base_internal::lanes
