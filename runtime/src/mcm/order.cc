// mcm/order.cc — order statistics of stored Monte Carlo values (order.h).
#include "mcm/order.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <span>
#include <vector>

#include <hwy/contrib/sort/vqsort.h>

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

// Below this many values, or with tails longer than a quarter of them, a copy of every value is
// sorted: the gathering pass would not pay off.
constexpr std::int64_t kGatherMin = 4096;

// Every value x <= lo into lows[0, *n_low) and x >= hi into highs[0, *n_high), in the values'
// order, in one branch-free pass: every value is written to both buffers and kept (the count
// advanced) when it lies beyond its threshold. The buffers start at `guess` and grow a block
// ahead of the counts.
template <typename T>
void GatherBeyond(std::span<const T> values, T lo, T hi, std::size_t guess, std::vector<T>& lows,
                  std::vector<T>& highs, std::size_t* n_low, std::size_t* n_high) {
  constexpr std::size_t kBlock = 4096;
  std::size_t nl = 0, nh = 0;
  lows.resize(guess + kBlock);
  highs.resize(guess + kBlock);
  const T* x = values.data();
  for (std::size_t start = 0; start < values.size(); start += kBlock) {
    const std::size_t end = std::min(values.size(), start + kBlock);
    if (lows.size() < nl + kBlock) lows.resize(2 * lows.size());
    if (highs.size() < nh + kBlock) highs.resize(2 * highs.size());
    T* l = lows.data();
    T* h = highs.data();
    for (std::size_t i = start; i < end; ++i) {
      const T v = x[i];
      l[nl] = v;
      nl += v <= lo ? 1 : 0;
      h[nh] = v;
      nh += v >= hi ? 1 : 0;
    }
  }
  *n_low = nl;
  *n_high = nh;
}

// GatherBeyond over blocks of kPassChunk values as parallel items, each block's values appended
// in block order to tails->low_values / high_values (the same values as one pass gathers).
template <typename T>
void GatherInBlocks(std::span<const T> values, T lo, T hi, int threads, Tails<T>* tails, std::size_t* n_low,
                    std::size_t* n_high) {
  const std::size_t n = values.size();
  const std::size_t blocks = (n + kPassChunk - 1) / kPassChunk;
  std::vector<std::vector<T>> block_lows(blocks), block_highs(blocks);
  std::vector<std::size_t> counts(2 * blocks);
  // Each worker gathers into its own buffers (one block long); a block keeps only what it gathered.
  const auto workers = static_cast<std::size_t>(parallel_internal::ResolveThreads(threads));
  std::vector<std::vector<T>> scratch_lows(workers), scratch_highs(workers);
  parallel_internal::ForEach(blocks, threads, [&](std::size_t b, int w) {
    const std::size_t begin = b * kPassChunk, end = std::min(n, begin + kPassChunk);
    std::size_t nl = 0, nh = 0;
    GatherBeyond(values.subspan(begin, end - begin), lo, hi, 0, scratch_lows[w], scratch_highs[w], &nl, &nh);
    block_lows[b].assign(scratch_lows[w].begin(), scratch_lows[w].begin() + static_cast<std::ptrdiff_t>(nl));
    block_highs[b].assign(scratch_highs[w].begin(), scratch_highs[w].begin() + static_cast<std::ptrdiff_t>(nh));
    counts[2 * b] = nl;
    counts[2 * b + 1] = nh;
  });
  std::size_t nl = 0, nh = 0;
  for (std::size_t b = 0; b < blocks; ++b) nl += counts[2 * b], nh += counts[2 * b + 1];
  tails->low_values.resize(nl);
  tails->high_values.resize(nh);
  nl = nh = 0;
  for (std::size_t b = 0; b < blocks; ++b) {
    std::copy_n(block_lows[b].begin(), counts[2 * b], tails->low_values.begin() + static_cast<std::ptrdiff_t>(nl));
    std::copy_n(block_highs[b].begin(), counts[2 * b + 1], tails->high_values.begin() + static_cast<std::ptrdiff_t>(nh));
    nl += counts[2 * b];
    nh += counts[2 * b + 1];
  }
  *n_low = nl;
  *n_high = nh;
}

}  // namespace

void SortAscending(std::span<float> values) {
  ThreadSorter()(values.data(), values.size(), hwy::SortAscending());
}

void SortAscending(std::span<double> values) {
  if (hwy::Sorter::HaveFloat64()) {
    ThreadSorter()(values.data(), values.size(), hwy::SortAscending());
  } else {
    std::sort(values.begin(), values.end());
  }
}

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
  const std::int64_t s = std::clamp<std::int64_t>(m / 16, 256, 4096);
  const std::int64_t step = m / s;
  tails->sample.resize(static_cast<std::size_t>(s));
  for (std::int64_t i = 0; i < s; ++i) tails->sample[i] = values[i * step + step / 2];
  SortAscending(std::span<T>(tails->sample));
  auto margin_rank = [&](std::int64_t tail) {
    const double expected = static_cast<double>(tail) / static_cast<double>(m) * static_cast<double>(s);
    return std::min<std::int64_t>(s / 2 - 1,
                                  static_cast<std::int64_t>(expected + 6.0 * std::sqrt(expected) + 8.0));
  };
  const std::int64_t k_low = margin_rank(low), k_high = margin_rank(high);
  constexpr T kInf = std::numeric_limits<T>::infinity();
  const T lo = low > 0 ? tails->sample[k_low] : -kInf;           // gather x <= lo
  const T hi = high > 0 ? tails->sample[s - 1 - k_high] : kInf;  // gather x >= hi

  std::size_t n_low = 0, n_high = 0;
  if (threads > 1 && m > 2 * kPassChunk) {
    GatherInBlocks(values, lo, hi, threads, tails, &n_low, &n_high);
  } else {
    const std::size_t guess =
        static_cast<std::size_t>(m / s) * static_cast<std::size_t>(std::max(k_low, k_high) + 1);
    GatherBeyond(values, lo, hi, guess, lows, highs, &n_low, &n_high);
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
template void FinishTail<double>(Tails<double>*, int);

}  // namespace vlt::mcm_internal
