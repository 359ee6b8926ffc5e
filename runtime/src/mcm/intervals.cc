// mcm/intervals.cc — coverage intervals from order statistics (JCGM 101 7.7) and the numerical
// tolerance (7.9.2).
#include <algorithm>
#include <cmath>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include "mcm/engine.h"
#include "vlt/error.h"
#include "vlt/mcm.h"

namespace vlt {

std::int64_t CoverageCount(std::int64_t m, double p) {
  if (!(p > 0.0 && p < 1.0)) {
    throw InputError("coverage probability must be in (0, 1), got " + std::to_string(p));
  }
  // 7.7.1: q = pM if pM is an integer, else the integer part of pM + 1/2. A few ulp of slack so
  // that a decimal p (0.95 is not a binary fraction) with pM "integer" gives that integer.
  const double pm = p * static_cast<double>(m);
  const double slack = 8.0 * std::numeric_limits<double>::epsilon() * pm;
  const double nearest = std::round(pm);
  const std::int64_t q = std::abs(pm - nearest) <= slack
                             ? static_cast<std::int64_t>(nearest)
                             : static_cast<std::int64_t>(std::floor(pm + 0.5));
  if (m - q < 1) {
    throw InputError("Monte Carlo: " + std::to_string(m) + " trials are too few for coverage "
                     "probability " + std::to_string(p) + " (need M - pM >= 1)");
  }
  return q;
}

namespace {
// r of the probabilistically symmetric interval (1-based): (M - q)/2 or (M - q + 1)/2.
std::int64_t SymmetricR(std::int64_t m, std::int64_t q) {
  return (m - q) % 2 == 0 ? (m - q) / 2 : (m - q + 1) / 2;
}
}  // namespace

CoverageInterval SymmetricCoverageInterval(std::span<const double> sorted, double p) {
  const auto m = static_cast<std::int64_t>(sorted.size());
  const std::int64_t q = CoverageCount(m, p);
  const std::int64_t r = SymmetricR(m, q);
  return {sorted[r - 1], sorted[r + q - 1]};
}

CoverageInterval ShortestCoverageInterval(std::span<const double> sorted, double p) {
  const auto m = static_cast<std::int64_t>(sorted.size());
  const std::int64_t q = CoverageCount(m, p);
  std::int64_t best = 1;
  for (std::int64_t r = 2; r <= m - q; ++r) {
    if (sorted[r + q - 1] - sorted[r - 1] < sorted[best + q - 1] - sorted[best - 1]) best = r;
  }
  return {sorted[best - 1], sorted[best + q - 1]};
}

double NumericalTolerance(double u, int significant_digits) {
  if (!(u > 0.0) || !std::isfinite(u)) return 0.0;
  // u = c x 10^l, c an integer of n_dig digits after rounding (7.9.2); delta = 10^l / 2.
  int l = static_cast<int>(std::floor(std::log10(u))) - significant_digits + 1;
  const double lower = std::pow(10.0, significant_digits - 1);
  const double upper = std::pow(10.0, significant_digits);
  for (int guard = 0; guard < 4; ++guard) {
    const double c = std::round(u / std::pow(10.0, l));
    if (c >= upper) {
      ++l;
    } else if (c < lower) {
      --l;
    } else {
      break;
    }
  }
  return 0.5 * std::pow(10.0, l);
}

namespace mcm_internal {

namespace {

// Runs from which the one-pass tail extraction pays off (below: selection in place).
constexpr std::int64_t kTailPassMin = 20'000;

// The order statistics of both tails without selecting over all M values: thresholds lo, hi
// from a strided sample of 4096 values, chosen a wide margin (6 binomial standard deviations +
// 8) beyond the tail fractions; one pass copies every value <= lo into `low` and every value
// >= hi into `high`. `low` then holds exactly the count(<= lo) smallest values and `high` the
// count(>= hi) largest (ties included), so once the counts are checked (low >= M - q values,
// high >= M - q values) sorting their ends gives y_(1..M-q) and y_(q+1..M) exactly, whatever the
// sample was. Returns false when a count is short (then the caller selects in place).
template <typename T>
bool SortedTails(std::span<const T> values, std::int64_t tail, std::int64_t q,
                 std::vector<T>* low, std::vector<T>* high) {
  const auto m = static_cast<std::int64_t>(values.size());
  constexpr std::int64_t kSample = 4096;
  const std::int64_t step = m / kSample;
  std::vector<T> sample(static_cast<std::size_t>(kSample));
  for (std::int64_t i = 0; i < kSample; ++i) sample[i] = values[i * step + step / 2];
  const double expected = static_cast<double>(tail) / static_cast<double>(m) * kSample;
  const auto k = std::min<std::int64_t>(
      kSample / 2 - 1, static_cast<std::int64_t>(expected + 6.0 * std::sqrt(expected) + 8.0));
  std::nth_element(sample.begin(), sample.begin() + k, sample.end());
  const T lo = sample[k];
  std::nth_element(sample.begin(), sample.begin() + (kSample - 1 - k), sample.end());
  const T hi = sample[kSample - 1 - k];
  low->clear();
  high->clear();
  const auto reserve = static_cast<std::size_t>(2 * (k + 1) * (m / kSample + 1));
  low->reserve(reserve);
  high->reserve(reserve);
  for (const T x : values) {
    if (x <= lo) low->push_back(x);
    if (x >= hi) high->push_back(x);
  }
  const auto h = static_cast<std::int64_t>(high->size());
  if (static_cast<std::int64_t>(low->size()) < tail || h < m - q) return false;
  std::nth_element(low->begin(), low->begin() + (tail - 1), low->end());
  std::sort(low->begin(), low->begin() + tail);
  const std::int64_t first_upper = q - (m - h);   // index in `high` of y_(q+1)
  std::nth_element(high->begin(), high->begin() + first_upper, high->end());
  std::sort(high->begin() + first_upper, high->end());
  return true;
}

template <typename T>
void CoverageIntervalsOf(std::span<const T> values, double reference, double p, CoverageInterval* symmetric,
                         CoverageInterval* shortest) {
  const auto m = static_cast<std::int64_t>(values.size());
  const std::int64_t q = CoverageCount(m, p);
  const std::int64_t r = SymmetricR(m, q);
  const std::int64_t tail = m - q;  // the shortest interval's r ranges over 1..M-q
  // Only y_(1..M-q) and y_(q+1..M) are needed: the endpoints below are all in these tails.
  std::vector<T> low, high, work;
  const bool from_tails =
      m >= kTailPassMin && 2 * tail < m && SortedTails<T>(values, tail, q, &low, &high);
  const std::int64_t upper_offset = m - static_cast<std::int64_t>(high.size());
  // The k-th smallest value (1-based) for k <= M - q or k >= q + 1.
  auto order = [&](std::int64_t k) -> T {
    if (!from_tails) return work[k - 1];
    return k <= tail ? low[k - 1] : high[k - upper_offset - 1];
  };
  if (!from_tails) {
    // Selection on a copy: the values stay in place for other readers (the engine's final pass
    // reads every output's values from several threads at once).
    work.assign(values.begin(), values.end());
    if (2 * tail >= m) {
      std::sort(work.begin(), work.end());
    } else {
      // Lower tail y_(1..M-q) and upper tail y_(q+1..M) in order; the middle is only partitioned.
      std::nth_element(work.begin(), work.begin() + (tail - 1), work.end());
      std::sort(work.begin(), work.begin() + tail);
      std::nth_element(work.begin() + tail, work.begin() + q, work.end());
      std::sort(work.begin() + q, work.end());
    }
  }
  auto y = [&](std::int64_t k) { return reference + static_cast<double>(order(k)); };
  // r <= M - q and r + q >= q + 1: both endpoints are in the sorted tails.
  *symmetric = {y(r), y(r + q)};
  std::int64_t best = 1;
  // Compare widths in the stored type's precision converted to double (exact for float).
  for (std::int64_t k = 2; k <= tail; ++k) {
    if (static_cast<double>(order(k + q)) - static_cast<double>(order(k)) <
        static_cast<double>(order(best + q)) - static_cast<double>(order(best))) {
      best = k;
    }
  }
  *shortest = {y(best), y(best + q)};
}

}  // namespace

void CoverageIntervals(std::span<const float> values, double reference, double p, CoverageInterval* symmetric,
                       CoverageInterval* shortest) {
  CoverageIntervalsOf(values, reference, p, symmetric, shortest);
}

void CoverageIntervals(std::span<const double> values, double reference, double p, CoverageInterval* symmetric,
                       CoverageInterval* shortest) {
  CoverageIntervalsOf(values, reference, p, symmetric, shortest);
}

}  // namespace mcm_internal
}  // namespace vlt
