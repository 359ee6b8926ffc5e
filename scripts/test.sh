#!/usr/bin/env bash
# Quick start, command 2: install what is missing, build everything, run the whole test suite.
set -euo pipefail
source "$(dirname "$0")/lib.sh"
vlt_install_packages "${VLT_BUILD_PACKAGES[@]}" "${VLT_TEST_PACKAGES[@]}"
vlt_build "$VLT_ROOT/build"
cd "$VLT_ROOT/build"
ctest --output-on-failure -j2 "$@"
