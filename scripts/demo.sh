#!/usr/bin/env bash
# Quick start, command 1: install what is missing, build, and run the embedded default job.
set -euo pipefail
source "$(dirname "$0")/lib.sh"
vlt_install_packages "${VLT_BUILD_PACKAGES[@]}"
vlt_build "$VLT_ROOT/build"
exec "$VLT_ROOT/build/runtime/vlt" demo "$@"
