// mcm/intervals.cc — coverage intervals from order statistics (JCGM 101 7.7) and the numerical
// tolerance (7.9.2).
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "mcm/engine.h"
#include "mcm/order.h"
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
  const std::int64_t q = std::abs(pm - nearest) <= slack ? static_cast<std::int64_t>(nearest)
                                                         : static_cast<std::int64_t>(std::floor(pm + 0.5));
  if (m - q < 1) {
    throw InputError("Monte Carlo: " + std::to_string(m) +
                     " trials are too few for coverage "
                     "probability " +
                     std::to_string(p) + " (need M - pM >= 1)");
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

template <typename T>
void GatherIntervalTails(std::span<const T> values, double p, int threads, Tails<T>* tails) {
  const auto m = static_cast<std::int64_t>(values.size());
  const std::int64_t tail = m - CoverageCount(m, p);
  GatherTails(values, tail, tail, tails, threads);
}

template void GatherIntervalTails<float>(std::span<const float>, double, int, Tails<float>*);
template void GatherIntervalTails<double>(std::span<const double>, double, int, Tails<double>*);

namespace {

// The first r in 1..n of the least width high[r - 1] - low[r - 1] (for q > M - q, y_(r+q) is
// high_values[r - 1] and y_(r) low_values[r - 1]): the least width first, in eight lanes the
// compiler vectorises (a minimum is exact in any order), then the first r that has it — the r of
// the scan that keeps the first strictly smaller width.
template <typename T>
std::int64_t NarrowestPair(const T* low, const T* high, std::int64_t n) {
  constexpr int kLanes = 8;
  double least[kLanes];
  for (double& l : least) l = std::numeric_limits<double>::infinity();
  std::int64_t i = 0;
  for (; i + kLanes <= n; i += kLanes) {
    for (int j = 0; j < kLanes; ++j) {
      const double w = static_cast<double>(high[i + j]) - static_cast<double>(low[i + j]);
      least[j] = w < least[j] ? w : least[j];
    }
  }
  double min = least[0];
  for (int j = 1; j < kLanes; ++j) min = least[j] < min ? least[j] : min;
  for (; i < n; ++i) {
    const double w = static_cast<double>(high[i]) - static_cast<double>(low[i]);
    min = w < min ? w : min;
  }
  for (std::int64_t r = 0; r < n; ++r) {
    if (static_cast<double>(high[r]) - static_cast<double>(low[r]) == min) return r + 1;
  }
  return 1;
}

// The same scan in order-statistic terms, for q <= M - q (p <= 1/2, where y_(r+q) may lie in the
// low tail).
template <typename Order>
std::int64_t NarrowestRByOrder(const Order& order, std::int64_t q, std::int64_t n) {
  std::int64_t best = 1;
  for (std::int64_t k = 2; k <= n; ++k) {
    if (static_cast<double>(order(k + q)) - static_cast<double>(order(k)) <
        static_cast<double>(order(best + q)) - static_cast<double>(order(best))) {
      best = k;
    }
  }
  return best;
}

// The probabilistically symmetric interval (JCGM 101 7.7.1) from the sorted tails.
template <typename T>
CoverageInterval SymmetricFromTailsOf(const Tails<T>& tails, std::int64_t m, double reference, double p) {
  const std::int64_t q = CoverageCount(m, p);
  const std::int64_t r = SymmetricR(m, q);
  const std::int64_t tail = m - q;
  auto y = [&](std::int64_t k) {
    return reference + static_cast<double>(k <= tail ? tails.low_values[k - 1] : tails.high_values[k - q - 1]);
  };
  return {y(r), y(r + q)};
}

// The endpoints of both intervals from the sorted tails y_(1..M-q) and y_(q+1..M) of M values.
template <typename T>
void IntervalsFromTailsOf(const Tails<T>& tails, std::int64_t m, double reference, double p,
                          CoverageInterval* symmetric, CoverageInterval* shortest) {
  const std::int64_t q = CoverageCount(m, p);
  const std::int64_t tail = m - q;  // the shortest interval's r ranges over 1..M-q
  // The k-th smallest value (1-based) for k <= M - q or k >= q + 1.
  auto order = [&](std::int64_t k) -> T {
    return k <= tail ? tails.low_values[k - 1] : tails.high_values[k - q - 1];
  };
  auto y = [&](std::int64_t k) { return reference + static_cast<double>(order(k)); };
  *symmetric = SymmetricFromTailsOf(tails, m, reference, p);
  // The first r of the least width y_(r+q) - y_(r), widths compared in the stored type's precision
  // converted to double (exact for float).
  const std::int64_t best = q > tail ? NarrowestPair(tails.low_values.data(), tails.high_values.data(), tail)
                                     : NarrowestRByOrder(order, q, tail);
  *shortest = {y(best), y(best + q)};
}

template <typename T>
void CoverageIntervalsOf(std::span<const T> values, double reference, double p, CoverageInterval* symmetric,
                         CoverageInterval* shortest, int threads) {
  // Only y_(1..M-q) and y_(q+1..M) are needed: every endpoint is in these tails (r <= M - q,
  // r + q >= q + 1), which SortedTails sorts without sorting the middle.
  Tails<T> tails;
  GatherIntervalTails(values, p, threads, &tails);
  FinishTail(&tails, 0);
  FinishTail(&tails, 1);
  IntervalsFromTailsOf(tails, static_cast<std::int64_t>(values.size()), reference, p, symmetric, shortest);
}

}  // namespace

void IntervalsFromTails(const Tails<float>& tails, std::int64_t m, double reference, double p,
                        CoverageInterval* symmetric, CoverageInterval* shortest) {
  IntervalsFromTailsOf(tails, m, reference, p, symmetric, shortest);
}

// Hill, Ann. Statist. 3 (1975) 1163: for P(X > x) ~ x^-alpha the mean of ln(X_(i) / X_(k+1)) over
// the k largest is 1 / alpha, its standard error alpha / sqrt(k). Measured from the centre of the
// 95 % interval, not from 0: the estimate must not depend on where the output lies. At one
// fraction the estimator is biased low for tails that are heavy but not a power (a lognormal with
// sigma = 1.5 gives 1.8 at 0.5 %): infinite variance is said only when the estimates at 0.5 %,
// 0.1 % and 0.02 % of the values all lie below 2 (a power tail is flat across them; those tails
// rise: 1.8, 2.3, 2.6).
TailIndexEstimate EstimateTailIndex(const Tails<float>& tails, std::int64_t m, double centre) {
  TailIndexEstimate estimate;
  const auto held = static_cast<std::int64_t>(std::min(tails.low_values.size(), tails.high_values.size()));
  const std::int64_t k1 =
      std::min(static_cast<std::int64_t>(kTailIndexFraction * static_cast<double>(m)), held - 1);
  if (k1 < kTailIndexMinimumCount) return estimate;
  // The index of both tails from their k most extreme values (the smaller), or infinity for
  // bounded tails.
  auto index = [&](std::int64_t k) {
    auto hill = [&](auto x) {
      const double threshold = x(k);
      if (!(threshold > 0.0)) return std::numeric_limits<double>::infinity();
      double sum = 0.0;
      for (std::int64_t i = 0; i < k; ++i) sum += std::log(x(i) / threshold);
      return sum > 0.0 ? static_cast<double>(k) / sum : std::numeric_limits<double>::infinity();
    };
    const auto& high = tails.high_values;
    const auto& low = tails.low_values;
    return std::min(
        hill([&](std::int64_t i) { return static_cast<double>(high[high.size() - 1 - i]) - centre; }),
        hill([&](std::int64_t i) { return centre - static_cast<double>(low[i]); }));
  };
  // Below 2 by two standard errors alpha / sqrt(k).
  auto below_two = [](double alpha, std::int64_t k) {
    return alpha * (1.0 + 2.0 / std::sqrt(static_cast<double>(k))) < 2.0;
  };
  estimate.index = index(k1);
  const std::int64_t k2 = k1 / 5, k3 = k1 / 25;
  estimate.decided = k3 >= kTailIndexMinimumCount;
  estimate.infinite_variance = estimate.decided && below_two(*estimate.index, k1) &&
                               below_two(index(k2), k2) && below_two(index(k3), k3);
  return estimate;
}

void SetTailIndex(const Tails<float>& tails, std::int64_t m, double reference, double p, McmOutputResult& out) {
  const CoverageInterval symmetric = SymmetricFromTailsOf(tails, m, reference, p);
  const double centre = 0.5 * (symmetric.low + symmetric.high) - reference;
  const TailIndexEstimate estimate = EstimateTailIndex(tails, m, centre);
  out.tail_index = estimate.index;
  out.infinite_variance = estimate.infinite_variance;
}

void IntervalsAndTailIndex(std::span<const float> values, double reference, double p, McmOutputResult& out) {
  Tails<float> tails;
  GatherIntervalTails(values, p, 1, &tails);
  FinishTail(&tails, 0);
  FinishTail(&tails, 1);
  const auto m = static_cast<std::int64_t>(values.size());
  IntervalsFromTailsOf(tails, m, reference, p, &out.symmetric, &out.shortest);
  SetTailIndex(tails, m, reference, p, out);
}

void CoverageIntervals(std::span<const float> values, double reference, double p, CoverageInterval* symmetric,
                       CoverageInterval* shortest, int threads) {
  CoverageIntervalsOf(values, reference, p, symmetric, shortest, threads);
}

void CoverageIntervals(std::span<const double> values, double reference, double p,
                       CoverageInterval* symmetric, CoverageInterval* shortest, int threads) {
  CoverageIntervalsOf(values, reference, p, symmetric, shortest, threads);
}

}  // namespace mcm_internal
}  // namespace vlt
