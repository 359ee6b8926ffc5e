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
# cmake --install writes the build tree's install_manifest.txt: one install at a time (cli_consumer_install).
set_tests_properties(cli_model_build_installed PROPERTIES TIMEOUT 600 RESOURCE_LOCK vlt_install)

# The example (examples/custom/polar.toml, JCGM 102 9.3): its [model] spec is built on the first run
# into a cache of the build tree and the run gives the Rice distribution's moments (exact mean
# 0.012565, u 0.006566) and a phase of u 1.74 rad where the GUM says 10 rad; the second-order
# check says of both outputs that it cannot decide (a pole 0.1 u from the estimate; issue 31: a
# step of one u had called the phase reliable).
add_test(NAME cli_model_spec_example
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=run;${CMAKE_SOURCE_DIR}/examples/custom/polar.toml;-o;${CMAKE_BINARY_DIR}/cli-tests/polar"
          -DOUT=${CMAKE_BINARY_DIR}/cli-tests/polar "-DFILES=outputs.csv;results.json;report.html"
          "-DJSON_KEYS=schema;outputs" -DSCHEMA=vlt-custom-results/1
          "-DEXPECT_STDOUT=magnitude +1 +0[.]001 +0[.]01 .* 0[.]00657[0-9]* +GUM NOT RELIABLE [(]2nd order cannot decide[^\n]*\nphase +rad +0 +10 .* 1[.]74[0-9]* +GUM NOT RELIABLE [(]2nd order cannot decide[^\n]*NOT validated"
          -P ${CMAKE_CURRENT_SOURCE_DIR}/cli/expect_outputs.cmake)
set_tests_properties(cli_model_spec_example PROPERTIES
                     ENVIRONMENT "VLT_MODEL_CACHE=${CMAKE_BINARY_DIR}/cli-tests/polar-model-cache" TIMEOUT 300)
