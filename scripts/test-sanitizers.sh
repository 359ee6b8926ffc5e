#!/usr/bin/env bash
# CI stage 2: the test suite built with Clang, AddressSanitizer + UndefinedBehaviorSanitizer
# (+ float-cast-overflow), in build-sanitize/ — the build that stage 3 (scripts/test-fuzz.sh) fuzzes.
# Every test but those labelled `browser` (a headless browser rendering a page; the runs that wrote
# the page are tests of their own and do run here) and the two calibration coverage studies, which
# repeat one calibration over hundreds of seeds (577 s of the stage's 955 test seconds under the
# sanitizers, for code paths that the other calibration tests run here): stage 1 runs those.
set -euo pipefail
source "$(dirname "$0")/lib.sh"
vlt_build_sanitize
cd "$VLT_ROOT/build-sanitize"
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  LSAN_OPTIONS=suppressions=$VLT_ROOT/scripts/lsan.supp:print_suppressions=0 \
  ctest --output-on-failure -j2 -LE browser \
  -E "^CalibrationTests[.](CoverageOfIdentifiedParametersOverManySeeds|CoverageWithExcludedParametersCarriesTheirPriors)$" "$@"
