#!/usr/bin/env bash
# Quick start, command 1: install what is missing, build, and run the embedded default job.
set -euo pipefail
source "$(dirname "$0")/lib.sh"
vlt_install_packages "${VLT_BUILD_PACKAGES[@]}"
# Only what the demo and the README's "Using vlt" commands run: vlt, and vlt-gen for `vlt model
# build` (a custom model's spec built on first use); the tests are the second command's.
VLT_BUILD_TARGETS="vlt vlt-gen" vlt_build "$VLT_ROOT/build"
exec "$VLT_ROOT/build/runtime/vlt" demo "$@"
