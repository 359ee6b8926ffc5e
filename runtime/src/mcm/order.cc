// mcm/order.cc — order statistics of stored Monte Carlo values (order.h).
#include "mcm/order.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>

#include <hwy/contrib/sort/vqsort.h>

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
void SortedTails(std::span<const T> values, std::int64_t low, std::int64_t high, Tails<T>* tails) {
  const auto m = static_cast<std::int64_t>(values.size());
  std::vector<T>& lows = tails->low_values;
  std::vector<T>& highs = tails->high_values;
  auto from_full_sort = [&] {
    tails->work.assign(values.begin(), values.end());
    SortAscending(std::span<T>(tails->work));
    lows.assign(tails->work.begin(), tails->work.begin() + low);
    highs.assign(tails->work.end() - high, tails->work.end());
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

  // One pass, branch-free: every value is written to both buffers and kept (the count advanced)
  // when it lies beyond the threshold. The buffers grow a block ahead of the counts.
  constexpr std::size_t kBlock = 4096;
  std::size_t n_low = 0, n_high = 0;
  const std::size_t guess =
      static_cast<std::size_t>(m / s) * static_cast<std::size_t>(std::max(k_low, k_high) + 1);
  lows.resize(guess + kBlock);
  highs.resize(guess + kBlock);
  const T* x = values.data();
  for (std::size_t start = 0; start < values.size(); start += kBlock) {
    const std::size_t end = std::min(values.size(), start + kBlock);
    if (lows.size() < n_low + kBlock) lows.resize(2 * lows.size());
    if (highs.size() < n_high + kBlock) highs.resize(2 * highs.size());
    T* l = lows.data();
    T* h = highs.data();
    for (std::size_t i = start; i < end; ++i) {
      const T v = x[i];
      l[n_low] = v;
      n_low += v <= lo ? 1 : 0;
      h[n_high] = v;
      n_high += v >= hi ? 1 : 0;
    }
  }
  // The gathered values are every value <= lo (>= hi), so once there are enough of them their
  // smallest (largest) are exactly the tail, ties included.
  if (static_cast<std::int64_t>(n_low) < low || static_cast<std::int64_t>(n_high) < high)
    return from_full_sort();
  lows.resize(n_low);
  SortAscending(std::span<T>(lows));
  lows.resize(static_cast<std::size_t>(low));
  highs.resize(n_high);
  SortAscending(std::span<T>(highs));
  highs.erase(highs.begin(), highs.end() - high);
}

template void SortedTails<float>(std::span<const float>, std::int64_t, std::int64_t, Tails<float>*);
template void SortedTails<double>(std::span<const double>, std::int64_t, std::int64_t, Tails<double>*);

}  // namespace vlt::mcm_internal
