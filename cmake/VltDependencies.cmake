# Every dependency is a Debian 12 package. A missing one stops configuration with a message
# that names the package to install (scripts/lib.sh installs them all).
find_package(PkgConfig QUIET)

macro(vlt_require found package what)
  if(NOT ${found})
    message(FATAL_ERROR "vlt: ${what} not found. Install the Debian package: apt-get install ${package}")
  endif()
endmacro()

if(NOT PKG_CONFIG_FOUND)
  message(FATAL_ERROR "vlt: pkg-config not found. Install the Debian package: apt-get install pkg-config")
endif()

find_package(Eigen3 3.4 QUIET NO_MODULE)
vlt_require(Eigen3_FOUND libeigen3-dev "Eigen 3.4")

pkg_check_modules(GINAC QUIET IMPORTED_TARGET ginac)
vlt_require(GINAC_FOUND libginac-dev "GiNaC")

find_package(tomlplusplus QUIET)
vlt_require(tomlplusplus_FOUND libtomlplusplus-dev "toml++")

find_package(CLI11 QUIET)
vlt_require(CLI11_FOUND libcli11-dev "CLI11")

find_package(nlohmann_json QUIET)
vlt_require(nlohmann_json_FOUND nlohmann-json3-dev "nlohmann-json")

find_path(RANDOM123_INCLUDE_DIR Random123/philox.h)
if(NOT RANDOM123_INCLUDE_DIR)
  set(RANDOM123_FOUND FALSE)
else()
  set(RANDOM123_FOUND TRUE)
  add_library(vlt_random123 INTERFACE)
  target_include_directories(vlt_random123 SYSTEM INTERFACE ${RANDOM123_INCLUDE_DIR})
endif()
vlt_require(RANDOM123_FOUND librandom123-dev "Random123")

# Ceres Solver: the nonlinear least squares of calibration (runtime/src/calibration/) and networks.
find_package(Ceres 2.1 QUIET)
vlt_require(Ceres_FOUND libceres-dev "Ceres Solver")

# NLopt (C++ interface): station optimisation, `vlt plan` (runtime/src/planning/). Debian splits
# the C++ interface into libnlopt_cxx (nlopt_cxx.pc); upstream NLopt and other distributions
# (Fedora's NLopt-devel) build it into libnlopt (nlopt.pc). VLT_NLOPT_LIBRARY names the one found,
# for the installed vlt.pc and vltConfig.cmake.
pkg_check_modules(NLOPT_CXX QUIET IMPORTED_TARGET nlopt_cxx)
set(VLT_NLOPT_LIBRARY nlopt_cxx)
if(NOT NLOPT_CXX_FOUND)
  pkg_check_modules(NLOPT_CXX QUIET IMPORTED_TARGET nlopt)
  set(VLT_NLOPT_LIBRARY nlopt)
  if(NLOPT_CXX_FOUND)
    include(CheckIncludeFileCXX)
    set(CMAKE_REQUIRED_INCLUDES ${NLOPT_CXX_INCLUDE_DIRS})
    check_include_file_cxx(nlopt.hpp VLT_HAVE_NLOPT_HPP)
    unset(CMAKE_REQUIRED_INCLUDES)
    if(NOT VLT_HAVE_NLOPT_HPP)
      set(NLOPT_CXX_FOUND FALSE)
    endif()
  endif()
endif()
vlt_require(NLOPT_CXX_FOUND libnlopt-cxx-dev "NLopt (C++: nlopt_cxx, or nlopt with nlopt.hpp)")

# Clp (COIN-OR's simplex): the linear programs of form by minimum zone (runtime/src/tasks/minimum_zone.cc).
pkg_check_modules(CLP QUIET IMPORTED_TARGET clp)
vlt_require(CLP_FOUND coinor-libclp-dev "Clp (COIN-OR linear programming)")

# OpenSSL's libcrypto: SHA-256 of the data files a calibration file records (provenance).
find_package(OpenSSL QUIET COMPONENTS Crypto)
vlt_require(OPENSSL_FOUND libssl-dev "OpenSSL (libcrypto)")

# Highway's vectorised quicksort (hwy::Sorter, libhwy_contrib): the order statistics of Monte
# Carlo runs (runtime/src/mcm/order.cc).
find_package(hwy QUIET)
vlt_require(hwy_FOUND libhwy-dev "Highway (libhwy_contrib)")

find_package(Threads REQUIRED)

# Open MPI (Debian libopenmpi-dev, openmpi-bin): only for -DVLT_MPI=ON (docs/mpi.md).
if(VLT_MPI)
  find_package(MPI QUIET COMPONENTS CXX)
  vlt_require(MPI_CXX_FOUND "libopenmpi-dev openmpi-bin" "MPI (Open MPI)")
endif()

if(VLT_BUILD_TESTS)
  find_package(GTest QUIET)
  vlt_require(GTest_FOUND "libgtest-dev libgmock-dev" "GoogleTest")
  include(GoogleTest)
endif()
if(VLT_BUILD_BENCH AND NOT VLT_SANITIZE AND NOT VLT_FUZZ)
  find_package(benchmark QUIET)
  vlt_require(benchmark_FOUND libbenchmark-dev "Google Benchmark")
endif()
