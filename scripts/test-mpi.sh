#!/usr/bin/env bash
# CI stage 4: the MPI build (-DVLT_MPI=ON, Open MPI from Debian) and its tests (`ctest -L mpi`): the
# same output files for 1, 2 and 3 ranks, and a failure on one rank ending every rank with exit 2
# (docs/mpi.md). It reuses build/ of stage 1 (scripts/test.sh): with -DVLT_MPI=ON that tree also
# links the MPI runtime (vlt_runtime_mpi) from the same objects, so only mpi/ranks.cc is compiled
# again, with MPI, for `build/runtime/mpi/vlt` and the engine test program tests/mpi/mcm_ranks.cc.
set -euo pipefail
source "$(dirname "$0")/lib.sh"
vlt_install_packages "${VLT_BUILD_PACKAGES[@]}" "${VLT_MPI_PACKAGES[@]}"
# build/ is configured back without MPI afterwards (nothing is rebuilt): scripts/test.sh's tree
# stays the plain one (its installed library and command are those without MPI).
trap 'cmake -S "$VLT_ROOT" -B "$VLT_ROOT/build" -DVLT_MPI=OFF >/dev/null' EXIT
cmake -S "$VLT_ROOT" -B "$VLT_ROOT/build" -DCMAKE_BUILD_TYPE=Release -DVLT_MPI=ON >/dev/null
cmake --build "$VLT_ROOT/build" -j2 --target vlt_mpi mcm_ranks >&2
cd "$VLT_ROOT/build"
ctest --output-on-failure -j2 -L mpi "$@"
