# The calibration loop on the command line (docs/calibration.md): `vlt test` on the shipped example
# reproduces the shipped simulated data byte for byte, `vlt calibrate` on those data reproduces the
# shipped calibration file, a job loads it, the reports draw, and bad input is one line, exit 2,
# nothing written.
if(NOT TARGET vlt)
  return()
endif()
set(_cli ${CMAKE_CURRENT_SOURCE_DIR}/cli)
set(_cal_jobs ${_cli}/calibration)
set(_ex ${CMAKE_SOURCE_DIR}/examples/calibration)
set(_out ${CMAKE_BINARY_DIR}/cli-tests)

add_test(NAME cli_test_example
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=test;${_ex}/head_tracker_tests.toml;-o;${_out}/cal_test"
          -DOUT=${_out}/cal_test
          "-DFILES=tests.csv;sensitivity.csv;report.html;simulated_readings.csv;simulated_calibration.toml"
          "-DEXPECT_STDOUT=78 tests of layout .* on a head tracker; largest \\|error\\| [0-9.]+ µm .*pass, [0-9]+ fail"
          -P ${_cli}/expect_outputs.cmake)
set_tests_properties(cli_test_example PROPERTIES FIXTURES_SETUP vlt_cal_test)
add_test(NAME cli_test_reproduces_shipped_readings
  COMMAND ${CMAKE_COMMAND} -E compare_files ${_out}/cal_test/simulated_readings.csv ${_ex}/simulated_readings.csv)
add_test(NAME cli_test_reproduces_shipped_calibration_input
  COMMAND ${CMAKE_COMMAND} -E compare_files ${_out}/cal_test/simulated_calibration.toml ${_ex}/simulated_calibration.toml)
add_test(NAME report_browser_test
  COMMAND ${CMAKE_COMMAND} -DPAGE=${_out}/cal_test/report.html -DPROFILE=${_out}/chromium-profile-cal-test
          -DMIN_PLOTS=1 -P ${_cli}/report_browser.cmake)
set_tests_properties(cli_test_reproduces_shipped_readings cli_test_reproduces_shipped_calibration_input
  report_browser_test PROPERTIES FIXTURES_REQUIRED vlt_cal_test)
set_tests_properties(report_browser_test PROPERTIES TIMEOUT 300)

# Report safety (issue 32): tests named to end the report's script and run their own; the names are
# shown literally (escaped in the tables) and in the browser nothing of them runs.
vlt_hostile_report(test report.html "tests.csv;report.html"
                   "report.html:&lt;/script&gt;&lt;script&gt;window[.]vltErrors[.]push" 1
                   test ${_cal_jobs}/hostile_tests.toml)
vlt_hostile_report(calibrate report.html "residuals.csv;report.html;calibration.toml"
                   "report.html:&lt;/script&gt;&lt;script&gt;window[.]vltErrors[.]push" 1
                   calibrate ${_cal_jobs}/hostile_calibration.toml)

add_test(NAME cli_calibrate_example
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=calibrate;${_ex}/simulated_calibration.toml;-o;${_out}/cal_calibrate"
          -DOUT=${_out}/cal_calibrate
          "-DFILES=calibration.toml;parameters.csv;correlation.csv;identifiability.csv;targets.csv;residuals.csv;report.html"
          "-DEXPECT_STDOUT=511 observations; 12 of 20 parameters identified.*held: .*lam .*srr \\(the data are blind to it\\)"
          # Every parameter named in words beside its symbol (issue 34): lam's meaning from the spec.
          "-DEXPECT_FILE_REGEX=report.html:<td class=\"l\">lam</td>.*<td class=\"l\">Range offset lambda [(]NPL[)]"
          -P ${_cli}/expect_outputs.cmake)
set_tests_properties(cli_calibrate_example PROPERTIES FIXTURES_SETUP vlt_cal_calibrate)
find_package(Python3 COMPONENTS Interpreter REQUIRED)
add_test(NAME cli_calibrate_reproduces_shipped_file
  COMMAND ${Python3_EXECUTABLE} ${_cli}/compare_calibration.py ${_out}/cal_calibrate/calibration.toml
          ${_ex}/calibration.toml)
add_test(NAME report_browser_calibrate
  COMMAND ${CMAKE_COMMAND} -DPAGE=${_out}/cal_calibrate/report.html -DPROFILE=${_out}/chromium-profile-cal
          -DMIN_PLOTS=1 -P ${_cli}/report_browser.cmake)
set_tests_properties(cli_calibrate_reproduces_shipped_file report_browser_calibrate PROPERTIES
  FIXTURES_REQUIRED vlt_cal_calibrate)
set_tests_properties(report_browser_calibrate PROPERTIES TIMEOUT 300)

# The job that uses the shipped calibration file: runs, the summary and results.json name the file.
add_test(NAME cli_run_with_calibration_summary
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=run;${_ex}/measure_with_calibration.toml;--no-mcm;-o;${_out}/cal_measure_summary"
          -DOUT=${_out}/cal_measure_summary "-DFILES=points.csv;results.json;report.html"
          "-DEXPECT_STDOUT=Tracker parameters from the calibration file .*calibration[.]toml [(]instrument 'simulated head tracker"
          -P ${_cli}/expect_outputs.cmake)
add_test(NAME cli_run_with_calibration
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=--json;run;${_ex}/measure_with_calibration.toml;--trials;4000;-o;${_out}/cal_measure"
          -DOUT=${_out}/cal_measure "-DFILES=points.csv;budget.csv;tasks.csv;results.json;report.html"
          "-DEXPECT_STDOUT=\"calibration\": {[^}]*\"file\": \"[^\"]*calibration\\.toml\"[^}]*\"instrument\": \"simulated head tracker"
          -P ${_cli}/expect_outputs.cmake)

# The loop closed (issue 34): the calibration `vlt calibrate` just wrote, used with --calibration
# (relative to the working directory) in place of the job's [tracker] calibration; a missing one is
# one line naming the option, exit 2.
add_test(NAME cli_run_with_new_calibration
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=run;${_ex}/measure_with_calibration.toml;--calibration;${_out}/cal_calibrate/calibration.toml;--no-mcm;-o;${_out}/cal_measure_new"
          -DOUT=${_out}/cal_measure_new "-DFILES=points.csv;results.json;report.html"
          "-DEXPECT_STDOUT=Tracker parameters from the calibration file [^\n]*cal_calibrate/calibration[.]toml [(]instrument"
          -P ${_cli}/expect_outputs.cmake)
set_tests_properties(cli_run_with_new_calibration PROPERTIES FIXTURES_REQUIRED vlt_cal_calibrate)
add_test(NAME cli_error_run_calibration_option_missing
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=run;${_ex}/measure_with_calibration.toml;--calibration;${_out}/no_such_calibration.toml;-o;${_out}/error_calibration_option"
          -DOUT=${_out}/error_calibration_option "-DEXPECT=--calibration: cannot read '[^']*no_such_calibration[.]toml': "
          -P ${_cli}/expect_error.cmake)
# A path longer than 160 characters is cut in the middle: the file name stays on the line.
string(REPEAT "d" 150 _deep)
add_test(NAME cli_error_run_calibration_long_path_keeps_name
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=run;${_ex}/measure_with_calibration.toml;--calibration;${_out}/${_deep}/no_such_calibration.toml;-o;${_out}/error_calibration_long"
          -DOUT=${_out}/error_calibration_long
          "-DEXPECT=--calibration: cannot read '[^']*[.][.][.][(][0-9]+ characters[)][.][.][.]d*/no_such_calibration[.]toml': no such file"
          -P ${_cli}/expect_error.cmake)

# Bad input: one line naming file and key or line, exit 2, nothing written.
function(vlt_calibration_error name command file regex)
  add_test(NAME cli_error_${name}
    COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
            "-DARGS=${command};${_cal_jobs}/${file};-o;${_out}/error_${name}"
            -DOUT=${_out}/error_${name} "-DEXPECT=${regex}" -P ${_cli}/expect_error.cmake)
endfunction()
vlt_calibration_error(calibrate_unknown_target calibrate unknown_target.toml
                      "unknown_target\\.toml: bar\\[0\\]: target 'NOPE' has no readings")
vlt_calibration_error(calibrate_too_few calibrate too_few.toml
                      "too_few\\.toml: [0-9]+ scalar observations for [0-9]+ unknowns .*too few observations")
vlt_calibration_error(calibrate_not_converged calibrate not_converged.toml
                      "not_converged\\.toml: the calibration did not converge in 1 iterations")
vlt_calibration_error(calibrate_unknown_fit calibrate unknown_fit.toml
                      "unknown_fit\\.toml: calibration\\.fit: unknown parameter 'lambda' of model 'head'")
vlt_calibration_error(calibrate_nothing_to_fit calibrate nothing_to_fit.toml
                      "nothing_to_fit\\.toml: calibration\\.fit: no parameter is left to identify")
vlt_calibration_error(calibrate_bar_without_u calibrate bar_without_u.toml
                      "bar_without_u\\.toml: bar\\[0\\]\\.u: required key is missing")
vlt_calibration_error(test_bad_orientation test bad_orientation.toml
                      "bad_layout\\.toml: length\\[0\\]\\.orientation: 'diagonal' \\(expected horizontal")
vlt_calibration_error(test_unknown_bar test unknown_bar.toml "unknown_bar_layout\\.toml: length\\[0\\]\\.bar: bar 'b2' is not defined")
vlt_calibration_error(run_calibration_wrong_model run wrong_model.toml
                      "wrong_model\\.toml: tracker\\.calibration: the calibration file is for model 'head', the tracker is model 'mirror'")
vlt_calibration_error(run_calibration_and_parameter run calibration_and_parameter.toml
                      "calibration_and_parameter\\.toml: tracker\\.parameters\\.ex: parameter 'ex' is given by the calibration file")
vlt_calibration_error(run_calibration_missing run calibration_missing.toml
                      "calibration_missing\\.toml: tracker\\.calibration: cannot read '.*no_such\\.toml'")

foreach(cmd test calibrate)
  add_test(NAME cli_help_${cmd} COMMAND vlt ${cmd} --help)
  set_tests_properties(cli_help_${cmd} PROPERTIES PASS_REGULAR_EXPRESSION "Usage:.*${cmd}")
endforeach()

# The report of the job with a calibration draws (its notes name the calibration file).
set_tests_properties(cli_run_with_calibration_summary PROPERTIES FIXTURES_SETUP vlt_cal_measure)
add_test(NAME report_browser_with_calibration
  COMMAND ${CMAKE_COMMAND} -DPAGE=${_out}/cal_measure_summary/report.html -DPROFILE=${_out}/chromium-profile-cal-measure
          -DMIN_PLOTS=3 -P ${_cli}/report_browser.cmake)
set_tests_properties(report_browser_with_calibration PROPERTIES FIXTURES_REQUIRED vlt_cal_measure TIMEOUT 300)

# A calibration that does not fit its data is not used silently (docs/calibration.md "Fit"): the
# mirror model fitted to head-tracker data warns and its calibration.toml says fits = false;
# under --strict nothing is written; a job loading a file marked so warns, and fails under --strict.
# (A long path in quotes is shortened in messages: the file is matched as any quoted text.)
add_test(NAME cli_calibrate_unfit_warns
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=calibrate;${_cli}/calibration/mirror_on_head.toml;-o;${_out}/cal_unfit" -DEXPECT_RC=0
          "-DEXPECT_STDERR=^vlt: warning: .*mirror_on_head[.]toml: calibration: the data do not fit the model: chi2 = [0-9.]+ for [0-9]+ degrees of freedom [(]Birge ratio [0-9.]+, p = .*[)]; calibration[.]toml says so"
          -DCLEAN=${_out}/cal_unfit -P ${_cli}/expect_run.cmake)
add_test(NAME cli_error_calibrate_unfit_strict
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=--strict;calibrate;${_cli}/calibration/mirror_on_head.toml;-o;${_out}/cal_unfit_strict"
          -DOUT=${_out}/cal_unfit_strict
          "-DEXPECT=mirror_on_head[.]toml: calibration: the data do not fit the model: .* [(]a warning; --strict makes it an error[)]"
          -P ${_cli}/expect_error.cmake)
add_test(NAME cli_run_unfit_calibration_warns
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=run;${_cli}/calibration/measure_with_unfit.toml;--no-mcm;-o;${_out}/cal_unfit_run" -DEXPECT_RC=0
          "-DEXPECT_STDERR=^vlt: warning: .*measure_with_unfit[.]toml: tracker[.]calibration: '[^']*' is a calibration that does not fit its data [(]the data do not fit the model: .*[)]: its uncertainties understate the tracker's errors"
          -DCLEAN=${_out}/cal_unfit_run -P ${_cli}/expect_run.cmake)
add_test(NAME cli_error_run_unfit_calibration_strict
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=--strict;run;${_cli}/calibration/measure_with_unfit.toml;--no-mcm;-o;${_out}/cal_unfit_run_strict"
          -DOUT=${_out}/cal_unfit_run_strict
          "-DEXPECT=measure_with_unfit[.]toml: tracker[.]calibration: '[^']*' is a calibration that does not fit its data"
          -P ${_cli}/expect_error.cmake)
