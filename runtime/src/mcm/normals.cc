// mcm/normals.cc — the Monte Carlo engine's standard normal deviates in SIMD lanes
// (KeyedStream::NormalsBulk; the stream is defined in mcm/random.h).
//
// Every stage is a loop over arrays of independent lanes that the compiler vectorises:
// Philox4x32-10 (Salmon et al., SC'11: ten rounds of two 32 x 32 -> 64-bit multiplies, xors and a
// Weyl key schedule; the multiplies map to (v)pmuludq), the uniforms from bit operations, then
// LogOpenUnit, the square root and SinCosTwoPi. Philox has AVX-512, AVX2 and SSE2 versions, the
// transform is compiled three times (GCC target_clones: AVX-512, AVX2 and the x86-64 baseline);
// the processor's best is chosen when the program loads. The integer stages give the same words
// on every path; the floating-point stages are single IEEE operations in program order (the
// project compiles with -ffp-contract=off: no fused multiply-add), so every clone — and the
// scalar reference KeyedStream::Normals — gives the same bits (tests/test_distributions.cc).
#include <algorithm>
#include <cmath>
#include <cstdint>

// The SIMD generator with GCC on x86-64; elsewhere (and with Clang, which builds only the fuzzing
// harnesses) the portable loop, which gives the same words.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define VLT_PHILOX_SIMD 1
#include <immintrin.h>
#else
#define VLT_PHILOX_SIMD 0
#endif

#include "mcm/random.h"

namespace vlt::mcm_internal {
namespace {

constexpr int kPairs = 2 * KeyedStream::kBulkGroups;  // one Philox4x32 call per pair of trials

// Philox4x32-10 (Random123 philox.h) on counters (first_pair + p, input) for p < lanes (SIMD: a
// multiple of two registers' lanes): round (x0, x1, x2, x3) -> (hi(M1 x2) ^ x1 ^ k0, lo(M1 x2), hi(M0 x0) ^ x3 ^ k1,
// lo(M0 x0)), key bumped by the Weyl constants before rounds 2..10. The SIMD versions keep
// sixteen (AVX-512), eight (AVX2) or four (SSE2) counters per register; the 32 x 32 -> 64-bit
// multiply (pmuludq) takes the even lanes, so the odd lanes are shifted down, multiplied, and the
// halves blended back.
constexpr std::uint32_t kM0 = 0xD2511F53u, kM1 = 0xCD9E8D57u;
constexpr std::uint32_t kW0 = 0x9E3779B9u, kW1 = 0xBB67AE85u;

struct PhiloxWords {
  alignas(64) std::uint32_t w0[kPairs], w1[kPairs], w2[kPairs], w3[kPairs];
};

void PhiloxPortable(std::uint32_t key0, std::uint32_t key1, std::uint64_t first_pair, int lanes,
                    std::uint64_t input, PhiloxWords& out) {
  for (int p = 0; p < lanes; ++p) {
    const std::uint64_t pair = first_pair + static_cast<std::uint64_t>(p);
    std::uint32_t x0 = static_cast<std::uint32_t>(pair), x1 = static_cast<std::uint32_t>(pair >> 32);
    std::uint32_t x2 = static_cast<std::uint32_t>(input), x3 = static_cast<std::uint32_t>(input >> 32);
    std::uint32_t k0 = key0, k1 = key1;
    for (int round = 0; round < 10; ++round, k0 += kW0, k1 += kW1) {
      const std::uint64_t product0 = std::uint64_t{kM0} * x0;
      const std::uint64_t product1 = std::uint64_t{kM1} * x2;
      const std::uint32_t y0 = static_cast<std::uint32_t>(product1 >> 32) ^ x1 ^ k0;
      const std::uint32_t y2 = static_cast<std::uint32_t>(product0 >> 32) ^ x3 ^ k1;
      x1 = static_cast<std::uint32_t>(product1);
      x3 = static_cast<std::uint32_t>(product0);
      x0 = y0;
      x2 = y2;
    }
    out.w0[p] = x0;
    out.w1[p] = x1;
    out.w2[p] = x2;
    out.w3[p] = x3;
  }
}

#if VLT_PHILOX_SIMD
// One SIMD implementation for both register widths: V is __m256i (AVX2, eight 32-bit lanes) or
// __m128i (SSE2, four). kBlocks independent registers per word are in flight at once, so that the
// multiplies of one block overlap the dependent shifts and xors of the other (one round is a
// chain of about ten cycles; one block alone would leave the multiplier idle).
struct Sse2Lanes {
  using V = __m128i;
  static constexpr int kWidth = 4;
  static __m128i Load(const std::uint32_t* p) { return _mm_load_si128(reinterpret_cast<const __m128i*>(p)); }
  static void Store(std::uint32_t* p, __m128i v) { _mm_store_si128(reinterpret_cast<__m128i*>(p), v); }
  static __m128i Splat32(std::uint32_t x) { return _mm_set1_epi32(static_cast<int>(x)); }
  static __m128i Splat64(std::uint64_t x) { return _mm_set1_epi64x(static_cast<long long>(x)); }
  static __m128i MulEven(__m128i a, __m128i b) { return _mm_mul_epu32(a, b); }
  static __m128i ShiftDown(__m128i a) { return _mm_srli_epi64(a, 32); }
  static __m128i ShiftUp(__m128i a) { return _mm_slli_epi64(a, 32); }
  static __m128i Xor(__m128i a, __m128i b) { return _mm_xor_si128(a, b); }
  static __m128i Xor3(__m128i a, __m128i b, __m128i c) { return Xor(Xor(a, b), c); }
  // Even 32-bit lanes from a, odd lanes from b (SSE2 has no blend instruction).
  static __m128i Blend(__m128i a, __m128i b) {
    const __m128i odd = _mm_set_epi32(-1, 0, -1, 0);
    return _mm_or_si128(_mm_andnot_si128(odd, a), _mm_and_si128(odd, b));
  }
};

struct Avx2Lanes {
  using V = __m256i;
  static constexpr int kWidth = 8;
  __attribute__((target("avx2"))) static __m256i Load(const std::uint32_t* p) {
    return _mm256_load_si256(reinterpret_cast<const __m256i*>(p));
  }
  __attribute__((target("avx2"))) static void Store(std::uint32_t* p, __m256i v) {
    _mm256_store_si256(reinterpret_cast<__m256i*>(p), v);
  }
  __attribute__((target("avx2"))) static __m256i Splat32(std::uint32_t x) {
    return _mm256_set1_epi32(static_cast<int>(x));
  }
  __attribute__((target("avx2"))) static __m256i Splat64(std::uint64_t x) {
    return _mm256_set1_epi64x(static_cast<long long>(x));
  }
  __attribute__((target("avx2"))) static __m256i MulEven(__m256i a, __m256i b) {
    return _mm256_mul_epu32(a, b);
  }
  __attribute__((target("avx2"))) static __m256i ShiftDown(__m256i a) { return _mm256_srli_epi64(a, 32); }
  __attribute__((target("avx2"))) static __m256i ShiftUp(__m256i a) { return _mm256_slli_epi64(a, 32); }
  __attribute__((target("avx2"))) static __m256i Xor(__m256i a, __m256i b) { return _mm256_xor_si256(a, b); }
  __attribute__((target("avx2"))) static __m256i Xor3(__m256i a, __m256i b, __m256i c) {
    return Xor(Xor(a, b), c);
  }
  __attribute__((target("avx2"))) static __m256i Blend(__m256i a, __m256i b) {
    return _mm256_blend_epi32(a, b, 0xAA);
  }
};

// AVX-512 (F): sixteen lanes per register, the three-way xor in one instruction (vpternlogd,
// truth table 0x96 = a ^ b ^ c) and the blend by a lane mask. GCC 12's AVX-512 headers
// initialise some intrinsics' results from themselves, which -Wmaybe-uninitialized reports when
// they are inlined here; the values are all defined.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"
struct Avx512Lanes {
  using V = __m512i;
  static constexpr int kWidth = 16;
  __attribute__((target("avx512f"))) static __m512i Load(const std::uint32_t* p) {
    return _mm512_load_si512(p);
  }
  __attribute__((target("avx512f"))) static void Store(std::uint32_t* p, __m512i v) {
    _mm512_store_si512(p, v);
  }
  __attribute__((target("avx512f"))) static __m512i Splat32(std::uint32_t x) {
    return _mm512_set1_epi32(static_cast<int>(x));
  }
  __attribute__((target("avx512f"))) static __m512i Splat64(std::uint64_t x) {
    return _mm512_set1_epi64(static_cast<long long>(x));
  }
  __attribute__((target("avx512f"))) static __m512i MulEven(__m512i a, __m512i b) {
    return _mm512_mul_epu32(a, b);
  }
  __attribute__((target("avx512f"))) static __m512i ShiftDown(__m512i a) { return _mm512_srli_epi64(a, 32); }
  __attribute__((target("avx512f"))) static __m512i ShiftUp(__m512i a) { return _mm512_slli_epi64(a, 32); }
  __attribute__((target("avx512f"))) static __m512i Xor(__m512i a, __m512i b) {
    return _mm512_xor_si512(a, b);
  }
  __attribute__((target("avx512f"))) static __m512i Xor3(__m512i a, __m512i b, __m512i c) {
    return _mm512_ternarylogic_epi32(a, b, c, 0x96);
  }
  __attribute__((target("avx512f"))) static __m512i Blend(__m512i a, __m512i b) {
    return _mm512_mask_blend_epi32(0xAAAA, a, b);
  }
};
#pragma GCC diagnostic pop

// PhiloxLanes<Avx2Lanes> is only ever inlined into PhiloxAvx2 (AVX2), so the warning that an AVX
// value crosses a function without AVX does not apply.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wpsabi"
template <class L>
__attribute__((always_inline)) inline void PhiloxLanes(std::uint32_t key0, std::uint32_t key1,
                                                       std::uint64_t first_pair, int lanes,
                                                       std::uint64_t input, PhiloxWords& out) {
  using V = typename L::V;
  constexpr int kBlocks = 2;
  constexpr int kStep = kBlocks * L::kWidth;
  const V m0 = L::Splat64(kM0), m1 = L::Splat64(kM1);
  for (int base = 0; base < lanes; base += kStep) {
    alignas(64) std::uint32_t lo[kStep], hi[kStep];
    for (int j = 0; j < kStep; ++j) {
      const std::uint64_t pair = first_pair + static_cast<std::uint64_t>(base + j);
      lo[j] = static_cast<std::uint32_t>(pair);
      hi[j] = static_cast<std::uint32_t>(pair >> 32);
    }
    V x0[kBlocks], x1[kBlocks], x2[kBlocks], x3[kBlocks];
    for (int b = 0; b < kBlocks; ++b) {
      x0[b] = L::Load(lo + b * L::kWidth);
      x1[b] = L::Load(hi + b * L::kWidth);
      x2[b] = L::Splat32(static_cast<std::uint32_t>(input));
      x3[b] = L::Splat32(static_cast<std::uint32_t>(input >> 32));
    }
    std::uint32_t k0 = key0, k1 = key1;
    for (int round = 0; round < 10; ++round, k0 += kW0, k1 += kW1) {
      const V key_a = L::Splat32(k0), key_b = L::Splat32(k1);
      for (int b = 0; b < kBlocks; ++b) {
        // 64-bit products of the even lanes, and of the odd lanes shifted down.
        const V p0e = L::MulEven(x0[b], m0), p0o = L::MulEven(L::ShiftDown(x0[b]), m0);
        const V p1e = L::MulEven(x2[b], m1), p1o = L::MulEven(L::ShiftDown(x2[b]), m1);
        const V hi0 = L::Blend(L::ShiftDown(p0e), p0o), lo0 = L::Blend(p0e, L::ShiftUp(p0o));
        const V hi1 = L::Blend(L::ShiftDown(p1e), p1o), lo1 = L::Blend(p1e, L::ShiftUp(p1o));
        x0[b] = L::Xor3(hi1, x1[b], key_a);
        x2[b] = L::Xor3(hi0, x3[b], key_b);
        x1[b] = lo1;
        x3[b] = lo0;
      }
    }
    for (int b = 0; b < kBlocks; ++b) {
      L::Store(out.w0 + base + b * L::kWidth, x0[b]);
      L::Store(out.w1 + base + b * L::kWidth, x1[b]);
      L::Store(out.w2 + base + b * L::kWidth, x2[b]);
      L::Store(out.w3 + base + b * L::kWidth, x3[b]);
    }
  }
}

#pragma GCC diagnostic pop

__attribute__((target("avx2"))) void PhiloxAvx2(std::uint32_t key0, std::uint32_t key1,
                                                std::uint64_t first_pair, int lanes, std::uint64_t input,
                                                PhiloxWords& out) {
  PhiloxLanes<Avx2Lanes>(key0, key1, first_pair, lanes, input, out);
}

void PhiloxSse2(std::uint32_t key0, std::uint32_t key1, std::uint64_t first_pair, int lanes,
                std::uint64_t input, PhiloxWords& out) {
  PhiloxLanes<Sse2Lanes>(key0, key1, first_pair, lanes, input, out);
}

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"
__attribute__((target("avx512f"))) void PhiloxAvx512(std::uint32_t key0, std::uint32_t key1,
                                                     std::uint64_t first_pair, int lanes, std::uint64_t input,
                                                     PhiloxWords& out) {
  PhiloxLanes<Avx512Lanes>(key0, key1, first_pair, lanes, input, out);
}
#pragma GCC diagnostic pop
#endif

void Philox(std::uint32_t key0, std::uint32_t key1, std::uint64_t first_pair, int pairs, std::uint64_t input,
            PhiloxWords& out) {
#if VLT_PHILOX_SIMD
  static const auto path = __builtin_cpu_supports("avx512f") ? PhiloxAvx512
                           : __builtin_cpu_supports("avx2")  ? PhiloxAvx2
                                                             : PhiloxSse2;
  // Whole steps of two registers (32 lanes with AVX-512); kPairs is a multiple of 32.
  const int lanes = (pairs + 31) & ~31;
  path(key0, key1, first_pair, lanes, input, out);
#else
  PhiloxPortable(key0, key1, first_pair, pairs, input, out);
#endif
}

// out[2 p + j] = z_{2 (first_pair + p) + j} of random.h for p < pairs: the transform in lanes,
// compiled for AVX-512, AVX2 and the baseline.
VLT_ARRAY_CLONES  // base/lanes.h (through random.h): AVX-512, AVX2 and baseline clones
    void
    BoxMuller(const PhiloxWords& words, int pairs, double* out) {
  const std::uint32_t *x0 = words.w0, *x1 = words.w1, *x2 = words.w2, *x3 = words.w3;
  // Box-Muller (random.h), stage by stage.
  alignas(64) double radius[kPairs], sine[kPairs], cosine[kPairs];
  for (int p = 0; p < pairs; ++p) {
    radius[p] = -2.0 * KeyedStream::LogOpenUnit(KeyedStream::OpenUnitFromHalves(x0[p], x1[p]));
  }
  // (-fno-math-errno, project-wide: std::sqrt without its errno branch, which would stop
  // vectorisation; radius > 0, where it is the same correctly rounded square root.)
  for (int p = 0; p < pairs; ++p) radius[p] = std::sqrt(radius[p]);
  for (int p = 0; p < pairs; ++p) {
    double s, c;
    KeyedStream::SinCosTwoPi(KeyedStream::OpenUnitFromHalves(x2[p], x3[p]), &s, &c);
    sine[p] = s;
    cosine[p] = c;
  }
  for (int p = 0; p < pairs; ++p) {
    out[2 * p] = radius[p] * cosine[p];
    out[2 * p + 1] = radius[p] * sine[p];
  }
}

}  // namespace

bool PhiloxImplementationRuns(PhiloxImplementation which) {
  switch (which) {
    case PhiloxImplementation::kPortable: return true;
#if VLT_PHILOX_SIMD
    case PhiloxImplementation::kSse2: return true;
    case PhiloxImplementation::kAvx2: return __builtin_cpu_supports("avx2");
    case PhiloxImplementation::kAvx512: return __builtin_cpu_supports("avx512f");
#endif
    default: return false;
  }
}

void PhiloxWordsForTest(PhiloxImplementation which, std::uint32_t key0, std::uint32_t key1,
                        std::uint64_t first_pair, int pairs, std::uint64_t input, std::uint32_t* words) {
  PhiloxWords w;
  const int lanes = (std::min(pairs, kPairs) + 31) & ~31;
  switch (which) {
#if VLT_PHILOX_SIMD
    case PhiloxImplementation::kSse2: PhiloxSse2(key0, key1, first_pair, lanes, input, w); break;
    case PhiloxImplementation::kAvx2: PhiloxAvx2(key0, key1, first_pair, lanes, input, w); break;
    case PhiloxImplementation::kAvx512: PhiloxAvx512(key0, key1, first_pair, lanes, input, w); break;
#endif
    default: PhiloxPortable(key0, key1, first_pair, lanes, input, w); break;
  }
  for (int p = 0; p < std::min(pairs, kPairs); ++p) {
    words[4 * p] = w.w0[p];
    words[4 * p + 1] = w.w1[p];
    words[4 * p + 2] = w.w2[p];
    words[4 * p + 3] = w.w3[p];
  }
}

void KeyedStream::NormalsBulk(std::uint64_t first_group, int groups, std::uint64_t input, double* out) const {
  PhiloxWords words;
  Philox(normal_key_[0], normal_key_[1], 2 * first_group, 2 * groups, input, words);
  BoxMuller(words, 2 * groups, out);
}

}  // namespace vlt::mcm_internal
