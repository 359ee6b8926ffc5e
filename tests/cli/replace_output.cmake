# Run by CTest: `vlt run JOB` twice into OUT with seeds 1 and 2 (docs/cli.md "Outputs": the output
# directory is replaced as a whole). Both runs succeed; OUT then holds the second run (results.json
# names seed 2); nothing is left beside it (no ".<name>.vlt-new-*" staging or ".<name>.vlt-old-*"
# set). With VLT_NO_RENAME_EXCHANGE in the environment the swap takes the fallback of a C library
# or file system without renameat2(RENAME_EXCHANGE): the old set moved aside, the new one in.
#   -DVLT=... -DJOB=... -DOUT=...
cmake_minimum_required(VERSION 3.25)
file(REMOVE_RECURSE ${OUT})
foreach(seed 1 2)
  execute_process(COMMAND ${VLT} -q run ${JOB} --trials 2000 --seed ${seed} -o ${OUT}
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "run with seed ${seed}: exit status '${rc}'\nstdout: ${out}\nstderr: ${err}")
  endif()
endforeach()
file(READ ${OUT}/results.json json)
string(JSON seed GET "${json}" monte_carlo seed)
if(NOT seed EQUAL 2)
  message(FATAL_ERROR "${OUT} holds the run with seed ${seed}, not the second one")
endif()
get_filename_component(parent ${OUT} DIRECTORY)
get_filename_component(name ${OUT} NAME)
file(GLOB left LIST_DIRECTORIES true "${parent}/.${name}.vlt-*")
if(left)
  message(FATAL_ERROR "left beside the output directory: ${left}")
endif()
