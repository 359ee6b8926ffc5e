#!/usr/bin/env bash
# CI stage: the MPI build (-DVLT_MPI=ON, Open MPI from Debian) and its tests (`ctest -L mpi`): the
# same output files for 1, 2 and 3 ranks, and a failure on one rank ending every rank with exit 2
# (docs/mpi.md). Only `vlt` and the engine test program are built; the non-MPI build and its tests
# are those of scripts/test.sh.
set -euo pipefail
source "$(dirname "$0")/lib.sh"
vlt_install_packages "${VLT_BUILD_PACKAGES[@]}" "${VLT_MPI_PACKAGES[@]}"
cmake -S "$VLT_ROOT" -B "$VLT_ROOT/build-mpi" -DCMAKE_BUILD_TYPE=Release -DVLT_MPI=ON -DVLT_BUILD_BENCH=OFF >/dev/null
cmake --build "$VLT_ROOT/build-mpi" -j2 --target vlt mcm_ranks >&2
cd "$VLT_ROOT/build-mpi"
ctest --output-on-failure -j2 -L mpi "$@"
