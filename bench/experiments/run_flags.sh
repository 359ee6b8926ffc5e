#!/bin/sh
# Compiler-flag experiment of docs/performance.md ("Flags"): builds kernel_flags.cc with several
# flag sets and compares every build's numbers with the portable -O3 build.
# Usage: bench/experiments/run_flags.sh [workdir]   (from the repository root; ~1 min)
set -e
src=$(cd "$(dirname "$0")/../.." && pwd)
work=${1:-/tmp/vlt-flags}
mkdir -p "$work"
build() {  # name, flags...
  name=$1; shift
  g++ -std=c++20 -DNDEBUG -I"$src" "$@" "$src/bench/experiments/kernel_flags.cc" \
      -o "$work/$name" -lbenchmark -lpthread
}
build O3 -O3
build O2 -O2
build O3_native -O3 -march=native
build O3_simd -O3 -fopenmp-simd
build O3_fastmath_simd -O3 -ffast-math -fopenmp-simd
build O3_native_fastmath_simd -O3 -march=native -ffast-math -fopenmp-simd
VLT_FLAGS_OUT="$work/ref.bin" "$work/O3" --benchmark_filter=NONE >/dev/null
for b in O3 O2 O3_native O3_simd O3_fastmath_simd O3_native_fastmath_simd; do
  echo "== $b"
  VLT_FLAGS_REF="$work/ref.bin" "$work/$b" --benchmark_min_time=0.3 2>/dev/null |
    grep -E "differ|BM_"
done
