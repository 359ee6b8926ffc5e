# Run by CTest in the MPI build (tests/mpi.cmake): the same vlt command as one plain process and
# under `mpirun -np R` with T threads for each "R:T" of RUNS; every output file must be the same
# byte for byte (docs/mpi.md). results.json differs only in how the run was made (Monte Carlo
# seconds, threads and ranks, the wall times), which is removed before comparing; its "ranks"
# must say R, so a run that silently did not use MPI fails.
#   -DVLT=... -DMPIEXEC=... "-DMPIEXEC_FLAGS=--oversubscribe;..." "-DARGS=run;job.toml;--trials;25000"
#   -DOUT=dir "-DRUNS=1:2;2:1;3:1" [-DSECTION=monte_carlo (the results.json object holding ranks;
#   none: its results.json does not say, e.g. vlt network, or there is none, vlt map)]
cmake_minimum_required(VERSION 3.25)
if(NOT SECTION)
  set(SECTION monte_carlo)
endif()
file(REMOVE_RECURSE ${OUT})

# results.json without the members that say how the run was made, not what it computed.
function(comparable_json file var)
  file(READ ${file} text)
  foreach(path "created" "${SECTION};seconds" "${SECTION};threads" "${SECTION};ranks" "summary;gum_seconds"
               "summary;mcm_seconds")
    string(JSON text ERROR_VARIABLE err REMOVE "${text}" ${path})
  endforeach()
  set(${var} "${text}" PARENT_SCOPE)
endfunction()

execute_process(COMMAND ${VLT} -q ${ARGS} --threads 1 -o ${OUT}/plain
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "plain run: exit status ${rc}\n${out}\n${err}")
endif()
file(GLOB_RECURSE files RELATIVE ${OUT}/plain ${OUT}/plain/*)
list(LENGTH files n_files)
if(n_files EQUAL 0)
  message(FATAL_ERROR "plain run wrote no files")
endif()

foreach(run ${RUNS})
  string(REPLACE ":" ";" rt ${run})
  list(GET rt 0 ranks)
  list(GET rt 1 threads)
  set(dir ${OUT}/np${ranks}_t${threads})
  execute_process(COMMAND ${MPIEXEC} ${MPIEXEC_FLAGS} -np ${ranks} ${VLT} -q ${ARGS} --threads ${threads} -o ${dir}
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "mpirun -np ${ranks} (${threads} threads): exit status ${rc}\n${out}\n${err}")
  endif()
  file(GLOB_RECURSE got RELATIVE ${dir} ${dir}/*)
  if(NOT got STREQUAL files)
    message(FATAL_ERROR "mpirun -np ${ranks}: wrote '${got}', the plain run '${files}'")
  endif()
  foreach(f ${files})
    if(f STREQUAL "results.json")
      if(NOT SECTION STREQUAL "none")
        file(READ ${dir}/${f} text)
        string(JSON used ERROR_VARIABLE err GET "${text}" ${SECTION} ranks)
        if(NOT used STREQUAL "${ranks}")
          message(FATAL_ERROR "mpirun -np ${ranks}: results.json says ranks = '${used}' ${err}")
        endif()
      endif()
      comparable_json(${OUT}/plain/${f} a)
      comparable_json(${dir}/${f} b)
      if(NOT a STREQUAL b)
        message(FATAL_ERROR "mpirun -np ${ranks} (${threads} threads): results.json differs from the plain run's")
      endif()
    elseif(f MATCHES "\\.html$")
      # The page embeds results.json; its numbers are compared through the files above.
      continue()
    else()
      file(SHA256 ${OUT}/plain/${f} a)
      file(SHA256 ${dir}/${f} b)
      if(NOT a STREQUAL b)
        message(FATAL_ERROR "mpirun -np ${ranks} (${threads} threads): ${f} differs from the plain run's")
      endif()
    endif()
  endforeach()
  message(STATUS "mpirun -np ${ranks} x ${threads} threads: ${n_files} files identical")
endforeach()
