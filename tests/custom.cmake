# Custom-model jobs through the command line (docs/custom-models.md): every example of
# examples/custom/ runs and writes its files; bad custom jobs give one line and exit 2.
if(NOT TARGET vlt)
  return()
endif()

set(_custom_cli ${CMAKE_CURRENT_SOURCE_DIR}/cli)
set(_custom_out ${CMAKE_BINARY_DIR}/cli-tests)
set(_custom_files "outputs.csv;budget.csv;results.json;report.html")
set(_custom_keys "schema;vlt_version;job;model;inputs;outputs;monte_carlo")

file(GLOB _custom_examples CONFIGURE_DEPENDS ${CMAKE_SOURCE_DIR}/examples/custom/*.toml)
foreach(example ${_custom_examples})
  get_filename_component(ex ${example} NAME_WE)
  add_test(NAME cli_custom_example_${ex}
    COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
            "-DARGS=run;${example};--trials;20000;-o;${_custom_out}/custom_${ex}"
            -DOUT=${_custom_out}/custom_${ex} "-DFILES=${_custom_files}" "-DJSON_KEYS=${_custom_keys}" -DSCHEMA=vlt-custom-results/1
            "-DEXPECT_STDOUT=custom model [a-z0-9_]+, [0-9]+ inputs"
            -P ${_custom_cli}/expect_outputs.cmake)
endforeach()

# GUM H.1 at 99 %: nu_eff 16, k = 2.921 in the summary; the conformity line.
add_test(NAME cli_custom_gum_h1_summary
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=run;${CMAKE_SOURCE_DIR}/examples/custom/gum_h1_end_gauge.toml;--no-mcm;-o;${_custom_out}/custom_h1_summary"
          -DOUT=${_custom_out}/custom_h1_summary "-DFILES=${_custom_files}" "-DJSON_KEYS=schema;outputs" -DSCHEMA=vlt-custom-results/1
          "-DEXPECT_STDOUT=l +m +0\\.050000838 +3\\.171e-08 +16 +2\\.921 +9\\.262e-08.*undetermined"
          -P ${_custom_cli}/expect_outputs.cmake)

function(vlt_custom_error name job regex)
  add_test(NAME cli_custom_error_${name}
    COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
            "-DARGS=run;${_custom_cli}/custom/${job};-o;${_custom_out}/custom_error_${name};${ARGN}"
            -DOUT=${_custom_out}/custom_error_${name} "-DEXPECT=${regex}"
            -P ${_custom_cli}/expect_error.cmake)
endfunction()
vlt_custom_error(csv_field bad_observations.toml "bad_observations\\.csv: line 4: column V: 'oops' is not a decimal number")
vlt_custom_error(tracker_model tracker_model.toml "tracker_model\\.toml: model\\.name: 'head' is a tracker model")

# `vlt simulate` on a custom model: y and dy/dx at the inputs given (JCGM 101 9.3 at rho_a =
# 1.3 kg/m^3: delta_m = 1.234 mg with d/d rho_W = (m_Rc + dm_Rc)(rho_a - 1.2)/rho_W^2 = 1.5625e-4).
add_test(NAME cli_custom_simulate COMMAND vlt simulate --model jcgm101_mass rho_a=1.3)
set_tests_properties(cli_custom_simulate PROPERTIES PASS_REGULAR_EXPRESSION
  "delta_m = 1\\.234[0-9]* mg +sensitivities: d/dm_Rc 1 d/ddelta_m_Rc 1 d/drho_a 0 d/drho_W -0\\.000156252")
add_test(NAME cli_custom_simulate_point
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt> "-DARGS=simulate;--model;jcgm101_mass;--point;1,1,1"
          -DOUT=${_custom_out}/custom_simulate_point "-DEXPECT=--point: 'jcgm101_mass' is a custom model"
          -P ${_custom_cli}/expect_error.cmake)

# A custom job run twice into the same directory: the second run replaces the first set (the
# directory holds only files vlt writes).
add_test(NAME cli_custom_rerun_same_directory
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=run;${CMAKE_SOURCE_DIR}/examples/custom/jcgm101_mass.toml;--trials;10000;-o;${_custom_out}/custom_rerun"
          -DOUT=${_custom_out}/custom_rerun -P ${_custom_cli}/run_twice.cmake)
