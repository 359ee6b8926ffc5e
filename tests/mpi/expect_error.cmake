# Run by CTest in the MPI build (tests/mpi.cmake): an mpirun command line (MPMD, "a : b", so that
# one rank gets a file another does not) must end with exit status 2 on every rank, exactly one
# line on standard error, "vlt: error: " and EXPECT (a regex), and no output directory OUT.
#   -DMPIEXEC=... "-DMPIEXEC_FLAGS=..." "-DCOMMAND=-np;1;vlt;run;a.toml;:;-np;1;..." -DOUT=... -DEXPECT=...
cmake_minimum_required(VERSION 3.25)
file(REMOVE_RECURSE ${OUT})
execute_process(COMMAND ${MPIEXEC} ${MPIEXEC_FLAGS} ${COMMAND}
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 2)
  message(FATAL_ERROR "exit status '${rc}', expected 2\nstdout: ${out}\nstderr: ${err}")
endif()
if(NOT err MATCHES "^vlt: error: [^\n]*${EXPECT}[^\n]*\n$")
  message(FATAL_ERROR "stderr is not one line 'vlt: error: ...${EXPECT}...':\n${err}")
endif()
if(EXISTS ${OUT})
  message(FATAL_ERROR "${OUT} was written")
endif()
