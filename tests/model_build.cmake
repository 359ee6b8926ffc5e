# Models without rebuilding vlt (issue 31, docs/custom-models.md "Without rebuilding vlt"): from an
# installed prefix, `vlt model build` of a spec not shipped with vlt and a `vlt run` of a job using
# it (tests/cli/model_build.cmake). Not in the sanitizer build (the installed vlt would need its
# runtime preloaded; the plugin is compiled without the sanitizers).
if(NOT TARGET vlt OR NOT TARGET vlt-gen OR VLT_SANITIZE OR VLT_FUZZ)
  return()
endif()
add_test(NAME cli_model_build_installed
  COMMAND ${CMAKE_COMMAND} -DBUILD_DIR=${CMAKE_BINARY_DIR} -DSOURCE_DIR=${CMAKE_SOURCE_DIR}
          -DOUT=${CMAKE_BINARY_DIR}/cli-tests/model_build -DCXX=${CMAKE_CXX_COMPILER}
          -P ${CMAKE_CURRENT_SOURCE_DIR}/cli/model_build.cmake)
set_tests_properties(cli_model_build_installed PROPERTIES TIMEOUT 600)
