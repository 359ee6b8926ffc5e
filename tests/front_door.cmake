# The command line's promise (docs/cli.md), item by item: outputs are a transaction (the old set or
# the new set, never a mixture; a directory vlt did not write is refused before computing), every
# error is one line "vlt: error: <file>: <key or line>: <problem>" with exit 2 — command-line
# errors included — and implausible values warn (--strict: error).
if(NOT TARGET vlt)
  return()
endif()
set(_cli ${CMAKE_CURRENT_SOURCE_DIR}/cli)
set(_fd ${_cli}/front_door)
set(_out ${CMAKE_BINARY_DIR}/cli-tests)

# Run A (with a map) then run B (without) into one directory: B's directory has no map.
add_test(NAME cli_outputs_replace_whole_set
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt> "-DARGS=run;${_fd}/with_map.toml;--no-mcm;-q;-o;${_out}/fd_replace"
          -DEXPECT_RC=0 -DCLEAN=${_out}/fd_replace -P ${_cli}/expect_run.cmake)
# (expect_run checks the map exists after run A through the second test's MISSING only after B.)
add_test(NAME cli_outputs_replace_whole_set_second
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt> "-DARGS=run;${_fd}/without_map.toml;--no-mcm;-q;-o;${_out}/fd_replace"
          -DEXPECT_RC=0 "-DMISSING=${_out}/fd_replace/map.csv;${_out}/fd_replace/map.html" -P ${_cli}/expect_run.cmake)
set_tests_properties(cli_outputs_replace_whole_set PROPERTIES FIXTURES_SETUP fd_replace)
set_tests_properties(cli_outputs_replace_whole_set_second PROPERTIES FIXTURES_REQUIRED fd_replace)

# A directory holding a file vlt did not write: refused before computing, untouched.
add_test(NAME cli_error_foreign_output_directory
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt> -DPREEXISTING=ON
          "-DARGS=run;${_fd}/without_map.toml;-o;${_out}/fd_foreign"
          -DOUT=${_out}/fd_foreign "-DEXPECT=fd_foreign: the output directory holds 'keep\\.txt', which vlt did not write"
          -P ${_cli}/expect_error.cmake)
# -o naming a file.
add_test(NAME cli_error_output_is_a_file
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt> "-DARGS=run;${_fd}/without_map.toml;-o;${_fd}/zenith.csv"
          -DEXPECT_RC=2 "-DEXPECT_STDERR=^vlt: error: [^\n]*zenith\\.csv: the output path exists and is not a directory\n$"
          -P ${_cli}/expect_run.cmake)

# vlt_front_door_error(NAME REGEX ARGS...): exit 2, one line "vlt: error: ..." matching REGEX, no output.
function(vlt_front_door_error name regex)
  add_test(NAME cli_error_${name}
    COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt> "-DARGS=${ARGN}"
            -DOUT=${_out}/fd_error_${name} "-DEXPECT=${regex}" -P ${_cli}/expect_error.cmake)
endfunction()
set(_o -o ${_out}/fd_error)
vlt_front_door_error(map_grid_overflow "command line: step: the grid has 6e\\+09 nodes, more than 1000000"
                     map ${_fd}/without_map.toml --plane z=-0.8 --extent 0,3e9,0,1 --step 1m -o ${_out}/fd_error_map_grid_overflow)
vlt_front_door_error(map_grid_overflow_job "map_overflow\\.toml: map: step: the grid has 6e\\+09 nodes"
                     run ${_fd}/map_overflow.toml -o ${_out}/fd_error_map_grid_overflow_job)
vlt_front_door_error(cli_trials_zero "command line: --trials: '0' is not an integer in 1 \\.\\. 1000000000"
                     run ${_fd}/without_map.toml --trials 0 -o ${_out}/fd_error_cli_trials_zero)
vlt_front_door_error(cli_threads_negative "command line: --threads: '-1' is not an integer in 0 \\.\\. 1024"
                     run ${_fd}/without_map.toml --threads -1 -o ${_out}/fd_error_cli_threads_negative)
vlt_front_door_error(cli_seed_text "command line: --seed: 'abc' is not an integer in 0 \\.\\. 18446744073709551615"
                     run ${_fd}/without_map.toml --seed abc -o ${_out}/fd_error_cli_seed_text)
vlt_front_door_error(cli_seed_overflow "command line: --seed: '99999999999999999999' is not an integer"
                     run ${_fd}/without_map.toml --seed 99999999999999999999 -o ${_out}/fd_error_cli_seed_overflow)
vlt_front_door_error(cli_unknown_option "command line: .*--frobnicate"
                     run ${_fd}/without_map.toml --frobnicate -o ${_out}/fd_error_cli_unknown_option)
vlt_front_door_error(cli_unknown_command "command line: .*frobnicate" frobnicate)
vlt_front_door_error(cli_run_without_job "command line: job is required" run)
vlt_front_door_error(zenith_reading "zenith\\.csv: line 3: elevation: the reading points along the tracker's standing axis"
                     run ${_fd}/zenith.toml -o ${_out}/fd_error_zenith_reading)
vlt_front_door_error(huge_range "huge_range\\.csv: line 3: range: 1e\\+300 m is beyond any laser tracker"
                     run ${_fd}/huge_range.toml -o ${_out}/fd_error_huge_range)
# A job at a path of more than 1000 characters: the error line keeps its first and last 480, so
# the problem at its end is never cut (issue 32).
set(_long_dir ${CMAKE_BINARY_DIR}/cli-tests/long)
foreach(_c a b c d e)
  string(REPEAT ${_c} 200 _part)
  set(_long_dir ${_long_dir}/${_part})
endforeach()
file(WRITE ${_long_dir}/job.toml "[tracker]\nmodel = \"nope\"\n")
vlt_front_door_error(long_path_keeps_the_problem
                     "[.][.][.][(][0-9]+ characters[)][.][.][.] .*/job\\.toml: tracker\\.model: unknown model 'nope' [(]tracker models: [^\n]*[)]\n$"
                     run ${_long_dir}/job.toml -o ${_out}/fd_error_long_path)
vlt_front_door_error(huge_angle "huge_angle\\.csv: line 3: azimuth: 1e\\+20 deg is not a plausible angle"
                     run ${_fd}/huge_angle.toml -o ${_out}/fd_error_huge_angle)
vlt_front_door_error(huge_uncertainty "huge_u\\.toml: tracker\\.parameters\\.tmv\\.u: uncertainty beyond what vlt computes with"
                     run ${_fd}/huge_u.toml -o ${_out}/fd_error_huge_uncertainty)
vlt_front_door_error(thermal_factor_zero "thermal_zero\\.toml: part\\.cte: the thermal expansion factor .* is not positive"
                     run ${_fd}/thermal_zero.toml -o ${_out}/fd_error_thermal_factor_zero)
vlt_front_door_error(pressure_in_pa "pressure_pa\\.toml: environment\\.pressure: 1013 Pa .*did you mean \"1013 hPa\""
                     run ${_fd}/pressure_pa.toml -o ${_out}/fd_error_pressure_in_pa)
# Air outside its equation's range of validity is computed with a warning (as NIST's calculator
# does), an error under --strict.
vlt_front_door_error(air_outside_validity "air_invalid\\.toml: environment: temperature 5000 degC is outside the range of validity of the Ciddor equation"
                     --strict run ${_fd}/air_invalid.toml -o ${_out}/fd_error_air_outside_validity)
vlt_front_door_error(air_unknown_equation "air_equation\\.toml: environment\\.equation: unknown refractive-index equation 'modified-edlen' \\(expected one of: ciddor, edlen, edlen_boensch, boensch_potulski, modified_edlen, birch_downs, edlen_birch_downs\\)"
                     run ${_fd}/air_equation.toml -o ${_out}/fd_error_air_unknown_equation)
vlt_front_door_error(job_is_a_directory "a_directory\\.toml: cannot read the job file: a directory, not a file"
                     run ${_fd}/a_directory.toml -o ${_out}/fd_error_job_is_a_directory)
vlt_front_door_error(hex_float_in_csv "hex\\.csv: line 2: range: .*'0x1p1'"
                     run ${_fd}/hex.toml -o ${_out}/fd_error_hex_float_in_csv)
vlt_front_door_error(bare_micro_sign "bare_micro\\.toml: line 4, column 11: a non-ASCII character outside a quoted string"
                     run ${_fd}/bare_micro.toml -o ${_out}/fd_error_bare_micro_sign)
vlt_front_door_error(strict_warning "implausible_u\\.toml: tracker\\.parameters\\.a0: .* is implausible for a tracker error parameter .*--strict"
                     --strict run ${_fd}/implausible_u.toml -o ${_out}/fd_error_strict_warning)
# A 2 MB CSV cell: the error line quotes its first and last 60 characters.
add_test(NAME cli_error_long_value_is_cut
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt> "-DARGS=run;${_fd}/long_cell.toml;-o;${_out}/fd_long"
          -DEXPECT_RC=2 "-DEXPECT_STDERR=long_cell\\.csv: line 2: elevation: '9+\\.\\.\\.[(]2000001 characters[)]\\.\\.\\.9+x'" -DMAX_STDERR=400
          -P ${_cli}/expect_run.cmake)

# Legal: a warning on stderr and the run goes on; a CR-only CSV; a correlation of exactly 1.
add_test(NAME cli_warning_implausible_value
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt> "-DARGS=run;${_fd}/implausible_u.toml;--no-mcm;-o;${_out}/fd_warn"
          -DEXPECT_RC=0 "-DEXPECT_STDERR=^vlt: warning: [^\n]*implausible_u\\.toml: tracker\\.parameters\\.a0: 2\\.063e\\+08 arcsec is implausible"
          -DCLEAN=${_out}/fd_warn -P ${_cli}/expect_run.cmake)
add_test(NAME cli_warning_air_outside_validity
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt> "-DARGS=run;${_fd}/air_hot_edlen.toml;--no-mcm;-o;${_out}/fd_air_hot"
          -DEXPECT_RC=0 "-DEXPECT_STDERR=^vlt: warning: [^\n]*air_hot_edlen\\.toml: environment: temperature 60 degC is outside the range of validity of the modified Edlen [(]NIST, Birch-Downs[)] equation [(]0[.][.]40 degC, NIST Engineering Metrology Toolbox[)]: n computed outside it"
          -DCLEAN=${_out}/fd_air_hot -P ${_cli}/expect_run.cmake)
# An absolute distance meter: the range correction uses the group index (docs/units.md).
add_test(NAME cli_adm_group_index
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt> "-DARGS=run;${_fd}/adm_group_index.toml;--no-mcm;-o;${_out}/fd_adm"
          -DOUT=${_out}/fd_adm "-DFILES=points.csv;results.json"
          "-DEXPECT_FILE_REGEX=results.json:\"ranging\": \"adm\",[^}]*\"range_correction_uses\": \"n_group\""
          -P ${_cli}/expect_outputs.cmake)
add_test(NAME cli_csv_cr_only_line_ends
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt> "-DARGS=run;${_fd}/cr_only.toml;--no-mcm;-o;${_out}/fd_cr"
          -DOUT=${_out}/fd_cr "-DFILES=points.csv" "-DEXPECT_STDOUT=P1 .*P2 " -P ${_cli}/expect_outputs.cmake)
add_test(NAME cli_correlation_of_one
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt> "-DARGS=run;${_fd}/correlation_one.toml;--trials;20000;-o;${_out}/fd_corr1"
          -DOUT=${_out}/fd_corr1 "-DFILES=points.csv;results.json" -P ${_cli}/expect_outputs.cmake)
# The same thermometer for the air and the part: [correlations] across input groups, r = 1 (a
# singular correlation matrix) through the GUM and the Monte Carlo copula; validated.
add_test(NAME cli_correlation_between_groups
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt> "-DARGS=run;${_fd}/shared_thermometer.toml;--trials;50000;-o;${_out}/fd_thermometer"
          -DOUT=${_out}/fd_thermometer "-DFILES=points.csv;budget.csv;results.json"
          "-DEXPECT_STDOUT=AB [^\n]* validated" -P ${_cli}/expect_outputs.cmake)

# Near the standing axis the first-order GUM is flagged without Monte Carlo (JCGM 100 5.1.2 note).
add_test(NAME cli_gum_not_reliable_near_axis
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt> "-DARGS=run;${_fd}/near_axis.toml;--no-mcm;-o;${_out}/fd_axis"
          -DOUT=${_out}/fd_axis "-DFILES=points.csv;results.json"
          "-DEXPECT_STDOUT=UP2um [^\n]*GUM NOT RELIABLE [(]2nd order [0-9.]+ x u\\^2[)]; not run\nUP10mm [^\n]* not run\n"
          -P ${_cli}/expect_outputs.cmake)

# `vlt simulate` takes the rule of every other source (vlt/job.h CheckTrackerPoint,
# CheckValueMagnitude; issue 32 item 5): a point 1000 km away, a parameter of 1e300 m.
vlt_front_door_error(simulate_far_point "command line: --point: 1e\\+06 m from the tracker is beyond any laser tracker"
                     simulate --model mirror --point 1e6,0,0)
vlt_front_door_error(simulate_huge_parameter "command line: tmv: beyond what vlt computes with \\(at most 1e12 in SI units\\)"
                     simulate --model mirror --point 3,0,0 tmv=1e300m)
