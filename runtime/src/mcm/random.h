// mcm/random.h — keyed counter-based random numbers for the Monte Carlo engine (internal).
//
// Philox4x64-10 (Random123; Salmon et al., SC'11) with key = (seed, 0). One call maps a 256-bit
// counter to four 64-bit words. The counter is
//     (trial / 4, input, purpose, 0)    for the regular draws: word j serves trial 4*(trial/4)+j
//     (trial, input, attempt, 1)        for rejection methods (Student t, Bailey's polar method)
// so every draw depends only on (seed, trial, input) — never on the thread, the batch or the order
// in which trials are computed: results are bit-identical for any number of threads.
// `purpose` 0 is the first uniform of each trial, purpose 1 the second (curvilinear trapezoid).
//
// Uniforms on the OPEN interval (0, 1): u = (floor(w / 2^12) + 1/2) * 2^-52, i.e. the 52 high bits
// of the word give k in [0, 2^52) and u is the midpoint of the k-th of 2^52 equal cells: values
// from 2^-53 to 1 - 2^-53, symmetric about 1/2, all exactly representable, never 0 or 1. (With 53
// bits the top midpoint 1 - 2^-54 is not a double and would round to 1.)
//
// Normals: Box-Muller (exact transform, JCGM 101 C.4.2) on a second member of the family,
// Philox4x32-10 with key = (seed mod 2^32, seed / 2^32), chosen because its 32 x 32 -> 64-bit
// multiplies run in SIMD lanes (mcm/normals.cc). Trial pair p = (2p, 2p+1) — group g of four
// trials 4g .. 4g+3 is pairs 2g and 2g+1 — has the counter (p mod 2^32, p / 2^32, input mod
// 2^32, input / 2^32) and its four 32-bit words (w0, w1, w2, w3) give two uniforms on the open
// interval from 52 bits each (ToOpenUnit of the 64-bit words w0:w1 and w2:w3):
//     z_{2p} = sqrt(-2 ln u) cos(2 pi v),   z_{2p+1} = sqrt(-2 ln u) sin(2 pi v).
// ln and sin/cos are vlt's own (LogOpenUnit, SinCosTwoPi below): additions, multiplications,
// one division and one square root, each IEEE correctly rounded and never fused, so a normal has
// the same bits on every x86-64 machine, whichever instruction set the SIMD path uses, with any
// C library. Each z depends only on (seed, trial, input).
#pragma once

#include <bit>
#include <cmath>
#include <cstdint>

#include <Random123/philox.h>

#include "base/lanes.h"

namespace vlt::mcm_internal {

class KeyedStream {
 public:
  using Generator = r123::Philox4x64;
  using NormalGenerator = r123::Philox4x32;

  explicit KeyedStream(std::uint64_t seed) {
    key_[0] = seed;
    key_[1] = 0;
    normal_key_[0] = static_cast<std::uint32_t>(seed);
    normal_key_[1] = static_cast<std::uint32_t>(seed >> 32);
  }

  const r123::Philox4x32::key_type& normal_key() const { return normal_key_; }

  // Four uniforms for trials 4*group .. 4*group+3 of `input` (purpose 0 or 1).
  void Uniforms(std::uint64_t group, std::uint64_t input, std::uint64_t purpose, double out[4]) const {
    Generator::ctr_type ctr = {{group, input, purpose, 0}};
    const Generator::ctr_type r = generator_(ctr, key_);
    for (int j = 0; j < 4; ++j) out[j] = ToOpenUnit(r[j]);
  }

  // Four standard normals for trials 4*group .. 4*group+3 of `input` (Box-Muller, see above):
  // the scalar reference of NormalsBulk.
  void Normals(std::uint64_t group, std::uint64_t input, double out[4]) const {
    for (int half = 0; half < 2; ++half) {
      const std::uint64_t pair = 2 * group + static_cast<std::uint64_t>(half);
      const NormalGenerator::ctr_type ctr = {
          {static_cast<std::uint32_t>(pair), static_cast<std::uint32_t>(pair >> 32),
           static_cast<std::uint32_t>(input), static_cast<std::uint32_t>(input >> 32)}};
      const NormalGenerator::ctr_type w = NormalGenerator()(ctr, normal_key_);
      const double u = OpenUnitFromHalves(w[0], w[1]);
      const double v = OpenUnitFromHalves(w[2], w[3]);
      const double r = std::sqrt(-2.0 * LogOpenUnit(u));
      double s, c;
      SinCosTwoPi(v, &s, &c);
      out[2 * half] = r * c;
      out[2 * half + 1] = r * s;
    }
  }

  // The normals of `groups` consecutive groups (groups <= kBulkGroups) of `input`:
  // out[4 g + j] = Normals(first_group + g, input)[j], bit for bit, computed in SIMD lanes
  // (mcm/normals.cc: Philox4x32-10 over arrays of counters, then the transform stage by stage).
  static constexpr int kBulkGroups = 64;
  void NormalsBulk(std::uint64_t first_group, int groups, std::uint64_t input, double* out) const;

  // The uniform on the open interval (0, 1) of the 64-bit word hi:lo, equal to ToOpenUnit of it
  // but written with bit operations only, so that it vectorises: with k the word's 52 high bits,
  // the double with exponent 0 and mantissa k is 1 + k 2^-52; subtracting 1 and adding 2^-53
  // are exact.
  static double OpenUnitFromHalves(std::uint32_t hi, std::uint32_t lo) {
    const std::uint64_t k = ((static_cast<std::uint64_t>(hi) << 32) | lo) >> 12;
    return (std::bit_cast<double>(k | 0x3FF0000000000000ull) - 1.0) + 0x1.0p-53;
  }

  // ln u for a normal double u in (0, 1) (the uniforms above lie in [2^-53, 1 - 2^-53]), without
  // a branch or a libm call: u = 2^e m with m in [sqrt(2)/2, sqrt(2)), f = m - 1 (exact),
  // s = f / (2 + f), ln(1 + f) = 2 atanh(s) = f - f^2/2 + s (f^2/2 + R(s^2)) with the minimax
  // polynomial R of fdlibm's e_log.c (Sun Microsystems, 1993; error below 1 ulp, checked against
  // long double in tests/test_distributions.cc), and e ln 2 in two parts (e ln2_hi is exact).
  static double LogOpenUnit(double u) {
    const std::uint64_t bits = std::bit_cast<std::uint64_t>(u);
    const std::uint64_t mantissa = bits & 0x000FFFFFFFFFFFFFull;
    // m >= sqrt(2) (the mantissa field above that of sqrt(2)): halve m, one more in e.
    const bool high = mantissa > 0x6A09E667F3BCCull;
    const std::uint64_t biased = (bits >> 52) + (high ? 1u : 0u);  // e + 1023, in [970, 1023]
    const double m = std::bit_cast<double>(mantissa | (high ? 0x3FE0000000000000ull : 0x3FF0000000000000ull));
    // e as a double, exactly: 2^52 + biased has `biased` in its mantissa field.
    const double e = std::bit_cast<double>(0x4330000000000000ull | biased) - (0x1.0p52 + 1023.0);
    const double f = m - 1.0;
    const double s = f / (2.0 + f);
    const double z = s * s;
    const double w = z * z;
    const double t1 = w * (0x1.999999997fa04p-2 + w * (0x1.c71c51d8e78afp-3 + w * 0x1.39a09d078c69fp-3));
    const double t2 =
        z * (0x1.5555555555593p-1 +
             w * (0x1.2492494229359p-2 + w * (0x1.7466496cb03dep-3 + w * 0x1.2f112df3e5244p-3)));
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
  static void SinCosTwoPi(double u, double* sine, double* cosine) {
    const double t = 4.0 * u;
    // q = nearbyint(t) for 0 <= t < 2^51 in the default rounding mode (to nearest, ties to
    // even): adding and subtracting 1.5 * 2^52 rounds away the fraction. Unlike nearbyint this
    // needs no libm call on baseline x86-64 (no SSE4.1 roundsd) and vectorises.
    const double q = (t + 0x1.8p52) - 0x1.8p52;
    const double x = (t - q) * 1.5707963267948966192313216916397514;
    double sin_x, cos_x;
    base_internal::lanes::SinCosTaylor(x, &sin_x, &cos_x);
    // Quarter turn q: (sin, cos) = (s, c), (c, -s), (-s, -c), (-c, s) for q mod 4 = 0, 1, 2, 3;
    // selects and sign flips only (exact), no branch.
    const int quarter = static_cast<int>(q);
    const bool odd = (quarter & 1) != 0;
    const double sin_sel = odd ? cos_x : sin_x;
    const double cos_sel = odd ? sin_x : cos_x;
    *sine = (quarter & 2) != 0 ? -sin_sel : sin_sel;
    *cosine = ((quarter + 1) & 2) != 0 ? -cos_sel : cos_sel;
  }

  // Four uniforms of one trial for a rejection method, attempt 0, 1, 2, ...
  void TrialUniforms(std::uint64_t trial, std::uint64_t input, std::uint64_t attempt, double out[4]) const {
    Generator::ctr_type ctr = {{trial, input, attempt, 1}};
    const Generator::ctr_type r = generator_(ctr, key_);
    for (int j = 0; j < 4; ++j) out[j] = ToOpenUnit(r[j]);
  }

  static double ToOpenUnit(std::uint64_t word) {
    // word >> 12 < 2^52: the signed conversion (one instruction; the unsigned one needs a
    // branch on x86-64) gives the same, exact double.
    return (static_cast<double>(static_cast<std::int64_t>(word >> 12)) + 0.5) * 0x1.0p-52;
  }

 private:
  Generator generator_;
  Generator::key_type key_;
  NormalGenerator::key_type normal_key_;
};

// Test hooks (tests/test_distributions.cc): each Philox4x32-10 implementation that NormalsBulk may
// use — the portable loop, SSE2 and AVX2 lanes (GCC on x86-64) — writes the four words of pairs
// first_pair .. first_pair + pairs - 1 (pairs <= 2 kBulkGroups) to words[4 p + j], to be compared
// with Random123 on this machine.
enum class PhiloxImplementation { kPortable, kSse2, kAvx2, kAvx512 };
bool PhiloxImplementationRuns(PhiloxImplementation which);
void PhiloxWordsForTest(PhiloxImplementation which, std::uint32_t key0, std::uint32_t key1,
                        std::uint64_t first_pair, int pairs, std::uint64_t input, std::uint32_t* words);

}  // namespace vlt::mcm_internal
