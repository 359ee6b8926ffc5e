// mcm/order.h — order statistics of the stored values of a Monte Carlo run (internal): the
// endpoints of the coverage intervals (JCGM 101 7.7), the per-batch endpoints of the adaptive
// procedure (7.9.4) and the coverage factor of the region (JCGM 102 7.7.3) are all order
// statistics in a tail of M values. Exact: the same values as a full sort, whatever the algorithm
// (and so the same for any number of threads).
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <vector>

namespace vlt::mcm_internal {

// Sorts ascending. Floats: an LSD radix sort of their IEEE 754 totalOrder keys (-0 before +0; the
// same order on every processor, mcm/order.cc says why not Highway's here); doubles: Highway's
// vectorised quicksort (hwy::Sorter, Debian libhwy-dev; one sorter per thread). Values must not
// be NaN.
void SortAscending(std::span<float> values);
void SortAscending(std::span<double> values);

// The `low` smallest and the `high` largest of a set of values, each in ascending order:
// low_values[k - 1] is y_(k) (k <= low) and high_values[j] is y_(M - high + 1 + j).
template <typename T>
struct Tails {
  std::vector<T> low_values, high_values;
  std::vector<T> sample, work;  // reused between calls
  std::int64_t low = 0, high = 0;  // the tails' lengths asked for
  bool sorted = false;             // GatherTails sorted every value (no FinishTail needed)
};

// Fills tails->low_values / high_values for `values` (finite; low + high <= M). For a large M
// with short tails it reads the values once: thresholds from a strided sample, chosen a wide
// margin beyond the tail fractions, and every value beyond a threshold gathered (branch-free);
// then only the gathered values are sorted. A count short of its tail (a sample that misled)
// falls back to sorting a copy of every value, so the result is exact in every case.
// threads > 1: the gathering pass runs in blocks of kPassChunk values on the process's workers
// (inline when called from inside a parallel item); the gathered values, sorted, are the same.
template <typename T>
void SortedTails(std::span<const T> values, std::int64_t low, std::int64_t high, Tails<T>* tails,
                 int threads = 1);

// SortedTails in two steps, so that the sorts of several series can run side by side (the
// engine's final pass): GatherTails leaves in low_values / high_values every value beyond the
// thresholds, unsorted (or the exact tails, `sorted`, when it sorted every value); FinishTail(0)
// and FinishTail(1), which may run on different threads, then sort and trim the low and the high
// tail. The result is SortedTails's.
template <typename T>
void GatherTails(std::span<const T> values, std::int64_t low, std::int64_t high, Tails<T>* tails, int threads);
template <typename T>
void FinishTail(Tails<T>* tails, int which);

// GatherTails's high tail (low = 0) of m values that `fill(begin, end, out)` computes into
// out[0, end - begin) on demand, one block of kPassChunk values at a time on each worker, instead
// of read from an array of m values (the coverage region's distances: no array of 8 M bytes,
// whose fresh pages the threads would fault at once). The sample's values are filled one by one.
// Returns false, leaving the tail unusable, where GatherTails would have sorted every value (a
// small m, a long tail) or a count fell short: the caller then fills an array and calls
// GatherTails.
bool GatherHighTail(std::int64_t m, std::int64_t high,
                    const std::function<void(std::int64_t begin, std::int64_t end, double* out)>& fill, int threads,
                    Tails<double>* tails);

// The smallest of the `high` largest values, from GatherTails's gathered values without sorting
// them: a selection (std::nth_element) — FinishTail(tails, 1) followed by high_values.front(), in
// linear time (the coverage region's k_p, JCGM 102 7.7.3, is this one order statistic).
template <typename T>
T SmallestOfHighTail(Tails<T>* tails);

// Whether the gathering pass of GatherTails may use AVX-512 where the processor has it (the
// default). Tests turn it off to check that the portable loop gathers the same values.
void AllowAvx512Gathering(bool allow);

// Adds the histogram counts of `values` to cells[0, bins + 2): value v falls in bin floor(b),
// b = ((reference + v) - low) / width, into cells[bins] (below) for b < 0 or NaN and into
// cells[bins + 1] (above) for b >= bins. The b of a block are computed in SIMD lanes (the same
// IEEE operations, so the same bins), then counted.
void CountHistogram(std::span<const float> values, double reference, double low, double width, int bins,
                    std::int64_t* cells);

}  // namespace vlt::mcm_internal
