# Run by CTest: `vlt ARGS` twice into OUT; both runs must succeed (the second replaces the first
# set of files; docs/cli.md "Outputs").
#   -DVLT=... -DARGS="run;job.toml;-o;OUT" -DOUT=...
cmake_minimum_required(VERSION 3.25)
file(REMOVE_RECURSE ${OUT})
foreach(run 1 2)
  execute_process(COMMAND ${VLT} -q ${ARGS} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "run ${run}: exit status '${rc}'\nstdout: ${out}\nstderr: ${err}")
  endif()
endforeach()
