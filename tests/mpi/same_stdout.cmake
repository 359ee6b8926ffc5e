# Run by CTest in the MPI build (tests/mpi.cmake): PROGRAM THREADS as one plain process, then
# under `mpirun -np R` with T threads for each "R:T" of RUNS; standard output must be identical
# byte for byte.
#   -DPROGRAM=... -DMPIEXEC=... "-DMPIEXEC_FLAGS=..." "-DRUNS=2:2;3:1"
cmake_minimum_required(VERSION 3.25)
execute_process(COMMAND ${PROGRAM} 1 RESULT_VARIABLE rc OUTPUT_VARIABLE plain ERROR_VARIABLE err)
if(NOT rc EQUAL 0 OR plain STREQUAL "")
  message(FATAL_ERROR "plain run: exit status ${rc}\n${err}")
endif()
foreach(run ${RUNS})
  string(REPLACE ":" ";" rt ${run})
  list(GET rt 0 ranks)
  list(GET rt 1 threads)
  execute_process(COMMAND ${MPIEXEC} ${MPIEXEC_FLAGS} -np ${ranks} ${PROGRAM} ${threads}
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "mpirun -np ${ranks} (${threads} threads): exit status ${rc}\n${err}")
  endif()
  if(NOT out STREQUAL plain)
    file(WRITE ${CMAKE_CURRENT_BINARY_DIR}/same_stdout_plain.txt "${plain}")
    file(WRITE ${CMAKE_CURRENT_BINARY_DIR}/same_stdout_np${ranks}.txt "${out}")
    message(FATAL_ERROR "mpirun -np ${ranks} (${threads} threads) printed other numbers than one process "
                        "(both in ${CMAKE_CURRENT_BINARY_DIR}/same_stdout_*.txt)")
  endif()
  string(LENGTH "${out}" n)
  message(STATUS "mpirun -np ${ranks} x ${threads} threads: ${n} characters identical")
endforeach()
