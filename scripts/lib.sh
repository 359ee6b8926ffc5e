# Shared by the README's two commands (scripts/demo.sh, scripts/test.sh) and .ci/run.
# Installs the Debian 12 packages vlt needs when they are missing, then configures and builds.

VLT_ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)

# Debian packages for building and running vlt (the runtime, the generator, tests, benchmarks).
VLT_BUILD_PACKAGES=(g++ cmake make ninja-build lld pkg-config git
  libginac-dev libeigen3-dev libgtest-dev libgmock-dev libbenchmark-dev
  libcli11-dev libtomlplusplus-dev nlohmann-json3-dev librandom123-dev libceres-dev
  libnlopt-cxx-dev          # station planning (runtime/src/planning/)
  coinor-libclp-dev         # linear programs of form by minimum zone (runtime/src/tasks/minimum_zone.cc)
  libssl-dev
  libhwy-dev                # Highway's vectorised sort: Monte Carlo order statistics (runtime/src/mcm/order.cc)
  pybind11-dev python3-dev  # the Python module (python/)
  python3-numpy             # the Python module's arrays; bench/numpy_baseline.py
  python3-pytest)           # tests/python, run by CTest
# plotly.js for report.html comes from the npm registry (`npm ci` at configure time). Debian's
# nodejs + npm are installed only when no `npm` is on the PATH: a machine may already have a
# Node.js from elsewhere, and Debian's npm package conflicts with it.
if ! command -v npm >/dev/null 2>&1; then
  VLT_BUILD_PACKAGES+=(nodejs npm)
fi
# Extra packages for the test suite only: the headless browser that renders and prints report.html.
VLT_TEST_PACKAGES=(chromium
  poppler-utils    # pdftotext / pdfinfo / pdfimages: the printed reports (tests/cli/report_print.cmake, check_print.py)
  python3-pip python3-setuptools python3-wheel  # pip install --no-build-isolation . (python_pip_install)
  python3-plotly)  # its plotly.js, what a build without npm embeds (report_browser_demo_debian_plotly)

# The MPI build (-DVLT_MPI=ON, docs/mpi.md; scripts/test-mpi.sh): Open MPI.
VLT_MPI_PACKAGES=(libopenmpi-dev openmpi-bin)
# The sanitizer and fuzzing build (scripts/test-sanitizers.sh, scripts/test-fuzz.sh): Clang, libFuzzer.
VLT_FUZZ_PACKAGES=(clang libfuzzer-14-dev)

# The Fedora (dnf) name of each Debian package above (checked on packages.fedoraproject.org for
# Fedora 40-42, 2026-11-27; docs/testing.md "Other distributions"). Open MPI's programs are then
# under /usr/lib64/openmpi/bin (`module load mpi/openmpi-x86_64`); libFuzzer comes with compiler-rt.
vlt_fedora_name() {
  case "$1" in
    g++) echo gcc-c++ ;;
    cmake | make | ninja-build | lld | git | chromium | poppler-utils | clang) echo "$1" ;;
    pkg-config) echo pkgconf-pkg-config ;;
    libginac-dev) echo ginac-devel ;;
    libeigen3-dev) echo eigen3-devel ;;
    libgtest-dev) echo gtest-devel ;;
    libgmock-dev) echo gmock-devel ;;
    libbenchmark-dev) echo google-benchmark-devel ;;
    libcli11-dev) echo cli11-devel ;;
    libtomlplusplus-dev) echo tomlplusplus-devel ;;
    nlohmann-json3-dev) echo json-devel ;;
    librandom123-dev) echo Random123-devel ;;
    libceres-dev) echo ceres-solver-devel ;;
    libnlopt-cxx-dev) echo NLopt-devel ;;
    coinor-libclp-dev) echo coin-or-Clp-devel ;;
    libssl-dev) echo openssl-devel ;;
    libhwy-dev) echo highway-devel ;;
    pybind11-dev) echo pybind11-devel ;;
    python3-dev) echo python3-devel ;;
    python3-numpy | python3-pytest | python3-pip | python3-setuptools | python3-wheel | python3-plotly) echo "$1" ;;
    nodejs) echo nodejs ;;
    npm) echo nodejs-npm ;;
    libopenmpi-dev) echo openmpi-devel ;;
    openmpi-bin) echo openmpi ;;
    libfuzzer-14-dev) echo compiler-rt ;;
    *) return 1 ;;
  esac
}

vlt_as_root() {
  if [ "$(id -u)" -eq 0 ]; then "$@"; else sudo "$@"; fi
}

# vlt_install_packages PKG... : apt-get update once and install only what is missing (Debian names);
# on a system with dnf and without apt-get, the same packages by their Fedora names.
vlt_install_packages() {
  local missing=()
  local p
  if ! command -v apt-get >/dev/null 2>&1 && command -v dnf >/dev/null 2>&1; then
    local f
    for p in "$@"; do
      f=$(vlt_fedora_name "$p") || { echo "vlt: no Fedora name known for the Debian package $p" >&2; return 1; }
      rpm -q "$f" >/dev/null 2>&1 || missing+=("$f")
    done
    if [ ${#missing[@]} -gt 0 ]; then
      echo "vlt: installing Fedora packages: ${missing[*]}" >&2
      vlt_as_root dnf install -y -q "${missing[@]}" >&2
    fi
    return 0
  fi
  for p in "$@"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  if [ ${#missing[@]} -gt 0 ]; then
    echo "vlt: installing Debian packages: ${missing[*]}" >&2
    vlt_as_root env DEBIAN_FRONTEND=noninteractive apt-get update -qq
    vlt_as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}" >&2
  fi
}

# vlt_build DIR [cmake args...] : configure (Release, Ninja), build with one job per core. Configuring on
# every run is cheap (npm ci reruns only when package-lock.json changes) and recovers from a configure
# that failed earlier (no network, say), which leaves CMakeCache.txt but no build.ninja behind.
# Ninja starts a program's sources while the libraries it links are still being built, which
# make's per-target order did not (docs/testing.md); a tree configured by an older vlt with make is
# configured afresh.
vlt_build() {
  local dir=$1; shift
  if [ -f "$dir/CMakeCache.txt" ] && ! grep -q '^CMAKE_GENERATOR:INTERNAL=Ninja$' "$dir/CMakeCache.txt"; then
    rm -rf "$dir/CMakeCache.txt" "$dir/CMakeFiles"
  fi
  # Warnings are errors in CI (.ci/run exports VLT_WARNINGS_AS_ERRORS=ON), not in a user's build.
  cmake -S "$VLT_ROOT" -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=Release \
    -DVLT_WARNINGS_AS_ERRORS="${VLT_WARNINGS_AS_ERRORS:-OFF}" "$@" >/dev/null
  # One job per core: cores + 1 was tried and measured no faster on the 2-core CI machine
  # (docs/testing.md). VLT_BUILD_TARGETS (space-separated) builds only those targets (the demo:
  # vlt and vlt-gen, not the tests).
  local targets=()
  for t in ${VLT_BUILD_TARGETS:-}; do targets+=(--target "$t"); done
  cmake --build "$dir" -j"$(nproc)" "${targets[@]}" >&2
}

# vlt_build_sanitize : the one Clang build that CI's sanitizer and fuzzing stages share
# (build-sanitize/): every target built with AddressSanitizer + UndefinedBehaviorSanitizer
# (+ float-cast-overflow) and libFuzzer's coverage instrumentation, and the fuzz harnesses.
# -O1 with line tables: the optimisation ASan's authors recommend for speed of the instrumented
# code, file:line in every report (docs/testing.md).
vlt_build_sanitize() {
  vlt_install_packages "${VLT_BUILD_PACKAGES[@]}" "${VLT_TEST_PACKAGES[@]}" "${VLT_FUZZ_PACKAGES[@]}"
  vlt_build "$VLT_ROOT/build-sanitize" -DCMAKE_CXX_COMPILER=clang++ -DVLT_SANITIZE=ON -DVLT_FUZZ=ON -DVLT_BUILD_BENCH=OFF \
    -DCMAKE_CXX_FLAGS_RELEASE="-O1 -gline-tables-only -DNDEBUG" -DVLT_TEST_OPTIMIZATION=-O1
}
