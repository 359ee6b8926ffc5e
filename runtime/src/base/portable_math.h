// base/portable_math.h — vlt's own ln, sin and cos, the uniforms of its normals and Philox4x32-10,
// written once in C++ that compiles unchanged on the host and, by NVRTC, as part of a GPU kernel
// (docs/gpu.md): no #include on the device, no standard library, no libm call (but SinCos's
// fallback beyond 2^19 rad, see there). The Monte Carlo engine's CPU path (mcm/random.h,
// base/lanes.h) and the GPU kernel source (gpu/kernel_source.cc) run these same lines, so a
// trial's draws and model have the same bits on both: +, -, *, / and sqrt are IEEE correctly
// rounded on x86-64 and on NVIDIA GPUs alike, and nothing is fused (-ffp-contract=off here,
// --fmad=false for NVRTC).
#pragma once

// VLT_PORTABLE_MARKS_UNREDUCED: SinCos beyond its reduction's range gives NaN, the mark that the
// CPU computes the trial (see SinCos). On the device always; on the host where a test compiles the
// kernel source as the device would run it.
#if defined(__CUDACC_RTC__) || defined(__CUDACC__)
#define VLT_PORTABLE_MARKS_UNREDUCED 1
#elif !defined(VLT_PORTABLE_MARKS_UNREDUCED)
#define VLT_PORTABLE_MARKS_UNREDUCED 0
#endif

#if defined(__CUDACC_RTC__) || defined(__CUDACC__)
#define VLT_PORTABLE __device__ __forceinline__
#define VLT_PORTABLE_DEVICE 1
#define VLT_LIBM(function) ::function
#else
#include <cmath>
#define VLT_PORTABLE inline
#define VLT_PORTABLE_DEVICE 0
#define VLT_LIBM(function) std::function
#endif

namespace vlt::base_internal::portable {

using U32 = unsigned int;
using U64 = unsigned long long;

VLT_PORTABLE double DoubleFromBits(U64 bits) {
#if VLT_PORTABLE_DEVICE
  return __longlong_as_double(static_cast<long long>(bits));
#else
  return __builtin_bit_cast(double, bits);
#endif
}

VLT_PORTABLE U64 BitsOfDouble(double x) {
#if VLT_PORTABLE_DEVICE
  return static_cast<U64>(__double_as_longlong(x));
#else
  return __builtin_bit_cast(U64, x);
#endif
}

// sin r and cos r for |r| <= pi/4 (double or lanes): Taylor series in r^2 to r^17 and r^16,
// Horner with the coefficients (-1)^k / (2k+1)! and (-1)^k / (2k)!; truncation below 3e-18.
// Shared by the Box-Muller transform (SinCosTwoPi) and base/lanes.h SinCos.
template <class T>
VLT_PORTABLE void SinCosTaylor(const T& r, T* sin_r, T* cos_r) {
  const T r2 = r * r;
  T sp = (1.0 / 355687428096000.0) * r2 - 1.0 / 1307674368000.0;  // 1/17!, 1/15!
  sp = sp * r2 + 1.0 / 6227020800.0;                              // 1/13!
  sp = sp * r2 - 1.0 / 39916800.0;                                // 1/11!
  sp = sp * r2 + 1.0 / 362880.0;                                  // 1/9!
  sp = sp * r2 - 1.0 / 5040.0;                                    // 1/7!
  sp = sp * r2 + 1.0 / 120.0;                                     // 1/5!
  sp = sp * r2 - 1.0 / 6.0;                                       // 1/3!
  *sin_r = r + r * r2 * sp;
  T cp = (1.0 / 20922789888000.0) * r2 - 1.0 / 87178291200.0;  // 1/16!, 1/14!
  cp = cp * r2 + 1.0 / 479001600.0;                            // 1/12!
  cp = cp * r2 - 1.0 / 3628800.0;                              // 1/10!
  cp = cp * r2 + 1.0 / 40320.0;                                // 1/8!
  cp = cp * r2 - 1.0 / 720.0;                                  // 1/6!
  cp = cp * r2 + 1.0 / 24.0;                                   // 1/4!
  cp = cp * r2 - 0.5;                                          // 1/2!
  *cos_r = 1.0 + r2 * cp;
}

// sin x and cos x for |x| <= kSmallAngle (double or lanes): the Taylor series to x^5 and x^4,
// sin x = x + x x^2 (-1/6 + x^2/120) and cos x = 1 + x^2 (-1/2 + x^2/24). The first terms left
// out, x^7/7! and x^6/6!, are below 2^-60/5040 = 1.7e-22 of the value (2^-53 = 1.1e-16 is half an
// ulp), and the correction added to x or 1 is at most 2^-20/6 of it, so its own rounding errors
// reach the sum only below 2^-70: each is the rounded exact value, but when that lies within about
// 2^-70 of a rounding boundary — as the full series' (tests/test_lanes.cc). The error angles of a
// tracker (micro-radians) take this path: a quarter of the full series' operations.
inline constexpr double kSmallAngle = 0x1.0p-10;
template <class T>
VLT_PORTABLE void SinCosSmall(const T& x, T* sin_x, T* cos_x) {
  const T x2 = x * x;
  *sin_x = x + x * x2 * ((1.0 / 120.0) * x2 - 1.0 / 6.0);
  *cos_x = 1.0 + x2 * ((1.0 / 24.0) * x2 - 0.5);
}

// The constants of SinCos's reduction (base/lanes.h uses them for its lanes): 2/pi, and pi/2 in
// three parts of 32, 33 and 28 bits (fdlibm's pio2_1, pio2_2, pio2_3: each k * part is exact for
// |k| < 2^20; their sum is pi/2 to 8.5e-32), and the largest |x| reduced so.
inline constexpr double kTwoOverPi = 0x1.45f306dc9c883p-1;
inline constexpr double kPiOverTwo1 = 0x1.921fb544p+0;
inline constexpr double kPiOverTwo2 = 0x1.0b4611a6p-34;
inline constexpr double kPiOverTwo3 = 0x1.3198a2ep-69;
inline constexpr double kSinCosReduced = 0x1.0p19;
// Adding and subtracting 1.5 2^52 rounds a double below 2^51 in magnitude to the nearest integer
// (ties to even, the default rounding mode), with no libm call; the sum holds the integer's two's-
// complement low bits in its mantissa.
inline constexpr double kRoundingShift = 0x1.8p52;

// sin x and cos x of one double: the scalar twin of base/lanes.h SinCos (the same operations, so a
// lane and this give the same bits; tests/test_lanes.cc): for |x| <= kSmallAngle SinCosSmall;
// else k = nearest integer to x 2/pi, r = x - k pi/2 in three parts, the Taylor series on
// |r| <= pi/4, the quadrant k mod 4 by exact selects and sign flips. Beyond kSinCosReduced, and
// for infinities and NaN, libm's on the CPU; on a GPU, whose sin and cos need not have libm's
// bits there, NaN: the mark that the CPU computes that trial instead (mcm/gpu_run.cc; the angles
// and offsets of a tracker are far below 2^19 rad, a custom model's inputs need not be).
VLT_PORTABLE void SinCos(double x_in, double* sine, double* cosine) {
  const double x_abs = DoubleFromBits(BitsOfDouble(x_in) & 0x7FFFFFFFFFFFFFFFull);
  if (x_abs <= kSmallAngle) {
    SinCosSmall(x_in, sine, cosine);
    return;
  }
  if (!(x_abs <= kSinCosReduced)) {  // rare: |x| > 2^19, infinite or NaN
#if VLT_PORTABLE_MARKS_UNREDUCED
    *sine = *cosine = DoubleFromBits(0x7FF8000000000000ull);
#else
    *sine = VLT_LIBM(sin)(x_in);
    *cosine = VLT_LIBM(cos)(x_in);
#endif
    return;
  }
  const double k = (x_in * kTwoOverPi + kRoundingShift) - kRoundingShift;
  const double r = ((x_in - k * kPiOverTwo1) - k * kPiOverTwo2) - k * kPiOverTwo3;
  double sin_r, cos_r;
  SinCosTaylor(r, &sin_r, &cos_r);
  const U64 q = BitsOfDouble(k + kRoundingShift);
  const bool odd = (q & 1) != 0;
  const U64 sin_flip = (q & 2) != 0 ? 0x8000000000000000ull : 0;
  const U64 cos_flip = ((q + 1) & 2) != 0 ? 0x8000000000000000ull : 0;
  *sine = DoubleFromBits(BitsOfDouble(odd ? cos_r : sin_r) ^ sin_flip);
  *cosine = DoubleFromBits(BitsOfDouble(odd ? sin_r : cos_r) ^ cos_flip);
}

// The uniform on the OPEN interval (0, 1) of the 64-bit word hi:lo (mcm/random.h: the 52 high
// bits k give the midpoint (k + 1/2) 2^-52 of the k-th of 2^52 cells), written with bit operations
// only, so that it vectorises: the double with exponent 0 and mantissa k is 1 + k 2^-52;
// subtracting 1 and adding 2^-53 are exact.
VLT_PORTABLE double OpenUnitFromHalves(U32 hi, U32 lo) {
  const U64 k = ((static_cast<U64>(hi) << 32) | lo) >> 12;
  return (DoubleFromBits(k | 0x3FF0000000000000ull) - 1.0) + 0x1.0p-53;
}

// ln u for a normal double u in (0, 1) (the uniforms above lie in [2^-53, 1 - 2^-53]), without
// a branch or a libm call: u = 2^e m with m in [sqrt(2)/2, sqrt(2)), f = m - 1 (exact),
// s = f / (2 + f), ln(1 + f) = 2 atanh(s) = f - f^2/2 + s (f^2/2 + R(s^2)) with the minimax
// polynomial R of fdlibm's e_log.c (Sun Microsystems, 1993; error below 1 ulp, checked against
// long double in tests/test_distributions.cc), and e ln 2 in two parts (e ln2_hi is exact).
VLT_PORTABLE double LogOpenUnit(double u) {
  const U64 bits = BitsOfDouble(u);
  const U64 mantissa = bits & 0x000FFFFFFFFFFFFFull;
  // m >= sqrt(2) (the mantissa field above that of sqrt(2)): halve m, one more in e.
  const bool high = mantissa > 0x6A09E667F3BCCull;
  const U64 biased = (bits >> 52) + (high ? 1u : 0u);  // e + 1023, in [970, 1023]
  const double m = DoubleFromBits(mantissa | (high ? 0x3FE0000000000000ull : 0x3FF0000000000000ull));
  // e as a double, exactly: 2^52 + biased has `biased` in its mantissa field.
  const double e = DoubleFromBits(0x4330000000000000ull | biased) - (0x1.0p52 + 1023.0);
  const double f = m - 1.0;
  const double s = f / (2.0 + f);
  const double z = s * s;
  const double w = z * z;
  const double t1 = w * (0x1.999999997fa04p-2 + w * (0x1.c71c51d8e78afp-3 + w * 0x1.39a09d078c69fp-3));
  const double t2 =
      z * (0x1.5555555555593p-1 + w * (0x1.2492494229359p-2 + w * (0x1.7466496cb03dep-3 + w * 0x1.2f112df3e5244p-3)));
  const double r = t2 + t1;
  const double hfsq = 0.5 * f * f;
  constexpr double kLn2Hi = 0x1.62e42feep-1, kLn2Lo = 0x1.a39ef35793c76p-33;
  return e * kLn2Hi - ((hfsq - (s * (hfsq + r) + e * kLn2Lo)) - f);
}

// sin and cos of 2 pi u for u in [0, 1], accurate to ~1 ulp, without a libm call (the
// Box-Muller transform spent most of its time in sincos): u is reduced EXACTLY to the nearest
// quarter turn q (4u - q is exact in binary floating point), x = (4u - q) pi/2 lies in
// [-pi/4, pi/4], where the Taylor series of sin to x^17 and cos to x^16 have a truncation
// error below 3e-18.
VLT_PORTABLE void SinCosTwoPi(double u, double* sine, double* cosine) {
  const double t = 4.0 * u;
  // q = nearbyint(t) for 0 <= t < 2^51, by kRoundingShift: unlike nearbyint this needs no libm
  // call on baseline x86-64 (no SSE4.1 roundsd) and vectorises.
  const double q = (t + kRoundingShift) - kRoundingShift;
  const double x = (t - q) * 1.5707963267948966192313216916397514;
  double sin_x, cos_x;
  SinCosTaylor(x, &sin_x, &cos_x);
  // Quarter turn q: (sin, cos) = (s, c), (c, -s), (-s, -c), (-c, s) for q mod 4 = 0, 1, 2, 3;
  // selects and sign flips only (exact), no branch.
  const int quarter = static_cast<int>(q);
  const bool odd = (quarter & 1) != 0;
  const double sin_sel = odd ? cos_x : sin_x;
  const double cos_sel = odd ? sin_x : cos_x;
  *sine = (quarter & 2) != 0 ? -sin_sel : sin_sel;
  *cosine = ((quarter + 1) & 2) != 0 ? -cos_sel : cos_sel;
}

// Philox4x32-10 (Salmon et al., SC'11; the constants of Random123's philox.h): the four 32-bit
// words of counter ctr under key (key0, key1). Checked word for word against Random123
// (tests/test_gpu_kernel.cc).
VLT_PORTABLE void Philox4x32(const U32 ctr_in[4], U32 key0, U32 key1, U32 out[4]) {
  U32 c0 = ctr_in[0], c1 = ctr_in[1], c2 = ctr_in[2], c3 = ctr_in[3];
  for (int round = 0; round < 10; ++round) {
    const U64 p0 = static_cast<U64>(0xD2511F53u) * c0;
    const U64 p1 = static_cast<U64>(0xCD9E8D57u) * c2;
    const U32 n0 = static_cast<U32>(p1 >> 32) ^ c1 ^ key0;
    const U32 n2 = static_cast<U32>(p0 >> 32) ^ c3 ^ key1;
    c1 = static_cast<U32>(p1);
    c3 = static_cast<U32>(p0);
    c0 = n0;
    c2 = n2;
    key0 += 0x9E3779B9u;
    key1 += 0xBB67AE85u;
  }
  out[0] = c0;
  out[1] = c1;
  out[2] = c2;
  out[3] = c3;
}

// The two standard normals of trial pair `pair` (trials 2 pair, 2 pair + 1) of stream `input` under
// `seed`: mcm/random.h KeyedStream::Normals (Box-Muller on Philox4x32-10 with key (seed mod 2^32,
// seed / 2^32) and counter (pair mod 2^32, pair / 2^32, input mod 2^32, input / 2^32)).
VLT_PORTABLE void NormalPair(U64 seed, U64 pair, U64 input, double* even, double* odd) {
  const U32 ctr[4] = {static_cast<U32>(pair), static_cast<U32>(pair >> 32), static_cast<U32>(input),
                      static_cast<U32>(input >> 32)};
  U32 w[4];
  Philox4x32(ctr, static_cast<U32>(seed), static_cast<U32>(seed >> 32), w);
  const double u = OpenUnitFromHalves(w[0], w[1]);
  const double v = OpenUnitFromHalves(w[2], w[3]);
  const double r = VLT_LIBM(sqrt)(-2.0 * LogOpenUnit(u));
  double s, c;
  SinCosTwoPi(v, &s, &c);
  *even = r * c;
  *odd = r * s;
}

// Four standard normals of trials 4 group .. 4 group + 3 of stream `input` (pairs 2 group and
// 2 group + 1).
VLT_PORTABLE void NormalsOfGroup(U64 seed, U64 group, U64 input, double out[4]) {
  NormalPair(seed, 2 * group, input, &out[0], &out[1]);
  NormalPair(seed, 2 * group + 1, input, &out[2], &out[3]);
}

// The standard normal of one trial of stream `input`: its element of NormalsOfGroup, computing its
// pair only.
VLT_PORTABLE double NormalOfTrial(U64 seed, U64 trial, U64 input) {
  double even, odd;
  NormalPair(seed, trial / 2, input, &even, &odd);
  return (trial & 1) != 0 ? odd : even;
}

// One trial's lane, for the generated models' Forward<Scalar> in the GPU kernel (gpu/point_trials.h)
// and in its test on the CPU: a double whose sin and cos are SinCos above and whose sqrt is the
// IEEE one, so that a trial's model value has the bits of its lane of base/lanes.h Double4 (the
// CPU engine's kernel). Implicit from a constant of the generated code (0.5 * elevation).
struct Lane {
  double v;
  Lane() = default;
  VLT_PORTABLE Lane(double x) : v(x) {}  // NOLINT(google-explicit-constructor)
};
VLT_PORTABLE Lane operator+(Lane a, Lane b) { return a.v + b.v; }
VLT_PORTABLE Lane operator-(Lane a, Lane b) { return a.v - b.v; }
VLT_PORTABLE Lane operator*(Lane a, Lane b) { return a.v * b.v; }
VLT_PORTABLE Lane operator/(Lane a, Lane b) { return a.v / b.v; }
VLT_PORTABLE Lane operator-(Lane a) { return -a.v; }
VLT_PORTABLE Lane sqrt(Lane a) { return VLT_LIBM(sqrt)(a.v); }
VLT_PORTABLE Lane sin(Lane a) {
  double s, c;
  SinCos(a.v, &s, &c);
  return s;
}
VLT_PORTABLE Lane cos(Lane a) {
  double s, c;
  SinCos(a.v, &s, &c);
  return c;
}
// Both at once, for the generated code's SinCos(x, &s, &c) where a kernel uses both (found by
// argument-dependent lookup).
VLT_PORTABLE void SinCos(Lane a, Lane* sine, Lane* cosine) { SinCos(a.v, &sine->v, &cosine->v); }

}  // namespace vlt::base_internal::portable
