# The MPI build only (-DVLT_MPI=ON; scripts/test-mpi.sh runs `ctest -L mpi`): the same bits on any
# number of ranks and threads, and failures on one rank ending every rank (docs/mpi.md). Loopback
# only: --oversubscribe lets 3 ranks share 2 cores, --allow-run-as-root lets CI run as root,
# --quiet keeps mpirun's own banner off standard error, --bind-to none lets a rank's threads use
# both cores, mpi_yield_when_idle stops a waiting rank from spinning on a core another rank needs.
if(NOT VLT_MPI OR NOT TARGET vlt_mpi)
  return()
endif()
set(_mpi ${CMAKE_CURRENT_SOURCE_DIR}/mpi)
set(_cli ${CMAKE_CURRENT_SOURCE_DIR}/cli)
set(_out ${CMAKE_BINARY_DIR}/mpi-tests)
set(_flags --quiet --oversubscribe --allow-run-as-root --bind-to none --mca mpi_yield_when_idle 1)
set(_online ${CMAKE_SOURCE_DIR}/examples/online_readings.toml)

# The engine: every number of fixed, adaptive, over-budget and custom-model runs.
add_executable(mcm_ranks ${_mpi}/mcm_ranks.cc)
target_link_libraries(mcm_ranks PRIVATE vlt_runtime_mpi GTest::gtest)
target_include_directories(mcm_ranks PRIVATE ${CMAKE_SOURCE_DIR}/runtime/src ${CMAKE_CURRENT_SOURCE_DIR})
vlt_target_warnings(mcm_ranks)
add_test(NAME mpi_engine_same_bits
  COMMAND ${CMAKE_COMMAND} -DPROGRAM=$<TARGET_FILE:mcm_ranks> -DMPIEXEC=${MPIEXEC_EXECUTABLE}
          "-DMPIEXEC_FLAGS=${_flags}" "-DRUNS=1:1;2:2;3:1" -P ${_mpi}/same_stdout.cmake)

# The command line: every output file of `vlt run` / `vlt map` with 1, 2, 3 ranks.
function(vlt_mpi_same_files name runs section)
  add_test(NAME ${name}
    COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt_mpi> -DMPIEXEC=${MPIEXEC_EXECUTABLE} "-DMPIEXEC_FLAGS=${_flags}"
            "-DARGS=${ARGN}" -DOUT=${_out}/${name} "-DRUNS=${runs}" -DSECTION=${section} -P ${_cli}/mpi_ranks.cmake)
endfunction()
vlt_mpi_same_files(mpi_run_fixed "1:2;2:1;3:1" monte_carlo run ${_online} --trials 25000)
vlt_mpi_same_files(mpi_run_adaptive "2:2;3:1" monte_carlo run ${_online})
vlt_mpi_same_files(mpi_run_custom "3:1" monte_carlo run ${CMAKE_SOURCE_DIR}/examples/custom/jcgm101_mass.toml
                   --trials 30000)
vlt_mpi_same_files(mpi_map "2:1;3:1" none map ${_online} --plane z=0 --extent 1,4,-1,1 --step 1m --mcm
                   --trials 12000)
# A network's Monte Carlo validation: the ranks share the re-adjusted simulated networks.
vlt_mpi_same_files(mpi_network "2:1;3:1" monte_carlo network ${_mpi}/wing_network_mc.toml)

# One rank cannot read its job file (rank 1, then rank 0 of 3): every rank exits 2, rank 0 prints
# the failed rank's line, nothing is written. Rank 0 meets the failure in the Monte Carlo engine,
# in the output transaction (GUM only) or at its own failure.
function(vlt_mpi_error name expect)
  add_test(NAME ${name}
    COMMAND ${CMAKE_COMMAND} -DMPIEXEC=${MPIEXEC_EXECUTABLE} "-DMPIEXEC_FLAGS=${_flags}" "-DCOMMAND=${ARGN}"
            -DOUT=${_out}/${name} "-DEXPECT=${expect}" -P ${_mpi}/expect_error.cmake)
endfunction()
set(_vlt $<TARGET_FILE:vlt_mpi>)
set(_missing ${_out}/no_such_job.toml)
vlt_mpi_error(mpi_error_rank1_unreadable "no_such_job\\.toml: cannot read the job file"
  -np 1 ${_vlt} run ${_online} --trials 25000 -o ${_out}/mpi_error_rank1_unreadable
  : -np 1 ${_vlt} run ${_missing} -o ${_out}/mpi_error_rank1_unreadable)
vlt_mpi_error(mpi_error_rank0_unreadable "no_such_job\\.toml: cannot read the job file"
  -np 1 ${_vlt} run ${_missing} -o ${_out}/mpi_error_rank0_unreadable
  : -np 2 ${_vlt} run ${_online} --trials 25000 -o ${_out}/mpi_error_rank0_unreadable)
vlt_mpi_error(mpi_error_gum_only "no_such_job\\.toml: cannot read the job file"
  -np 1 ${_vlt} run ${_online} --no-mcm -o ${_out}/mpi_error_gum_only
  : -np 1 ${_vlt} run ${_missing} --no-mcm -o ${_out}/mpi_error_gum_only)
# Rank 1's output path is a file: it fails before computing, rank 0 while in the trials.
vlt_mpi_error(mpi_error_rank1_output "the output path exists and is not a directory"
  -np 1 ${_vlt} run ${_online} --trials 25000 -o ${_out}/mpi_error_rank1_output
  : -np 1 ${_vlt} run ${_online} --trials 25000 -o ${_online})

get_property(_tests DIRECTORY PROPERTY TESTS)
foreach(t ${_tests})
  if(t MATCHES "^mpi_")
    set_tests_properties(${t} PROPERTIES LABELS mpi TIMEOUT 300)
  endif()
endforeach()
