# Tests that drive vlt-gen (included by tests/CMakeLists.txt; also run as a script, see below).
#
#  - test_generated_spec (GoogleTest) runs vlt-gen on temporary specs: it needs the binary.
#  - generated_hand_edit_is_detected: copies generated/, edits one file by hand and runs
#    cmake/CheckGenerated.cmake against the copy, which must FAIL (while the unedited copy passes).
#    This file is its own script: with CMAKE_SCRIPT_MODE_FILE set it performs that check.

if(CMAKE_SCRIPT_MODE_FILE)
  file(REMOVE_RECURSE ${WORK})
  file(MAKE_DIRECTORY ${WORK})
  file(COPY ${CHECKED_IN}/ DESTINATION ${WORK}/copy)
  # Positive control: the unedited copy passes the regeneration check.
  execute_process(COMMAND ${CMAKE_COMMAND} -DVLT_GEN=${VLT_GEN} -DMODELS=${MODELS}
                          -DCHECKED_IN=${WORK}/copy -DOUT=${WORK}/regenerated -P ${CHECK}
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "the unedited copy of generated/ already fails the check:\n${out}${err}")
  endif()
  # A hand edit: change one constant of the generated mirror header.
  file(READ ${WORK}/copy/mirror.h text)
  string(REPLACE "kNumOutputs = 3;" "kNumOutputs = 3;  // tuned by hand" edited "${text}")
  if(edited STREQUAL text)
    message(FATAL_ERROR "could not apply the hand edit to mirror.h")
  endif()
  file(WRITE ${WORK}/copy/mirror.h "${edited}")
  execute_process(COMMAND ${CMAKE_COMMAND} -DVLT_GEN=${VLT_GEN} -DMODELS=${MODELS}
                          -DCHECKED_IN=${WORK}/copy -DOUT=${WORK}/regenerated -P ${CHECK}
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(rc EQUAL 0)
    message(FATAL_ERROR "a hand-edited generated/mirror.h passed the regeneration check")
  endif()
  if(NOT "${out}${err}" MATCHES "tuned by hand")
    message(FATAL_ERROR "the regeneration check failed without showing the edit:\n${out}${err}")
  endif()
  message(STATUS "hand edit detected, as it must be")
  return()
endif()

if(TARGET test_generated_spec)
  add_dependencies(test_generated_spec vlt-gen)
endif()

add_test(NAME generated_hand_edit_is_detected
  COMMAND ${CMAKE_COMMAND}
    -DVLT_GEN=$<TARGET_FILE:vlt-gen>
    -DMODELS=${CMAKE_SOURCE_DIR}/models
    -DCHECKED_IN=${CMAKE_SOURCE_DIR}/generated
    -DCHECK=${CMAKE_SOURCE_DIR}/cmake/CheckGenerated.cmake
    -DWORK=${CMAKE_BINARY_DIR}/hand_edit_check
    -P ${CMAKE_CURRENT_LIST_FILE})

# bench/numpy_baseline.py ports the generated mirror Forward to numpy line by line (the benchmark
# against numpy, docs/performance.md): the port must still read every line the generator writes
# and give vlt's points (its own check against `vlt simulate`, 1e-9 m and 1e-12 m).
add_test(NAME numpy_baseline_port_matches_vlt
  COMMAND ${Python3_EXECUTABLE} ${CMAKE_SOURCE_DIR}/bench/numpy_baseline.py --build ${CMAKE_BINARY_DIR} --port-only)
