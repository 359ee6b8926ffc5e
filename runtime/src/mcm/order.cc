// mcm/order.cc — order statistics of stored Monte Carlo values (order.h).
#include "mcm/order.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <span>
#include <type_traits>
#include <utility>
#include <vector>

#include <hwy/contrib/sort/vqsort.h>

// The gathering pass in AVX-512 with GCC on x86-64 (chosen when the processor has it); elsewhere
// the portable loop, which gathers the same values.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define VLT_GATHER_SIMD 1
#include <immintrin.h>
#else
#define VLT_GATHER_SIMD 0
#endif

#include "base/lanes.h"
#include "mcm/storage.h"
#include "parallel/pool.h"

namespace vlt::mcm_internal {

namespace {

// Highway's sorter keeps a small buffer: one per thread (the engine's items run on the pool's
// threads at once).
const hwy::Sorter& ThreadSorter() {
  thread_local const hwy::Sorter sorter;
  return sorter;
}

// Floats are sorted by an LSD radix sort of their IEEE 754 totalOrder keys, not by Highway's
// vqsort: Debian's Highway 1.0.3 stores its 32-bit partitions with VPCOMPRESSD to memory,
// microcoded on AMD Zen 4, where it sorted the engine's float tails at 30-40 ns a value against
// 4-12 ns for this sort (docs/performance.md 4.16); and a radix sort's order of the keys is the
// same on every processor, -0 before +0 included, where vqsort's order of equal values depends on
// the SIMD target it dispatches to.
//
// The digits: four of 8 bits below kRadixWide values, three of 11, 11 and 10 bits from there on.
// A sort's fixed cost is clearing and summing its digits' counts (3 x 2048 against 4 x 256), which
// the 10^4-trial batches' sorts of 600-700 values paid more than their values: 7.4 against 5.0 ns
// a value at 625 values, 4.1 against 4.8 at 4096 (docs/performance.md 4.17). Below kRadixLeast
// values a comparison sort is the faster (std::sort's insertion sort up to 16 of them).
constexpr std::size_t kRadixLeast = 64;
constexpr std::size_t kRadixWide = 2048;
constexpr std::size_t kRadixKept = std::size_t{1} << 20;  // keys a thread keeps buffers for (2 x 4 MiB)

// The bits of x, reordered so that unsigned order is IEEE 754 totalOrder: a positive float's
// sign bit set, a negative float's every bit flipped.
std::uint32_t TotalOrderKey(float x) {
  const auto bits = std::bit_cast<std::uint32_t>(x);
  return bits ^ ((bits >> 31) != 0 ? 0xFFFFFFFFu : 0x80000000u);
}

float FromTotalOrderKey(std::uint32_t key) {
  return std::bit_cast<float>(key ^ ((key >> 31) != 0 ? 0x80000000u : 0xFFFFFFFFu));
}

// The LSD radix sort of `values` (at least one, fewer than 2^32) by their totalOrder keys, with
// digits of kBits bits (the last one the bits left), in `keys` and `spare` (resized to the
// values' count).
template <int kBits>
void RadixSortByTotalOrder(std::span<float> values, std::vector<std::uint32_t>& keys,
                           std::vector<std::uint32_t>& spare) {
  constexpr int kPasses = (32 + kBits - 1) / kBits;
  constexpr std::uint32_t kMask = (std::uint32_t{1} << kBits) - 1;
  auto digit = [](std::uint32_t key, int pass) { return (key >> (kBits * pass)) & kMask; };
  const std::size_t n = values.size();
  keys.resize(n);
  spare.resize(n);
  // One pass: every key, and the count of each digit value of each digit.
  std::array<std::array<std::uint32_t, std::size_t{kMask} + 1>, kPasses> counts{};
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint32_t key = TotalOrderKey(values[i]);
    keys[i] = key;
    for (int pass = 0; pass < kPasses; ++pass) ++counts[pass][digit(key, pass)];
  }
  // Then one stable scatter per digit, least significant first, skipping a digit that every key
  // shares (the high digit of a tail often is).
  std::uint32_t* from = keys.data();
  std::uint32_t* to = spare.data();
  for (int pass = 0; pass < kPasses; ++pass) {
    auto& next = counts[pass];
    if (next[digit(from[0], pass)] == n) continue;
    std::uint32_t start = 0;
    for (std::uint32_t& count : next) start += std::exchange(count, start);
    for (std::size_t i = 0; i < n; ++i) to[next[digit(from[i], pass)]++] = from[i];
    std::swap(from, to);
  }
  for (std::size_t i = 0; i < n; ++i) values[i] = FromTotalOrderKey(from[i]);
}

// Below this many values, or with tails longer than a quarter of them, a copy of every value is
// sorted: the gathering pass would not pay off.
constexpr std::int64_t kGatherMin = 4096;

// Every value x <= lo appended to l at *nl and x >= hi to h at *nh, in the values' order, in one
// branch-free pass: every value is written to both buffers and kept (the count advanced) when it
// lies beyond its threshold. l and h have room for n values past the counts.
template <typename T>
void GatherBlockPortable(const T* x, std::size_t n, T lo, T hi, T* l, T* h, std::size_t* nl, std::size_t* nh) {
  std::size_t kept_low = *nl, kept_high = *nh;
  for (std::size_t i = 0; i < n; ++i) {
    const T v = x[i];
    l[kept_low] = v;
    kept_low += v <= lo ? 1 : 0;
    h[kept_high] = v;
    kept_high += v >= hi ? 1 : 0;
  }
  *nl = kept_low;
  *nh = kept_high;
}

#if VLT_GATHER_SIMD
// The same with AVX-512: a register's values beyond a threshold compressed to its front (in
// order) and the whole register stored, the count advanced by the number kept; the values past
// the count are overwritten by the next store, as in the portable loop. (A compress to registers,
// then an ordinary store: the compress to memory is microcoded and slow on AMD's AVX-512.)
#define VLT_AVX512 __attribute__((target("avx512f"), always_inline)) static
template <typename T>
struct Avx512Register {
  using V = __m512d;
};
template <>
struct Avx512Register<float> {
  using V = __m512;
};
template <typename T>
struct Avx512 {
  static constexpr bool kFloat = std::is_same_v<T, float>;
  using V = typename Avx512Register<T>::V;
  static constexpr std::size_t kWidth = kFloat ? 16 : 8;
  VLT_AVX512 V Splat(T x) {
    if constexpr (kFloat) return _mm512_set1_ps(x); else return _mm512_set1_pd(x);
  }
  VLT_AVX512 V Load(const T* p) {
    if constexpr (kFloat) return _mm512_loadu_ps(p); else return _mm512_loadu_pd(p);
  }
  VLT_AVX512 unsigned AtMost(V v, V t) {
    if constexpr (kFloat) return _mm512_cmp_ps_mask(v, t, _CMP_LE_OQ); else return _mm512_cmp_pd_mask(v, t, _CMP_LE_OQ);
  }
  VLT_AVX512 unsigned AtLeast(V v, V t) {
    if constexpr (kFloat) return _mm512_cmp_ps_mask(v, t, _CMP_GE_OQ); else return _mm512_cmp_pd_mask(v, t, _CMP_GE_OQ);
  }
  VLT_AVX512 void StoreKept(T* p, unsigned kept, V v) {
    if constexpr (kFloat) {
      _mm512_storeu_ps(p, _mm512_maskz_compress_ps(static_cast<__mmask16>(kept), v));
    } else {
      _mm512_storeu_pd(p, _mm512_maskz_compress_pd(static_cast<__mmask8>(kept), v));
    }
  }
};
#undef VLT_AVX512

template <typename T>
__attribute__((target("avx512f"))) void GatherBlockAvx512(const T* x, std::size_t n, T lo, T hi, T* l, T* h,
                                                          std::size_t* nl, std::size_t* nh) {
  using Simd = Avx512<T>;
  const typename Simd::V low = Simd::Splat(lo), high = Simd::Splat(hi);
  std::size_t i = 0;
  for (; i + Simd::kWidth <= n; i += Simd::kWidth) {
    const typename Simd::V v = Simd::Load(x + i);
    const unsigned at_low = Simd::AtMost(v, low), at_high = Simd::AtLeast(v, high);
    Simd::StoreKept(l + *nl, at_low, v);
    Simd::StoreKept(h + *nh, at_high, v);
    *nl += static_cast<std::size_t>(__builtin_popcount(at_low));
    *nh += static_cast<std::size_t>(__builtin_popcount(at_high));
  }
  GatherBlockPortable(x + i, n - i, lo, hi, l, h, nl, nh);
}

#endif

std::atomic<bool> allow_avx512_gathering{true};  // AllowAvx512Gathering

template <typename T>
void GatherBlock(const T* x, std::size_t n, T lo, T hi, T* l, T* h, std::size_t* nl, std::size_t* nh) {
#if VLT_GATHER_SIMD
  static const bool has_avx512 = __builtin_cpu_supports("avx512f");
  if (has_avx512 && allow_avx512_gathering.load(std::memory_order_relaxed)) {
    return GatherBlockAvx512(x, n, lo, hi, l, h, nl, nh);
  }
#endif
  GatherBlockPortable(x, n, lo, hi, l, h, nl, nh);
}

// `buffer` at least `size` long, its first `kept` values kept: a new one of twice the size (or
// `size`) with those copied, so that the values past the count — uninitialised in the workers'
// buffers (UninitializedAllocator) — are never read.
template <class Buffer>
void GrowKeeping(Buffer& buffer, std::size_t kept, std::size_t size) {
  if (buffer.size() >= size) return;
  Buffer bigger;
  bigger.resize(std::max(2 * buffer.size(), size));
  std::copy(buffer.begin(), buffer.begin() + static_cast<std::ptrdiff_t>(kept), bigger.begin());
  buffer.swap(bigger);
}

// Every value x <= lo appended to lows at *n_low and x >= hi to highs at *n_high, in the values'
// order (GatherBlock); the counts are advanced. The buffers grow a block ahead of the counts.
template <typename T, class Buffer>
void GatherBeyond(std::span<const T> values, T lo, T hi, Buffer& lows, Buffer& highs, std::size_t* n_low,
                  std::size_t* n_high) {
  constexpr std::size_t kBlock = 4096;
  std::size_t nl = *n_low, nh = *n_high;
  for (std::size_t start = 0; start < values.size(); start += kBlock) {
    const std::size_t end = std::min(values.size(), start + kBlock);
    GrowKeeping(lows, nl, nl + kBlock);
    GrowKeeping(highs, nh, nh + kBlock);
    GatherBlock(values.data() + start, end - start, lo, hi, lows.data(), highs.data(), &nl, &nh);
  }
  *n_low = nl;
  *n_high = nh;
}

// GatherBeyond over blocks of kPassChunk of n values as parallel items — block(begin, end, worker)
// gives a block's values — each block's values appended in block order to tails->low_values /
// high_values (the same values as one pass gathers). Each
// worker appends the blocks it runs to its own buffers (uninitialised, grown by doubling: no
// allocation per block, no zeroing); the blocks are then copied out in block order.
template <typename T>
void GatherInBlocks(std::size_t n, const std::function<std::span<const T>(std::size_t, std::size_t, int)>& block,
                    T lo, T hi, int threads, std::size_t guess, Tails<T>* tails, std::size_t* n_low,
                    std::size_t* n_high) {
  using Buffer = std::vector<T, UninitializedAllocator<T>>;
  struct Gathered {
    int worker = 0;
    std::size_t low_at = 0, low_end = 0, high_at = 0, high_end = 0;
  };
  const std::size_t blocks = (n + kPassChunk - 1) / kPassChunk;
  const auto workers = static_cast<std::size_t>(parallel_internal::ResolveThreads(threads));
  std::vector<Buffer> lows(workers), highs(workers);
  for (std::size_t w = 0; w < workers; ++w) {
    lows[w].resize(guess / workers + static_cast<std::size_t>(kPassChunk));
    highs[w].resize(guess / workers + static_cast<std::size_t>(kPassChunk));
  }
  std::vector<std::size_t> used_low(workers, 0), used_high(workers, 0);
  std::vector<Gathered> where(blocks);
  parallel_internal::ForEach(blocks, threads, [&](std::size_t b, int w) {
    const std::size_t begin = b * kPassChunk, end = std::min(n, begin + kPassChunk);
    Gathered& g = where[b];
    g.worker = w;
    g.low_at = g.low_end = used_low[w];
    g.high_at = g.high_end = used_high[w];
    GatherBeyond(block(begin, end, w), lo, hi, lows[w], highs[w], &g.low_end, &g.high_end);
    used_low[w] = g.low_end;
    used_high[w] = g.high_end;
  });
  std::size_t nl = 0, nh = 0;
  for (const Gathered& g : where) nl += g.low_end - g.low_at, nh += g.high_end - g.high_at;
  tails->low_values.clear();
  tails->high_values.clear();
  tails->low_values.reserve(nl);
  tails->high_values.reserve(nh);
  for (const Gathered& g : where) {
    const T* low = lows[g.worker].data();
    const T* high = highs[g.worker].data();
    tails->low_values.insert(tails->low_values.end(), low + g.low_at, low + g.low_end);
    tails->high_values.insert(tails->high_values.end(), high + g.high_at, high + g.high_end);
  }
  *n_low = nl;
  *n_high = nh;
}

// The bin of each of n values (CountHistogram), in lanes: no branch, a division per value that
// the compiler vectorises (AVX-512, AVX2 or baseline clones; a scalar division was most of the
// count's time).
VLT_ARRAY_CLONES
void BinsOf(const float* values, int n, double reference, double low, double width, int bins, int* bin) {
  const double top = static_cast<double>(bins);
  for (int i = 0; i < n; ++i) {
    const double b = (reference + static_cast<double>(values[i]) - low) / width;
    const bool inside = b >= 0.0 && b < top;  // false for NaN
    const int floor_b = static_cast<int>(inside ? b : 0.0);  // truncation = floor for b >= 0
    bin[i] = inside ? floor_b : (b >= 0.0 ? bins + 1 : bins);
  }
}

}  // namespace

void AllowAvx512Gathering(bool allow) { allow_avx512_gathering.store(allow); }

void CountHistogram(std::span<const float> values, double reference, double low, double width, int bins,
                    std::int64_t* cells) {
  constexpr std::size_t kBlock = 1024;
  int bin[kBlock];
  for (std::size_t start = 0; start < values.size(); start += kBlock) {
    const std::size_t n = std::min(kBlock, values.size() - start);
    BinsOf(values.data() + start, static_cast<int>(n), reference, low, width, bins, bin);
    for (std::size_t i = 0; i < n; ++i) ++cells[bin[i]];
  }
}

void SortAscending(std::span<float> values) {
  const std::size_t n = values.size();
  // Below kRadixLeast values a comparison sort is the faster, and beyond 2^32 - 1 the 32-bit
  // counts would overflow; the order is the same, totalOrder being total.
  if (n < kRadixLeast || n > std::numeric_limits<std::uint32_t>::max()) {
    std::sort(values.begin(), values.end(),
              [](float a, float b) { return TotalOrderKey(a) < TotalOrderKey(b); });
    return;
  }
  // The keys: in this thread's buffers, kept for the next sort up to kRadixKept values (the
  // 10^4-trial batches' sorts of a few hundred values, the final tails of a run up to 10^7 trials),
  // freed after a larger sort, which a library user's process would hold otherwise.
  thread_local std::vector<std::uint32_t> kept_keys, kept_spare;
  std::vector<std::uint32_t> keys = std::move(kept_keys), spare = std::move(kept_spare);
  if (n < kRadixWide) {
    RadixSortByTotalOrder<8>(values, keys, spare);
  } else {
    RadixSortByTotalOrder<11>(values, keys, spare);
  }
  if (n <= kRadixKept) {
    kept_keys = std::move(keys);
    kept_spare = std::move(spare);
  }
}

void SortAscending(std::span<double> values) {
  if (hwy::Sorter::HaveFloat64()) {
    ThreadSorter()(values.data(), values.size(), hwy::SortAscending());
  } else {
    std::sort(values.begin(), values.end());
  }
}

namespace {

// The rank in a sorted sample of s of M values beyond which a tail of `tail` values is gathered:
// the tail's expected count in the sample + 6 binomial standard deviations + 8, so that at least
// `tail` values lie beyond it except with a negligible probability (and then the counts catch it).
std::int64_t MarginRank(std::int64_t tail, std::int64_t m, std::int64_t s) {
  const double expected = static_cast<double>(tail) / static_cast<double>(m) * static_cast<double>(s);
  return std::min<std::int64_t>(s / 2 - 1, static_cast<std::int64_t>(expected + 6.0 * std::sqrt(expected) + 8.0));
}

// The sorted strided sample of M values whose ranks set the thresholds: s values (1 in 16, 256 to
// 4096), value_at(i step + step / 2). Returns s.
template <typename T, class ValueAt>
std::int64_t SortedSample(std::int64_t m, const ValueAt& value_at, std::vector<T>& sample) {
  const std::int64_t s = std::clamp<std::int64_t>(m / 16, 256, 4096);
  const std::int64_t step = m / s;
  sample.resize(static_cast<std::size_t>(s));
  for (std::int64_t i = 0; i < s; ++i) sample[static_cast<std::size_t>(i)] = value_at(i * step + step / 2);
  SortAscending(std::span<T>(sample));
  return s;
}

}  // namespace

template <typename T>
void GatherTails(std::span<const T> values, std::int64_t low, std::int64_t high, Tails<T>* tails, int threads) {
  tails->low = low;
  tails->high = high;
  tails->sorted = false;
  const auto m = static_cast<std::int64_t>(values.size());
  std::vector<T>& lows = tails->low_values;
  std::vector<T>& highs = tails->high_values;
  auto from_full_sort = [&] {
    tails->work.assign(values.begin(), values.end());
    SortAscending(std::span<T>(tails->work));
    lows.assign(tails->work.begin(), tails->work.begin() + low);
    highs.assign(tails->work.end() - high, tails->work.end());
    tails->sorted = true;
  };
  if (m < kGatherMin || 4 * (low + high) > m) return from_full_sort();

  // Thresholds: a strided sample of s values (1 in 16, at most 4096), sorted; the low threshold
  // is the sample's k-th smallest, k the tail's expected count in the sample + 6 binomial
  // standard deviations + 8, so that at least `low` values lie at or below it except with a
  // negligible probability (and then the counts below catch it).
  const std::int64_t s =
      SortedSample(m, [&](std::int64_t i) { return values[static_cast<std::size_t>(i)]; }, tails->sample);
  const std::int64_t k_low = MarginRank(low, m, s), k_high = MarginRank(high, m, s);
  constexpr T kInf = std::numeric_limits<T>::infinity();
  const T lo = low > 0 ? tails->sample[k_low] : -kInf;           // gather x <= lo
  const T hi = high > 0 ? tails->sample[s - 1 - k_high] : kInf;  // gather x >= hi

  std::size_t n_low = 0, n_high = 0;
  const std::size_t guess =
      static_cast<std::size_t>(m / s) * static_cast<std::size_t>(std::max(k_low, k_high) + 1);
  if (threads > 1 && m > 2 * kPassChunk) {
    auto block = [&](std::size_t begin, std::size_t end, int) { return values.subspan(begin, end - begin); };
    GatherInBlocks<T>(values.size(), block, lo, hi, threads, guess, tails, &n_low, &n_high);
  } else {
    lows.resize(guess);
    highs.resize(guess);
    GatherBeyond(values, lo, hi, lows, highs, &n_low, &n_high);
  }
  // The gathered values are every value <= lo (>= hi), so once there are enough of them their
  // smallest (largest) are exactly the tail, ties included.
  if (static_cast<std::int64_t>(n_low) < low || static_cast<std::int64_t>(n_high) < high)
    return from_full_sort();
  lows.resize(n_low);
  highs.resize(n_high);
}

template <typename T>
void FinishTail(Tails<T>* tails, int which) {
  if (tails->sorted) return;  // sorted in full by GatherTails
  if (which == 0) {
    SortAscending(std::span<T>(tails->low_values));
    tails->low_values.resize(static_cast<std::size_t>(tails->low));
  } else {
    std::vector<T>& highs = tails->high_values;
    SortAscending(std::span<T>(highs));
    highs.erase(highs.begin(), highs.end() - tails->high);
  }
}

bool GatherHighTail(std::int64_t m, std::int64_t high,
                    const std::function<void(std::int64_t begin, std::int64_t end, double* out)>& fill, int threads,
                    Tails<double>* tails) {
  tails->low = 0;
  tails->high = high;
  tails->sorted = false;
  if (m < kGatherMin || 4 * high > m) return false;
  // The threshold from the strided sample, and the pass in blocks, as GatherTails; each block
  // filled into its worker's buffer (kPassChunk values, zeroed once) first.
  auto value_at = [&](std::int64_t i) {
    double x;
    fill(i, i + 1, &x);
    return x;
  };
  const std::int64_t s = SortedSample(m, value_at, tails->sample);
  const std::int64_t k_high = MarginRank(high, m, s);
  const double hi = tails->sample[static_cast<std::size_t>(s - 1 - k_high)];
  const auto workers = static_cast<std::size_t>(parallel_internal::ResolveThreads(threads));
  std::vector<std::vector<double>> buffers(workers, std::vector<double>(static_cast<std::size_t>(kPassChunk)));
  auto block = [&](std::size_t begin, std::size_t end, int w) {
    fill(static_cast<std::int64_t>(begin), static_cast<std::int64_t>(end), buffers[w].data());
    return std::span<const double>(buffers[w].data(), end - begin);
  };
  std::size_t no_low = 0, count = 0;
  const std::size_t guess = static_cast<std::size_t>(m / s) * static_cast<std::size_t>(k_high + 1);
  GatherInBlocks<double>(static_cast<std::size_t>(m), block, -std::numeric_limits<double>::infinity(), hi,
                         threads, guess, tails, &no_low, &count);
  return static_cast<std::int64_t>(count) >= high;
}

template <typename T>
T SmallestOfHighTail(Tails<T>* tails) {
  std::vector<T>& highs = tails->high_values;
  if (tails->sorted) return highs.front();  // the exact tail, sorted by GatherTails
  // Every value >= the threshold was gathered, at least `high` of them: the `high` largest of all
  // are the `high` largest gathered, and the smallest of those is the gathered (n - high)-th.
  const auto k = static_cast<std::ptrdiff_t>(highs.size()) - static_cast<std::ptrdiff_t>(tails->high);
  std::nth_element(highs.begin(), highs.begin() + k, highs.end());
  return highs[static_cast<std::size_t>(k)];
}

template <typename T>
void SortedTails(std::span<const T> values, std::int64_t low, std::int64_t high, Tails<T>* tails, int threads) {
  GatherTails(values, low, high, tails, threads);
  FinishTail(tails, 0);
  FinishTail(tails, 1);
}

template void SortedTails<float>(std::span<const float>, std::int64_t, std::int64_t, Tails<float>*, int);
template void SortedTails<double>(std::span<const double>, std::int64_t, std::int64_t, Tails<double>*, int);
template void GatherTails<float>(std::span<const float>, std::int64_t, std::int64_t, Tails<float>*, int);
template void GatherTails<double>(std::span<const double>, std::int64_t, std::int64_t, Tails<double>*, int);
template void FinishTail<float>(Tails<float>*, int);
template float SmallestOfHighTail<float>(Tails<float>*);
template double SmallestOfHighTail<double>(Tails<double>*);
template void FinishTail<double>(Tails<double>*, int);

}  // namespace vlt::mcm_internal
