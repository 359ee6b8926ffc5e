// stats/log_gamma.h — ln Γ(x) for the statistics of stats/, callable from several threads at once.
// std::lgamma (C's lgamma) stores the sign of Γ(x) in the global `signgam`: POSIX lets it be not
// thread-safe, and ThreadSanitizer found the race when a run's writers computed coverage factors
// (ChiSquareCdf) on several threads. lgamma_r (glibc, POSIX.1-2024) returns the sign through its
// argument instead; its value is lgamma's (one implementation).
#pragma once

#include <math.h>

namespace vlt::stats_internal {

inline double LogGamma(double x) {
  int sign = 0;
  return ::lgamma_r(x, &sign);
}

}  // namespace vlt::stats_internal
