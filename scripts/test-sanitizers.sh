#!/usr/bin/env bash
# CI stage 2: the test suite built with AddressSanitizer + UndefinedBehaviorSanitizer.
set -euo pipefail
source "$(dirname "$0")/lib.sh"
vlt_install_packages "${VLT_BUILD_PACKAGES[@]}" "${VLT_TEST_PACKAGES[@]}"
vlt_build "$VLT_ROOT/build-sanitize" -DVLT_SANITIZE=ON -DVLT_BUILD_BENCH=OFF
cd "$VLT_ROOT/build-sanitize"
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  LSAN_OPTIONS=suppressions=$VLT_ROOT/scripts/lsan.supp:print_suppressions=0 \
  ctest --output-on-failure -j2 "$@"
