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
#include "base/portable_math.h"

namespace vlt::mcm_internal {

class KeyedStream {
 public:
  using Generator = r123::Philox4x64;
  using NormalGenerator = r123::Philox4x32;

  explicit KeyedStream(std::uint64_t seed) : seed_(seed) {
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
    base_internal::portable::NormalsOfGroup(seed_, group, input, out);
  }

  // The normals of `groups` consecutive groups (groups <= kBulkGroups) of `input`:
  // out[4 g + j] = Normals(first_group + g, input)[j], bit for bit, computed in SIMD lanes
  // (mcm/normals.cc: Philox4x32-10 over arrays of counters, then the transform stage by stage).
  static constexpr int kBulkGroups = 64;
  void NormalsBulk(std::uint64_t first_group, int groups, std::uint64_t input, double* out) const;

  // The uniform on the open interval (0, 1) of the 64-bit word hi:lo, equal to ToOpenUnit of it
  // (base/portable_math.h: the lines the GPU kernel runs too).
  static double OpenUnitFromHalves(std::uint32_t hi, std::uint32_t lo) { return base_internal::portable::OpenUnitFromHalves(hi, lo); }
  // ln u for u in [2^-53, 1 - 2^-53], within 1 ulp, branch-free (base/portable_math.h).
  static double LogOpenUnit(double u) { return base_internal::portable::LogOpenUnit(u); }
  // sin and cos of 2 pi u for u in [0, 1], ~1 ulp, branch-free (base/portable_math.h).
  static void SinCosTwoPi(double u, double* sine, double* cosine) { base_internal::portable::SinCosTwoPi(u, sine, cosine); }

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
  std::uint64_t seed_;
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
