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
// Normals: Box-Muller (exact transform, JCGM 101 C.4.2): from the uniforms (u0, u1) of trials
// 4g, 4g+1 and (u2, u3) of trials 4g+2, 4g+3 of the SAME input,
//     z_{4g}   = sqrt(-2 ln u0) cos(2 pi u1),   z_{4g+1} = sqrt(-2 ln u0) sin(2 pi u1),
// and likewise for 4g+2, 4g+3. The pair shares one counter, so each z still depends only on
// (seed, trial, input).
#pragma once

#include <cmath>
#include <cstdint>

#include <Random123/philox.h>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace vlt::mcm_internal {

class KeyedStream {
 public:
  using Generator = r123::Philox4x64;

  explicit KeyedStream(std::uint64_t seed) {
    key_[0] = seed;
    key_[1] = 0;
  }

  // Four uniforms for trials 4*group .. 4*group+3 of `input` (purpose 0 or 1).
  void Uniforms(std::uint64_t group, std::uint64_t input, std::uint64_t purpose,
                double out[4]) const {
    Generator::ctr_type ctr = {{group, input, purpose, 0}};
    const Generator::ctr_type r = generator_(ctr, key_);
    for (int j = 0; j < 4; ++j) out[j] = ToOpenUnit(r[j]);
  }

  // Four standard normals for trials 4*group .. 4*group+3 of `input` (Box-Muller, see above).
  void Normals(std::uint64_t group, std::uint64_t input, double out[4]) const {
    double u[4];
    Uniforms(group, input, 0, u);
    BoxMuller(u, out);
  }

  // The normals of `groups` consecutive groups (groups <= kBulkGroups) of `input`:
  // out[4 g + j] = Normals(first_group + g, input)[j], bit for bit. The same operations as
  // Normals, reordered into stages over arrays (all Philox calls, then the logarithms and square
  // roots, then the branch-free quarter-turn sine/cosine) so that independent work overlaps and
  // the polynomial stage vectorises; every value goes through exactly the same IEEE operations.
  static constexpr int kBulkGroups = 64;
  void NormalsBulk(std::uint64_t first_group, int groups, std::uint64_t input,
                   double* out) const {
    double u0[kBulkGroups], u1[kBulkGroups], u2[kBulkGroups], u3[kBulkGroups];
    for (int g = 0; g < groups; ++g) {
      Generator::ctr_type ctr = {{first_group + static_cast<std::uint64_t>(g), input, 0, 0}};
      const Generator::ctr_type r = generator_(ctr, key_);
      u0[g] = ToOpenUnit(r[0]);
      u1[g] = ToOpenUnit(r[1]);
      u2[g] = ToOpenUnit(r[2]);
      u3[g] = ToOpenUnit(r[3]);
    }
    for (int g = 0; g < groups; ++g) {
      u0[g] = -2.0 * std::log(u0[g]);   // squared radius of trials 4g, 4g+1
      u2[g] = -2.0 * std::log(u2[g]);   // squared radius of trials 4g+2, 4g+3
    }
    SqrtArray(u0, groups);
    SqrtArray(u2, groups);
    double s0[kBulkGroups], c0[kBulkGroups], s1[kBulkGroups], c1[kBulkGroups];
    SinCosTwoPiArray(u1, groups, s0, c0);
    SinCosTwoPiArray(u3, groups, s1, c1);
    for (int g = 0; g < groups; ++g) {
      out[4 * g + 0] = u0[g] * c0[g];
      out[4 * g + 1] = u0[g] * s0[g];
      out[4 * g + 2] = u2[g] * c1[g];
      out[4 * g + 3] = u2[g] * s1[g];
    }
  }

  // x[i] = sqrt(x[i]) for x[i] > 0 (IEEE correctly rounded either way). std::sqrt keeps an
  // errno branch that stops the compiler from vectorising; the SSE2 instruction does two at once.
  static void SqrtArray(double* x, int n) {
    int i = 0;
#if defined(__SSE2__)
    for (; i + 2 <= n; i += 2) _mm_storeu_pd(x + i, _mm_sqrt_pd(_mm_loadu_pd(x + i)));
#endif
    for (; i < n; ++i) x[i] = std::sqrt(x[i]);
  }

  // SinCosTwoPi over an array (same values), written without branches so that it vectorises.
  static void SinCosTwoPiArray(const double* u, int n, double* sine, double* cosine) {
    for (int i = 0; i < n; ++i) {
      double s, c;
      SinCosTwoPi(u[i], &s, &c);
      sine[i] = s;
      cosine[i] = c;
    }
  }

  // (u0, u1, u2, u3) -> four standard normals (the transform of Normals).
  static void BoxMuller(const double u[4], double out[4]) {
    const double r0 = std::sqrt(-2.0 * std::log(u[0]));
    const double r1 = std::sqrt(-2.0 * std::log(u[2]));
    double s0, c0, s1, c1;
    SinCosTwoPi(u[1], &s0, &c0);
    SinCosTwoPi(u[3], &s1, &c1);
    out[0] = r0 * c0;
    out[1] = r0 * s0;
    out[2] = r1 * c1;
    out[3] = r1 * s1;
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
    const double x2 = x * x;
    // Horner in x^2 with coefficients (-1)^k / (2k+1)! and (-1)^k / (2k)!.
    double sp = 1.0 / 355687428096000.0;            // 1/17!
    sp = sp * x2 - 1.0 / 1307674368000.0;           // 1/15!
    sp = sp * x2 + 1.0 / 6227020800.0;              // 1/13!
    sp = sp * x2 - 1.0 / 39916800.0;                // 1/11!
    sp = sp * x2 + 1.0 / 362880.0;                  // 1/9!
    sp = sp * x2 - 1.0 / 5040.0;                    // 1/7!
    sp = sp * x2 + 1.0 / 120.0;                     // 1/5!
    sp = sp * x2 - 1.0 / 6.0;                       // 1/3!
    const double sin_x = x + x * x2 * sp;
    double cp = 1.0 / 20922789888000.0;             // 1/16!
    cp = cp * x2 - 1.0 / 87178291200.0;             // 1/14!
    cp = cp * x2 + 1.0 / 479001600.0;               // 1/12!
    cp = cp * x2 - 1.0 / 3628800.0;                 // 1/10!
    cp = cp * x2 + 1.0 / 40320.0;                   // 1/8!
    cp = cp * x2 - 1.0 / 720.0;                     // 1/6!
    cp = cp * x2 + 1.0 / 24.0;                      // 1/4!
    cp = cp * x2 - 0.5;                             // 1/2!
    const double cos_x = 1.0 + x2 * cp;
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
  void TrialUniforms(std::uint64_t trial, std::uint64_t input, std::uint64_t attempt,
                     double out[4]) const {
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
};

}  // namespace vlt::mcm_internal
