// Large result arrays paged in side by side.
//
// Why: a scan's records of 10^6 points (384 MB of PointResult, 144 MB of JobPoint, 48 MB of
// PointUncertainty per block of 65 536) are fresh memory; the kernel maps and zeroes each page on
// its first touch, and a std::vector constructs its elements on one thread, so that touch is
// serial: 0.24 s for the PointResult records alone on the 2-core machine, about a tenth of what
// stayed serial in a 10^6-point scan (docs/performance.md 4.2, issue 33). Here the pages are
// mapped first, in parallel, without touching them (Linux MADV_POPULATE_WRITE, kernel 5.14+);
// the elements are then constructed in memory already mapped (0.24 s -> 0.07 + 0.02 s on two
// threads). No value depends on it: where the kernel lacks it, nothing is done.
#pragma once

#include <cstddef>
#include <vector>

namespace vlt::parallel_internal {

// Maps the whole pages of [begin, begin + bytes) for writing, side by side on `threads` threads
// (0: all), in 128 items (8 for each of 16 threads). Below 8 MiB it does nothing: the serial
// touch is then short. Never fails: a kernel without MADV_POPULATE_WRITE leaves the pages to be
// mapped on first touch, as without this call.
void MapPages(void* begin, std::size_t bytes, int threads);

// Reserves room for n elements in v and maps the pages past its present elements (MapPages):
// construct them next (resize, emplace_back), in memory already mapped.
template <typename T>
void ReserveMapped(std::vector<T>& v, std::size_t n, int threads) {
  if (n <= v.size()) return;
  v.reserve(n);
  MapPages(v.data() + v.size(), (n - v.size()) * sizeof(T), threads);
}

}  // namespace vlt::parallel_internal
