# Networks on the command line (docs/network.md): the shipped offline plan runs and writes its
# simulated measurement, which adjusts as an online network; bad input is one line, exit 2,
# nothing written.
if(NOT TARGET vlt)
  return()
endif()
set(_cli ${CMAKE_CURRENT_SOURCE_DIR}/cli)
set(_ex ${CMAKE_SOURCE_DIR}/examples/network)
set(_out ${CMAKE_BINARY_DIR}/cli-tests)

add_test(NAME cli_network_plan
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=network;${_ex}/wing_network_plan.toml;--simulate;7;-o;${_out}/network_plan"
          -DOUT=${_out}/network_plan
          "-DFILES=targets.csv;stations.csv;residuals.csv;covariance.csv;tasks.csv;results.json;report.html;simulated_S1.csv;simulated_S2.csv;simulated_S3.csv;simulated_network.toml"
          "-DEXPECT_STDOUT=Planned network 'wing-network-plan': 3 stations, 18 targets, 159 observations, 72 unknowns, dof 87; predicted: largest \\|U\\| [(]k = 1[.]96[)] [0-9.]+ µm at"
          "-DJSON_KEYS=schema;created;vlt_version;vlt_commit;units;job;summary;stations;targets;tasks;files"
          -DSCHEMA=vlt-network/1 -P ${_cli}/expect_outputs.cmake)
set_tests_properties(cli_network_plan PROPERTIES FIXTURES_SETUP vlt_network_plan)
add_test(NAME cli_network_simulated
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=network;${_out}/network_plan/simulated_network.toml;-o;${_out}/network_simulated"
          -DOUT=${_out}/network_simulated
          "-DFILES=targets.csv;stations.csv;residuals.csv;covariance.csv;tasks.csv;results.json;report.html"
          "-DEXPECT_STDOUT=Measured network 'wing-network-plan-simulated-7': 3 stations, 18 targets, 159 observations, 72 unknowns, dof 87; chi2 [0-9.]+, Birge ratio [0-9.]+"
          "-DJSON_KEYS=schema;created;vlt_version;vlt_commit;units;job;summary;stations;targets;tasks;files"
          -DSCHEMA=vlt-network/1 -P ${_cli}/expect_outputs.cmake)
set_tests_properties(cli_network_simulated PROPERTIES FIXTURES_REQUIRED vlt_network_plan FIXTURES_SETUP vlt_network_simulated)
add_test(NAME report_browser_network
  COMMAND ${CMAKE_COMMAND} -DPAGE=${_out}/network_simulated/report.html -DPROFILE=${_out}/chromium-profile-network
          -DMIN_PLOTS=1 -P ${_cli}/report_browser.cmake)
set_tests_properties(report_browser_network PROPERTIES FIXTURES_REQUIRED vlt_network_simulated TIMEOUT 300)
# A hostile station name (issue 32): shown literally in the report's tables; in the browser the
# page draws with no script error, which fails if the name closes the figures' <script> (its own
# script would run, the page's would break).
add_test(NAME cli_network_hostile_names
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=network;${_cli}/network/hostile_names.toml;-o;${_out}/network_hostile"
          -DOUT=${_out}/network_hostile "-DFILES=results.json;report.html"
          "-DEXPECT_FILE_REGEX=report.html:&lt;/script&gt;&lt;script&gt;window[.]vltErrors[.]push"
          "-DJSON_KEYS=schema;summary;stations;targets;files" -DSCHEMA=vlt-network/1
          -P ${_cli}/expect_outputs.cmake)
set_tests_properties(cli_network_hostile_names PROPERTIES FIXTURES_SETUP vlt_network_hostile)
add_test(NAME report_browser_network_hostile
  COMMAND ${CMAKE_COMMAND} -DPAGE=${_out}/network_hostile/report.html -DPROFILE=${_out}/chromium-profile-hostile
          -DMIN_PLOTS=1 -P ${_cli}/report_browser.cmake)
set_tests_properties(report_browser_network_hostile PROPERTIES FIXTURES_REQUIRED vlt_network_hostile TIMEOUT 300)

# Scale bars (docs/network.md N-4a): a plan held by S1 whose scale the bars give, its simulated
# measurement adjusted (distances.csv), and a second run into the same directory (the marker lists
# every file the first one wrote, simulated_<station>.csv among them).
add_test(NAME cli_network_scale_bars
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=network;${_ex}/scale_bar_network.toml;--simulate;11;-o;${_out}/network_bars"
          -DOUT=${_out}/network_bars
          "-DFILES=targets.csv;stations.csv;residuals.csv;covariance.csv;distances.csv;parameters.csv;identifiability.csv;results.json;report.html;simulated_S1.csv;simulated_network.toml"
          "-DEXPECT_STDOUT=Planned network 'scale-bar-network': 3 stations, 20 targets, 184 observations, 73 unknowns, dof 111; predicted: largest.*Scale bars and distances: 3.*Self-calibration: 1 of 1 combinations"
          "-DJSON_KEYS=schema;summary;targets;parameters;identifiability;distances;robust;files"
          -DSCHEMA=vlt-network/1 -P ${_cli}/expect_outputs.cmake)
set_tests_properties(cli_network_scale_bars PROPERTIES FIXTURES_SETUP vlt_network_bars)
add_test(NAME cli_network_scale_bars_simulated
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=network;${_out}/network_bars/simulated_network.toml;-o;${_out}/network_bars_simulated"
          -DOUT=${_out}/network_bars_simulated
          "-DFILES=distances.csv;parameters.csv;results.json;report.html"
          "-DEXPECT_STDOUT=Measured network 'scale-bar-network-simulated-11': 3 stations, 20 targets, 184 observations.*Scale bars and distances: 3"
          "-DJSON_KEYS=schema;summary;distances;robust;files"
          -DSCHEMA=vlt-network/1 -P ${_cli}/expect_outputs.cmake)
set_tests_properties(cli_network_scale_bars_simulated PROPERTIES FIXTURES_REQUIRED vlt_network_bars)
add_test(NAME cli_network_rerun_same_directory
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=network;${_ex}/scale_bar_network.toml;--simulate;11;-o;${_out}/network_bars_again"
          -DOUT=${_out}/network_bars_again -DTWICE=ON
          "-DFILES=simulated_S1.csv;simulated_network.toml;distances.csv"
          "-DJSON_KEYS=schema;files" -DSCHEMA=vlt-network/1 -P ${_cli}/expect_outputs.cmake)

add_test(NAME cli_network_two_instruments
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=network;${_cli}/network/two_instruments.toml;-o;${_out}/network_two_instruments"
          -DOUT=${_out}/network_two_instruments
          "-DFILES=targets.csv;stations.csv;residuals.csv;covariance.csv;identifiability.csv;parameters.csv;results.json;report.html"
          "-DEXPECT_STDOUT=Planned network 'two-instruments': 3 stations, 18 targets, 164 observations, 68 unknowns, dof 96.*Self-calibration: [0-9] of 2 combinations of the 2 inputs determined by the network"
          "-DJSON_KEYS=schema;created;vlt_version;vlt_commit;units;job;summary;stations;targets;parameters;identifiability;tasks;files"
          -DSCHEMA=vlt-network/1 -P ${_cli}/expect_outputs.cmake)

# Air per station (docs/network.md N-2a): four stations over a shift, two sensors; the plan, its
# simulated measurement adjusted, each station's air in results.json and the report.
add_test(NAME cli_network_station_air
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=network;${_ex}/hall_air_network.toml;--simulate;5;-o;${_out}/network_air"
          -DOUT=${_out}/network_air
          "-DFILES=targets.csv;stations.csv;distances.csv;results.json;report.html;simulated_S4.csv;simulated_network.toml"
          "-DEXPECT_STDOUT=Planned network 'hall-air-network': 4 stations, 20 targets, [0-9]+ observations, [0-9]+ unknowns, dof [0-9]+; predicted: largest"
          "-DEXPECT_FILE_REGEX=results.json:\"air\": {[^}]*\"temperature\": 21[.]7[^}]*\"u_temperature\": 0[.]6[^}]*\"sensor\": \"WS2\""
          "-DJSON_KEYS=schema;summary;stations;targets;distances;files"
          -DSCHEMA=vlt-network/1 -P ${_cli}/expect_outputs.cmake)
set_tests_properties(cli_network_station_air PROPERTIES FIXTURES_SETUP vlt_network_air)
add_test(NAME cli_network_station_air_simulated
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=network;${_out}/network_air/simulated_network.toml;-o;${_out}/network_air_simulated"
          -DOUT=${_out}/network_air_simulated
          "-DFILES=targets.csv;results.json;report.html"
          "-DEXPECT_STDOUT=Measured network 'hall-air-network-simulated-5': 4 stations, 20 targets"
          "-DEXPECT_FILE_REGEX=report.html:<h2>Air per station</h2>"
          "-DJSON_KEYS=schema;summary;stations;files"
          -DSCHEMA=vlt-network/1 -P ${_cli}/expect_outputs.cmake)
set_tests_properties(cli_network_station_air_simulated PROPERTIES FIXTURES_REQUIRED vlt_network_air)

function(vlt_network_error name file regex)
  add_test(NAME cli_error_network_${name}
    COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
            "-DARGS=network;${_cli}/network/${file};${ARGN};-o;${_out}/error_network_${name}"
            -DOUT=${_out}/error_network_${name} "-DEXPECT=${regex}" -P ${_cli}/expect_error.cmake)
endfunction()
vlt_network_error(no_datum no_datum.toml "no_datum\\.toml: datum: the part frame is undetermined")
vlt_network_error(disconnected disconnected.toml
                  "disconnected\\.toml: station\\[1\\]: station 'S2' shares fewer than 3 non-collinear targets .*disconnected network")
vlt_network_error(unknown_sighting unknown_sighting.toml "unknown_sighting\\.toml: station\\[0\\]\\.sees: unknown target 'NOPE'")
vlt_network_error(mixed mixed.toml "mixed\\.toml: station\\[1\\]: every station gives readings .* not a mix")
vlt_network_error(collinear collinear.toml "collinear\\.toml: datum: the references do not fix the part frame")
vlt_network_error(unknown_input unknown_input.toml "unknown_input\\.toml: network\\.self_calibrate: unknown input 'tmv'")
vlt_network_error(unknown_task_target unknown_distance.toml
                  "unknown_distance\\.toml: task\\[0\\]\\.points: task 'd': point 'W99' not measured")
vlt_network_error(missing_instrument missing_instrument.toml
                  "missing_instrument\\.toml: station\\[2\\]\\.instrument: required key is missing [(]the network has several instruments[)]")
vlt_network_error(scale_bar_same_target scale_bar_same_target.toml
                  "scale_bar_same_target\\.toml: scale_bar\\[0\\]\\.to: the same target as `from`")
vlt_network_error(scale_bar_unknown_target scale_bar_unknown_target.toml
                  "scale_bar_unknown_target\\.toml: scale_bar\\[0\\]\\.from: unknown target 'NOPE' [(]not in \\[targets\\][)]")
vlt_network_error(distance_no_u scale_bar_no_u.toml
                  "scale_bar_no_u\\.toml: distance\\[0\\]\\.u: required key is missing")
add_test(NAME cli_error_network_simulate_online
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=network;${_out}/network_plan/simulated_network.toml;--simulate;3;-o;${_out}/error_network_simulate_online"
          -DOUT=${_out}/error_network_simulate_online
          "-DEXPECT=simulated_network\\.toml: station: --simulate needs an offline network" -P ${_cli}/expect_error.cmake)
set_tests_properties(cli_error_network_simulate_online PROPERTIES FIXTURES_REQUIRED vlt_network_plan)
# A seed past 2^64 - 1 is refused, not clamped to 2^63 - 1 (issue 32: numbers that slip through).
add_test(NAME cli_error_network_simulate_seed_overflow
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=network;${_ex}/wing_network_plan.toml;--simulate;18446744073709551616;-o;${_out}/error_network_simulate_seed"
          -DOUT=${_out}/error_network_simulate_seed
          "-DEXPECT=command line: --simulate: '18446744073709551616' is not an integer in 0 \\.\\. 18446744073709551615"
          -P ${_cli}/expect_error.cmake)
vlt_network_error(air_unknown_sensor air_unknown_sensor.toml
                  "air_unknown_sensor\\.toml: station\\[1\\]\\.environment\\.sensor: unknown air sensor 'WS9'")
vlt_network_error(air_below_sensor air_below_sensor.toml
                  "air_below_sensor\\.toml: station\\[1\\]\\.environment\\.temperature: u below the u of its sensor 'WS1'")
vlt_network_error(air_change_no_from air_change_no_from.toml
                  "air_change_no_from\\.toml: station\\[1\\]\\.environment\\[1\\]\\.from: required key is missing")
vlt_network_error(air_change_outside air_change_outside.toml
                  "air_change_outside\\.toml: station\\[1\\]\\.environment\\[1\\]\\.from: outside the station's readings")
vlt_network_error(air_change_kinds air_change_kinds.toml
                  "air_change_kinds\\.toml: station\\[1\\]\\.environment\\[2\\]\\.from: seconds, but .*environment\\[1\\]\\.from gives a date and time")
vlt_network_error(air_change_offline air_change_offline.toml
                  "air_change_offline\\.toml: station\\[1\\]\\.environment\\[1\\]: air that changes during a station's readings is for measured readings")

# Drift (docs/network.md N-12): S2 drifts over 2 h 15 min with three drift checks; the adjustment
# estimates the drift at every knot (drift.csv, results.json stations[].drift, the report's chart)
# and the Monte Carlo validation re-adjusts networks whose drift is drawn from its prior. S2's air
# changes at 09:40 (N-2a): results.json stations[].air_changes.
add_test(NAME cli_network_drift
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=network;${_ex}/drift_network.toml;-o;${_out}/network_drift"
          -DOUT=${_out}/network_drift
          "-DFILES=targets.csv;stations.csv;residuals.csv;drift.csv;covariance.csv;tasks.csv;mcm.csv;results.json;report.html"
          "-DEXPECT_STDOUT=Measured network 'drift-network': 3 stations, 18 targets, 216 observations, 84 unknowns, dof 132.*Drift of station S2 over 2[.]25 h [(]4 knots[)]: [0-9.]+ µm, U [0-9.]+ µm.*the GUM agrees"
          "-DEXPECT_FILE_REGEX=results.json:\"air_changes\": \\[\n *{\n *\"time\": 1795686000[.]0,\n *\"elapsed_h\": 2[.]166[0-9]*,\n *\"temperature\": 21[.]2,[^}]*\"sensor\": \"WS1\"\n *}\n *\\],\n *\"drift\": {[^}]*\"model\": \"linear\",[^}]*\"translation_rate\": 2[.]7[0-9]*e-09"
          "-DJSON_KEYS=schema;summary;stations;targets;monte_carlo;files"
          -DSCHEMA=vlt-network/1 -P ${_cli}/expect_outputs.cmake)
set_tests_properties(cli_network_drift PROPERTIES FIXTURES_SETUP vlt_network_drift)
add_test(NAME report_browser_network_drift
  COMMAND ${CMAKE_COMMAND} -DPAGE=${_out}/network_drift/report.html -DPROFILE=${_out}/chromium-profile-drift
          -DMIN_PLOTS=2 -P ${_cli}/report_browser.cmake)
set_tests_properties(report_browser_network_drift PROPERTIES FIXTURES_REQUIRED vlt_network_drift TIMEOUT 300)
# Drift planned offline (N-12): S2 of the wing plan reads a target every 5 min and re-reads R1..R4
# at 30 and 60 min; the plan has 4 knots over 85 min (18 readings, the last at 17 x 5 min). Its
# simulated measurement writes the readings' times and each check's readings in their own file, and
# adjusts as a measured drifting network with the same knots and observations.
add_test(NAME cli_network_drift_plan
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=network;${_ex}/drift_network_plan.toml;--simulate;7;-o;${_out}/network_drift_plan"
          -DOUT=${_out}/network_drift_plan
          "-DFILES=targets.csv;stations.csv;drift.csv;results.json;report.html;simulated_S2.csv;simulated_S2_check1.csv;simulated_S2_check2.csv;simulated_network.toml"
          "-DEXPECT_STDOUT=Planned network 'drift-network-plan': 3 stations, 18 targets, 201 observations, 90 unknowns, dof 111;.*Drift of station S2 over 1[.]42 h [(]4 knots[)]: predicted U [0-9.]+ µm at the last knot"
          "-DEXPECT_FILE_REGEX=simulated_S2_check2.csv:^name,range,azimuth,elevation,face,time\nR1,[0-9.]+,[0-9.]+,-?[0-9.e-]+,front,3600\n"
          "-DJSON_KEYS=schema;created;vlt_version;vlt_commit;units;job;summary;stations;targets;tasks;files"
          -DSCHEMA=vlt-network/1 -P ${_cli}/expect_outputs.cmake)
set_tests_properties(cli_network_drift_plan PROPERTIES FIXTURES_SETUP vlt_network_drift_plan)
add_test(NAME cli_network_drift_plan_simulated
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=network;${_out}/network_drift_plan/simulated_network.toml;-o;${_out}/network_drift_plan_simulated"
          -DOUT=${_out}/network_drift_plan_simulated "-DFILES=targets.csv;drift.csv;results.json"
          "-DEXPECT_STDOUT=Measured network 'drift-network-plan-simulated-7': 3 stations, 18 targets, 201 observations, 90 unknowns, dof 111;.*Drift of station S2 over 1[.]42 h [(]4 knots[)]: [0-9.]+ µm, U [0-9.]+ µm"
          "-DJSON_KEYS=schema;created;vlt_version;vlt_commit;units;job;summary;stations;targets;tasks;files"
          -DSCHEMA=vlt-network/1 -P ${_cli}/expect_outputs.cmake)
set_tests_properties(cli_network_drift_plan_simulated PROPERTIES FIXTURES_REQUIRED vlt_network_drift_plan)
add_test(NAME cli_network_one_station_drift
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=network;${_cli}/network/one_station_drift.toml;-o;${_out}/network_one_station_drift"
          -DOUT=${_out}/network_one_station_drift "-DFILES=targets.csv;drift.csv;results.json"
          "-DEXPECT_STDOUT=Measured network 'one-station-drift': 1 station, 18 targets, 108 observations, 72 unknowns, dof 36;.*Drift of station S2 over 2[.]25 h [(]4 knots[)]: [0-9.]+ µm, U [0-9.]+ µm"
          "-DJSON_KEYS=schema;created;vlt_version;vlt_commit;units;job;summary;stations;targets;tasks;files"
          -DSCHEMA=vlt-network/1 -P ${_cli}/expect_outputs.cmake)
vlt_network_error(drift_plan_no_interval drift_plan_no_interval.toml
                  "drift_plan_no_interval\\.toml: station\\[1\\]\\.drift: interval: required key is missing [(]offline")
vlt_network_error(drift_plan_short_interval drift_plan_short_interval.toml
                  "drift_plan_short_interval\\.toml: station\\[1\\]\\.drift\\.interval: a duration from 1 s to 24 h")
vlt_network_error(drift_plan_check_readings drift_plan_check_readings.toml
                  "drift_plan_check_readings\\.toml: drift_check\\[0\\]\\.readings: an offline drift check plans what it will re-read")
vlt_network_error(drift_plan_clock_time drift_plan_clock_time.toml
                  "drift_plan_clock_time\\.toml: drift_check\\[0\\]\\.time: offline, a duration after the station's first planned reading .*not a clock time")
vlt_network_error(drift_online_interval drift_online_interval.toml
                  "drift_online_interval\\.toml: station\\[1\\]\\.drift\\.interval: for an offline station [(]sees[)] only")
vlt_network_error(drift_online_sees drift_online_sees.toml
                  "drift_online_sees\\.toml: drift_check\\[0\\]\\.sees: a measured drift check gives what it read")
vlt_network_error(drift_check_still drift_check_still.toml
                  "drift_check_still\\.toml: drift_check\\[0\\]\\.station: station 'S2' has no drift model")
vlt_network_error(drift_no_time drift_no_time.toml
                  "drift_S2_check1\\.csv: line 2: station 'S2' has a drift model: every reading needs its time")
vlt_network_error(drift_mixed_times drift_mixed_times.toml
                  "drift_S2_check1\\.csv: line 2: time: a clock time, but .*drift_S1\\.csv: line 2 gives a date and time")
vlt_network_error(drift_bad_rate drift_bad_rate.toml
                  "drift_bad_rate\\.toml: station\\[1\\]\\.drift\\.translation_rate: expected a rate such as \"10 um/h\"")

# A tracker and a total station (issue 29 item 5, models/total_station.toml): the plan with its
# simulated measurement, which adjusts and validates by Monte Carlo; the report in the browser.
add_test(NAME cli_network_total_station
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=network;${_ex}/tracker_total_station.toml;--simulate;3;-o;${_out}/network_ts"
          -DOUT=${_out}/network_ts
          "-DFILES=targets.csv;parameters.csv;identifiability.csv;mcm.csv;results.json;report.html;simulated_S3.csv;simulated_network.toml"
          "-DEXPECT_STDOUT=Planned network 'tracker-total-station': 4 stations, 18 targets, 327 observations, 75 unknowns, dof 252.*Self-calibration: 3 of 3 combinations.*the GUM agrees"
          "-DEXPECT_FILE_REGEX=results.json:\"model\": \"total_station\""
          "-DJSON_KEYS=schema;summary;stations;targets;parameters;identifiability;monte_carlo;files"
          -DSCHEMA=vlt-network/1 -P ${_cli}/expect_outputs.cmake)
set_tests_properties(cli_network_total_station PROPERTIES FIXTURES_SETUP vlt_network_ts)
add_test(NAME cli_network_total_station_measured
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=network;${_out}/network_ts/simulated_network.toml;-o;${_out}/network_ts_measured"
          -DOUT=${_out}/network_ts_measured
          "-DFILES=targets.csv;parameters.csv;mcm.csv;results.json;report.html"
          "-DEXPECT_STDOUT=Measured network 'tracker-total-station-simulated-3': 4 stations, 18 targets, 327 observations.*the GUM agrees"
          "-DJSON_KEYS=schema;summary;parameters;monte_carlo;files"
          -DSCHEMA=vlt-network/1 -P ${_cli}/expect_outputs.cmake)
set_tests_properties(cli_network_total_station_measured PROPERTIES FIXTURES_REQUIRED vlt_network_ts FIXTURES_SETUP vlt_network_ts_measured)
add_test(NAME report_browser_network_total_station
  COMMAND ${CMAKE_COMMAND} -DPAGE=${_out}/network_ts_measured/report.html -DPROFILE=${_out}/chromium-profile-ts
          -DMIN_PLOTS=1 -P ${_cli}/report_browser.cmake)
set_tests_properties(report_browser_network_total_station PROPERTIES FIXTURES_REQUIRED vlt_network_ts_measured TIMEOUT 300)

# The ISO 10360-10 length test from the network (issue 29 item 6, docs/network.md N-13): the plan
# (E = 0 for every length) and its simulated measurement (the drawn instrument errors give E).
add_test(NAME cli_network_length_test
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=network;${_ex}/length_test_network.toml;--simulate;4;-o;${_out}/network_lt"
          -DOUT=${_out}/network_lt
          "-DFILES=length_test.csv;identifiability.csv;results.json;report.html;simulated_network.toml"
          "-DEXPECT_STDOUT=Length test [(]ISO 10360-10 from the network, MPE 15[.]0 µm [+] 6[.]00 µm/m[)]: 760 lengths of at least 1[.]00 m, 760 conform, 0 do not, 0 undetermined; largest [|]E[|] / MPE 0[.]000 .*E 0[.]0 µm.*: conforms"
          "-DEXPECT_FILE_REGEX=results.json:\"length_test\": {[^}]*\"lengths\": 760,[^}]*\"verdict\": \"conforms\""
          "-DJSON_KEYS=schema;summary;length_test;files"
          -DSCHEMA=vlt-network/1 -P ${_cli}/expect_outputs.cmake)
set_tests_properties(cli_network_length_test PROPERTIES FIXTURES_SETUP vlt_network_lt)
add_test(NAME cli_network_length_test_measured
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=network;${_out}/network_lt/simulated_network.toml;-o;${_out}/network_lt_measured"
          -DOUT=${_out}/network_lt_measured "-DFILES=length_test.csv;results.json;report.html"
          "-DEXPECT_STDOUT=Length test [(]ISO 10360-10 from the network.*760 lengths of at least 1[.]00 m, [0-9]+ conform"
          "-DEXPECT_FILE_REGEX=report.html:<h2>Length test from the network [(]ISO 10360-10[)]</h2>"
          "-DJSON_KEYS=schema;summary;length_test;files"
          -DSCHEMA=vlt-network/1 -P ${_cli}/expect_outputs.cmake)
set_tests_properties(cli_network_length_test_measured PROPERTIES FIXTURES_REQUIRED vlt_network_lt)
vlt_network_error(length_test_bad_mpe length_test_bad_mpe.toml
                  "length_test_bad_mpe\\.toml: network\\.length_test\\.mpe: '15 arcsec' is neither a length nor a ratio")
