# Priors from a datasheet on the command line (docs/profiles.md): every shipped profile round-trips
# through `vlt test` (its own propagation of the prior file) and a job runs with it; bad input is
# one line, exit 2, nothing written.
if(NOT TARGET vlt)
  return()
endif()
set(_cli ${CMAKE_CURRENT_SOURCE_DIR}/cli)
set(_prior ${_cli}/prior)
set(_out ${CMAKE_BINARY_DIR}/cli-tests)

# profile -> a job of the same architecture that runs with its prior
foreach(pair "leica-at500:calibration/measure_with_calibration.toml"
             "faro-vantage:calibration/measure_with_calibration.toml"
             "mirror-15um-6um:online_readings.toml")
  string(REPLACE ":" ";" pair "${pair}")
  list(GET pair 0 profile)
  list(GET pair 1 job)
  add_test(NAME cli_prior_roundtrip_${profile}
    COMMAND ${Python3_EXECUTABLE} ${_cli}/check_prior_roundtrip.py $<TARGET_FILE:vlt>
            ${CMAKE_SOURCE_DIR}/profiles/${profile}.toml ${_out}/prior_${profile}
            ${CMAKE_SOURCE_DIR}/examples/${job})
  set_tests_properties(cli_prior_roundtrip_${profile} PROPERTIES
    PASS_REGULAR_EXPRESSION "ok: [0-9]+ length/ranging tests agree with vlt test, all [0-9]+ meet their MPE")
endforeach()

function(vlt_prior_error name regex)
  add_test(NAME cli_error_prior_${name}
    COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
            "-DARGS=prior;${_prior}/${name}.toml;-o;${_out}/error_prior_${name}"
            -DOUT=${_out}/error_prior_${name} "-DEXPECT=${regex}" -P ${_cli}/expect_error.cmake)
endfunction()
vlt_prior_error(noise_too_big
  "noise_too_big\\.toml: tests\\.mpe\\.ranging: test 'RG2': the reading noise alone \\([0-9.]+ µm at p = 0\\.95\\) exceeds its MPE \\(10 µm\\)")
vlt_prior_error(with_estimate "with_estimate\\.toml: tracker\\.parameters\\.ex: a profile gives only u")
vlt_prior_error(no_mpe "no_mpe\\.toml: tests\\.mpe: a profile needs at least one MPE")
vlt_prior_error(bad_bound "bad_bound\\.toml: prior\\.bound: expected a multiple of the generic u from 1 to 1000")
vlt_prior_error(bad_probability "bad_probability\\.toml: prior\\.conformance_probability: must be between 0 and 1")
# A tiny probability (5e-324) hung the two-face quantile's bracket, whose start was 0.
vlt_prior_error(tiny_probability "tiny_probability\\.toml: prior\\.conformance_probability: an MPE statement's probability of conformance is at least 0\\.5")
vlt_prior_error(source_two_lines "source_two_lines\\.toml: prior\\.source\\.ranging: a control character")
vlt_prior_error(test_keys "test_keys\\.toml: tests\\.coverage_probability: unknown key")

# The built-in priors (profiles/priors/, compiled in) are what `vlt prior` derives from the shipped
# profiles now: every key and text, every number to 1e-9 relative (tests/cli/compare_calibration.py).
# Regenerate with: SOURCE_DATE_EPOCH=... vlt prior profiles/<name>.toml -o DIR; cp DIR/prior.toml profiles/priors/<name>.toml
foreach(profile leica-at500 faro-vantage mirror-15um-6um)
  set_tests_properties(cli_prior_roundtrip_${profile} PROPERTIES FIXTURES_SETUP vlt_prior_${profile})
  add_test(NAME cli_prior_reproduces_shipped_${profile}
    COMMAND ${Python3_EXECUTABLE} ${_cli}/compare_calibration.py ${_out}/prior_${profile}/prior/prior.toml
            ${CMAKE_SOURCE_DIR}/profiles/priors/${profile}.toml)
  set_tests_properties(cli_prior_reproduces_shipped_${profile} PROPERTIES FIXTURES_REQUIRED vlt_prior_${profile})
endforeach()

# `[tracker] profile = "<name>"`: the built-in prior, the same numbers as the file through --calibration.
set(_ex ${CMAKE_SOURCE_DIR}/examples/calibration)
add_test(NAME cli_run_with_profile
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=run;${_ex}/measure_with_profile.toml;-o;${_out}/run_with_profile"
          -DOUT=${_out}/run_with_profile "-DFILES=points.csv;results.json;report.html"
          "-DEXPECT_STDOUT=Tracker parameters: a prior from the datasheet's MPE [(]profile 'leica-at500' [(]built in[)], 'Leica Absolute Tracker AT500'"
          -P ${_cli}/expect_outputs.cmake)
add_test(NAME cli_run_with_prior_file
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=run;${_ex}/measure_with_profile.toml;--calibration;${CMAKE_SOURCE_DIR}/profiles/priors/leica-at500.toml;-o;${_out}/run_with_prior_file"
          -DOUT=${_out}/run_with_prior_file "-DFILES=points.csv"
          "-DEXPECT_STDOUT=Tracker parameters: a prior from the datasheet's MPE"
          -P ${_cli}/expect_outputs.cmake)
set_tests_properties(cli_run_with_profile cli_run_with_prior_file PROPERTIES FIXTURES_SETUP vlt_run_profile)
add_test(NAME cli_run_profile_equals_prior_file
  COMMAND ${CMAKE_COMMAND} -E compare_files ${_out}/run_with_profile/points.csv ${_out}/run_with_prior_file/points.csv)
set_tests_properties(cli_run_profile_equals_prior_file PROPERTIES FIXTURES_REQUIRED vlt_run_profile)
function(vlt_profile_error name regex)
  add_test(NAME cli_error_profile_${name}
    COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
            "-DARGS=run;${_prior}/${name}.toml;-o;${_out}/error_profile_${name}"
            -DOUT=${_out}/error_profile_${name} "-DEXPECT=${regex}" -P ${_cli}/expect_error.cmake)
endfunction()
vlt_profile_error(unknown_profile "unknown_profile\\.toml: tracker\\.profile: unknown profile 'nope' [(]built in: faro-vantage, leica-at500, mirror-15um-6um")
vlt_profile_error(profile_and_calibration "profile_and_calibration\\.toml: tracker\\.profile: a job takes its parameters from a calibration or from a profile, not both")

# Report safety (issue 32): hostile test names, profile name, instrument and sources are shown
# literally (escaped in the tables and the plot data) and in the browser nothing of them runs.
vlt_hostile_report(prior report.html "prior.toml;tests.csv;shares.csv;report.html"
                   "report.html:&lt;/script&gt;&lt;script&gt;window[.]vltErrors[.]push[(]'source ran'[)]" 1
                   prior ${_prior}/hostile_profile.toml)
vlt_prior_error(source_bad_key "source_bad_key\\.toml: prior\\.source: a key of letters, digits")
vlt_prior_error(zero_mpe "zero_mpe\\.toml: tests\\.mpe\\.ranging: an MPE of zero: no instrument meets it")
