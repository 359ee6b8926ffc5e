# Tests that drive the `vlt` command line (docs/cli.md): bad input -> one line, exit 2, no output
# files; the demo, the examples, `vlt map`; the report rendered in headless Chromium.
# Helper scripts: tests/cli/*.cmake; job files: tests/cli/jobs/.
if(NOT TARGET vlt)
  return()
endif()

set(_cli ${CMAKE_CURRENT_SOURCE_DIR}/cli)
set(_jobs ${_cli}/jobs)
set(_out ${CMAKE_BINARY_DIR}/cli-tests)

# vlt_cli_error(NAME JOB REGEX [extra args...]): `vlt run JOB -o DIR --no-mcm` must fail.
function(vlt_cli_error name job regex)
  add_test(NAME cli_error_${name}
    COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
            "-DARGS=run;${_jobs}/${job};-o;${_out}/error_${name};${ARGN}"
            -DOUT=${_out}/error_${name} "-DEXPECT=${regex}"
            -P ${_cli}/expect_error.cmake)
endfunction()

# One test per class of bad input; each checks the one-line message names the file and the key
# or line, and that nothing was written.
vlt_cli_error(toml_syntax syntax_error.toml "syntax_error\\.toml: line 10, column [0-9]+: TOML syntax error")
vlt_cli_error(unknown_key unknown_key.toml "unknown_key\\.toml: tracker\\.noise\\.azimth: unknown key")
# A drifting station belongs to `vlt network` (docs/network.md N-12): said where it is written.
vlt_cli_error(station_drift station_drift.toml "station_drift\\.toml: station\\.drift: a job takes its station as still; .*adjusted by `vlt network`")
vlt_cli_error(drift_check drift_check.toml "drift_check\\.toml: drift_check: a job takes its station as still")
vlt_cli_error(bad_ranging bad_ranging.toml
              "bad_ranging\\.toml: tracker\\.ranging: unknown ranging principle 'ADM-2' [(]expected one of: ifm, adm, aifm[)]")
vlt_cli_error(missing_key missing_key.toml "missing_key\\.toml: tracker\\.model: required key is missing")
vlt_cli_error(unknown_parameter unknown_parameter.toml
              "unknown_parameter\\.toml: tracker\\.parameters\\.tmx: unknown parameter 'tmx' of model 'mirror'")
vlt_cli_error(unknown_model unknown_model.toml "unknown_model\\.toml: tracker\\.model: unknown model 'laser9000'")
vlt_cli_error(wrong_unit wrong_unit.toml
              "wrong_unit\\.toml: tracker\\.noise\\.elevation: '5 um' is a length, expected an angle")
vlt_cli_error(negative_uncertainty negative_u.toml "negative_u\\.toml: tracker\\.parameters\\.tmv\\.u: negative uncertainty")
vlt_cli_error(nonfinite_uncertainty nonfinite_u.toml "nonfinite_u\\.toml: tracker\\.parameters\\.rmv\\.u: not a finite number")
vlt_cli_error(correlation_not_psd correlation_not_psd.toml
              "correlation_not_psd\\.toml: tracker\\.correlations\\.encoders\\.matrix: correlation matrix is not positive semi-definite")
vlt_cli_error(correlation_unknown_input correlation_unknown_input.toml
              "correlation_unknown_input\\.toml: correlations\\.thermometer\\.inputs: unknown input 'part\\.temperature': .*'thermal\\.temperature' for \\[part\\] temperature")
vlt_cli_error(point_on_vertical_axis on_vertical_axis.toml
              "on_vertical_axis\\.toml: plan\\.point\\[4\\]: point 'Z' lies on the tracker's vertical axis")
vlt_cli_error(csv_row bad_csv_row.toml "bad_readings\\.csv: line 4: elevation: 'oops' does not start with a number")
vlt_cli_error(csv_missing missing_csv.toml "missing_csv\\.toml: readings\\.csv: cannot read '.*no_such_file\\.csv'")
vlt_cli_error(map_step_unit bad_map_step.toml "bad_map_step\\.toml: map: step: '0\\.25 rad' is an angle, expected a length")
# An error found while computing (a plane through collinear points) also leaves nothing behind,
# with Monte Carlo on.
vlt_cli_error(collinear_plane collinear_plane.toml "collinear_plane\\.toml: task\\[0\\]: .*collinear")
vlt_cli_error(trials_too_few good.toml "--trials: at least 2000 trials" --trials 100)
vlt_cli_error(missing_job_file no_such_job.toml "no_such_job\\.toml: cannot read the job file")
# A bad job must not touch an existing output directory.
add_test(NAME cli_error_keeps_existing_directory
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt> -DPREEXISTING=ON
          "-DARGS=run;${_jobs}/unknown_key.toml;-o;${_out}/error_existing"
          -DOUT=${_out}/error_existing "-DEXPECT=unknown key" -P ${_cli}/expect_error.cmake)
# vlt map with a plane but no extent.
add_test(NAME cli_error_map_without_extent
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=map;${_jobs}/good.toml;--plane;z=0;-o;${_out}/error_map"
          -DOUT=${_out}/error_map "-DEXPECT=--extent: required with --plane" -P ${_cli}/expect_error.cmake)

set(_all_files "points.csv;points.jsonl;budget.csv;tasks.csv;results.json;report.html")

# A good job, GUM only and with a small Monte Carlo run; --json prints results.json.
add_test(NAME cli_run_good_no_mcm
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=run;${_jobs}/good.toml;-o;${_out}/good_no_mcm;--no-mcm"
          -DOUT=${_out}/good_no_mcm "-DFILES=${_all_files}"
          "-DEXPECT_STDOUT=Ux\\[µm\\].*Monte Carlo: not run" -P ${_cli}/expect_outputs.cmake)
add_test(NAME cli_run_good_json
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=run;${_jobs}/good.toml;-o;${_out}/good_json;--trials;4000;--json"
          -DOUT=${_out}/good_json "-DFILES=${_all_files}"
          "-DEXPECT_STDOUT=^{\n \"schema\": \"vlt-results/2\"" -P ${_cli}/expect_outputs.cmake)

# A two_face task between a point and its back-face twin, with Monte Carlo: all three
# components in the summary, with a GUM-vs-MCM verdict.
add_test(NAME cli_run_two_face
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=run;${_jobs}/two_face.toml;-o;${_out}/two_face"
          -DOUT=${_out}/two_face "-DFILES=${_all_files}"
          "-DEXPECT_STDOUT=P_two_face +two_face +dx +0\\.0000 mm .*validated.*P_two_face +two_face +dy .*P_two_face +two_face +dz .*Q_two_face +two_face +dz"
          -P ${_cli}/expect_outputs.cmake)

# The demo (the README's first command) with fewer trials, then its report in Chromium.
add_test(NAME cli_demo
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=demo;--trials;4000;-o;${_out}/demo"
          -DOUT=${_out}/demo "-DFILES=${_all_files};map.csv;map.html"
          "-DEXPECT_STDOUT=GUM validated by MCM \\(JCGM 101 8\\): [0-9]+/50 points" -P ${_cli}/expect_outputs.cmake)
set_tests_properties(cli_demo PROPERTIES FIXTURES_SETUP vlt_demo_outputs)
add_test(NAME report_browser_demo
  COMMAND ${CMAKE_COMMAND} -DPAGE=${_out}/demo/report.html -DPROFILE=${_out}/chromium-profile-report
          -DMIN_PLOTS=4 -P ${_cli}/report_browser.cmake)
add_test(NAME report_browser_map
  COMMAND ${CMAKE_COMMAND} -DPAGE=${_out}/demo/map.html -DPROFILE=${_out}/chromium-profile-map
          -DMIN_PLOTS=1 -P ${_cli}/report_browser.cmake)
# An adaptive run's report: the convergence plot and the histograms draw.
add_test(NAME cli_run_adaptive
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt> "-DARGS=run;${_jobs}/good.toml;--adaptive;-o;${_out}/adaptive"
          -DOUT=${_out}/adaptive "-DFILES=${_all_files}" -P ${_cli}/expect_outputs.cmake)
set_tests_properties(cli_run_adaptive PROPERTIES FIXTURES_SETUP vlt_adaptive)
add_test(NAME report_browser_adaptive
  COMMAND ${CMAKE_COMMAND} -DPAGE=${_out}/adaptive/report.html -DPROFILE=${_out}/chromium-profile-adaptive
          -DMIN_PLOTS=5 -P ${_cli}/report_browser.cmake)
set_tests_properties(report_browser_adaptive PROPERTIES FIXTURES_REQUIRED vlt_adaptive TIMEOUT 300)

# The report printed to PDF ("a report one can file"): every table whole, the plots, provenance.
add_test(NAME report_print_demo
  COMMAND ${CMAKE_COMMAND} -DDIR=${_out}/demo -DPROFILE=${_out}/chromium-profile-print -DMIN_PAGES=6
          -P ${_cli}/report_print.cmake)
# The bytes the build embedded (cmake/vlt_embed.cc), and the run report drawn with the plotly.js a
# build without npm embeds (Debian's python3-plotly copy, cmake/VltPlotly.cmake).
add_test(NAME report_embeds_plotly_bytes
  COMMAND ${CMAKE_COMMAND} -DPAGE=${_out}/demo/report.html -DPLOTLY=${VLT_PLOTLY_JS_FILE}
          -DLICENSE=${VLT_PLOTLY_LICENSE_FILE} -P ${_cli}/check_embedded_assets.cmake)
add_test(NAME setup_plotly_fallback
  COMMAND ${CMAKE_COMMAND} -DSOURCE_DIR=${CMAKE_SOURCE_DIR} -DOUT=${_out}/plotly_fallback
          -P ${_cli}/check_plotly_fallback.cmake)
add_test(NAME report_browser_demo_debian_plotly
  COMMAND ${CMAKE_COMMAND} -DPAGE=${_out}/demo/report.html -DPROFILE=${_out}/chromium-profile-debian-plotly
          -DSWAP_PLOTLY=${VLT_PLOTLY_JS_FILE} -DWITH_PLOTLY=${VLT_DEBIAN_PLOTLY_JS}
          -DSWAPPED=${_out}/demo_debian_plotly.html -DMIN_PLOTS=4 -P ${_cli}/report_browser.cmake)
set_tests_properties(report_browser_demo_debian_plotly PROPERTIES SKIP_REGULAR_EXPRESSION "SKIPPED:")
set_tests_properties(report_browser_demo report_browser_map report_print_demo report_embeds_plotly_bytes
  report_browser_demo_debian_plotly PROPERTIES FIXTURES_REQUIRED vlt_demo_outputs TIMEOUT 300)

# A scan (2000 points, one plane over all): report.html holds the 200 points with the largest |U|
# and an overview, stays small and draws.
add_test(NAME cli_run_scan
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt> "-DARGS=run;${_jobs}/scan_2000.toml;-o;${_out}/scan"
          -DOUT=${_out}/scan "-DFILES=${_all_files}" "-DEXPECT_STDOUT=2000 points, 1 task\n" -P ${_cli}/expect_outputs.cmake)
set_tests_properties(cli_run_scan PROPERTIES FIXTURES_SETUP vlt_scan_outputs)

# The output directory replaced as a whole, by renameat2(RENAME_EXCHANGE) and by its fallback (the
# old set moved aside: C libraries and file systems without the exchange; issue 34).
foreach(_mode exchange fallback)
  add_test(NAME cli_run_replaces_output_${_mode}
    COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt> -DJOB=${_jobs}/good.toml -DOUT=${_out}/replace_${_mode}
            -P ${_cli}/replace_output.cmake)
endforeach()
set_tests_properties(cli_run_replaces_output_fallback PROPERTIES ENVIRONMENT VLT_NO_RENAME_EXCHANGE=1)
add_test(NAME report_browser_scan
  COMMAND ${CMAKE_COMMAND} -DPAGE=${_out}/scan/report.html -DPROFILE=${_out}/chromium-profile-scan
          -DMIN_PLOTS=3 -DMAX_BYTES=10000000 -P ${_cli}/report_browser.cmake)
set_tests_properties(report_browser_scan PROPERTIES FIXTURES_REQUIRED vlt_scan_outputs TIMEOUT 300)

# A large scan (10^5 points, generated at test time): the compact per-point file (the default above
# 10^4 points; points.jsonl and budget.csv are not written, check_points_npy.py checks their
# absence and the rows), and the report stays small (the 200 largest-|U| points, an overview of
# 20000) and draws. docs/performance.md 4.2 records the 10^6-point run (time, memory, bytes).
find_package(Python3 COMPONENTS Interpreter REQUIRED)
add_test(NAME cli_make_scan_large
  COMMAND ${Python3_EXECUTABLE} ${_cli}/make_scan.py 100000 ${_out}/scan_large_job)
set_tests_properties(cli_make_scan_large PROPERTIES FIXTURES_SETUP vlt_scan_large_job)
# Report safety (issue 32): a job whose points, task and description are named to end the report's
# <script> and run their own. The page's data carry them as JSON with every '<' written \u003c
# (nothing can close the script element); in the browser every plot draws and nothing of them runs.
vlt_hostile_report(run report.html "points.csv;tasks.csv;results.json;report.html"
                   "report.html:[\\\\]u003c/script>[\\\\]u003cscript>window[.]vltErrors[.]push[(]'injected'[)]" 3
                   run ${_jobs}/hostile_names.toml)
# The same names on the map's markers (map.html) and in a station search: the station map draws and
# the planned job, which holds the names in TOML, runs (its strings escaped for TOML).
vlt_hostile_report(map map.html "map.csv;map.html"
                   "map.html:[\\\\]u003c/script>[\\\\]u003cscript>window[.]vltErrors[.]push[(]'injected'[)]" 1
                   map ${_jobs}/hostile_names.toml --plane z=0 --extent 2,5,-1,2 --step 0.5m)
vlt_hostile_report(plan station_map.html "plan.json;station_map.html;planned_job.toml" "" 1
                   plan ${_jobs}/hostile_plan.toml --threads 2)
add_test(NAME cli_plan_hostile_planned_job_runs
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=run;${_out}/plan_hostile/planned_job.toml;--no-mcm;-o;${_out}/plan_hostile_run"
          -DOUT=${_out}/plan_hostile_run "-DFILES=points.csv;report.html" -P ${_cli}/expect_outputs.cmake)
set_tests_properties(cli_plan_hostile_planned_job_runs PROPERTIES FIXTURES_REQUIRED vlt_plan_hostile TIMEOUT 300)

add_test(NAME cli_run_scan_large
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt> "-DARGS=run;${_out}/scan_large_job/scan.toml;-q;-o;${_out}/scan_large"
          -DOUT=${_out}/scan_large "-DFILES=points.csv;tasks.csv;results.json;report.html" -DSKIP_JSONL_LINES=ON
          -P ${_cli}/expect_outputs.cmake)
set_tests_properties(cli_run_scan_large PROPERTIES FIXTURES_REQUIRED vlt_scan_large_job
                     FIXTURES_SETUP vlt_scan_large_outputs TIMEOUT 600)
add_test(NAME report_browser_scan_large
  COMMAND ${CMAKE_COMMAND} -DPAGE=${_out}/scan_large/report.html -DPROFILE=${_out}/chromium-profile-scan-large
          -DMIN_PLOTS=3 -DMAX_BYTES=20000000 -P ${_cli}/report_browser.cmake)
set_tests_properties(report_browser_scan_large PROPERTIES FIXTURES_REQUIRED vlt_scan_large_outputs TIMEOUT 300)

# vlt map through the tracker's vertical axis: the node at the origin is skipped and reported.
add_test(NAME cli_map_plane
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=map;${_jobs}/good.toml;--plane;z=0;--extent;-2,2,-2,2;--step;0.5m;-o;${_out}/map"
          -DOUT=${_out}/map "-DFILES=map.csv;map.html"
          "-DEXPECT_STDOUT=over 80 nodes.*Skipped 1 node.*\\(0, 0, 0\\) m: at the tracker" -P ${_cli}/expect_outputs.cmake)

# vlt --json map prints the map object of results.json: the node at the tracker is null, the
# others are numbers in metres (tens of micrometres here).
add_test(NAME cli_map_json
  COMMAND vlt --json map ${_jobs}/good.toml --plane z=0 --extent -1,1,-1,1 --step 1m -o ${_out}/map_json)
set_tests_properties(cli_map_json PROPERTIES PASS_REGULAR_EXPRESSION
  "\"U_norm\": \\[[\n ]*[0-9.]+e-05,[\n ]*[0-9.]+e-05,[\n ]*[0-9.]+e-05,[\n ]*[0-9.]+e-05,[\n ]*null,")

# Every example runs (small Monte Carlo).
file(GLOB _examples CONFIGURE_DEPENDS ${CMAKE_SOURCE_DIR}/examples/*.toml)
foreach(example ${_examples})
  get_filename_component(ex ${example} NAME_WE)
  add_test(NAME cli_example_${ex}
    COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
            "-DARGS=run;${example};--trials;4000;-o;${_out}/example_${ex}"
            -DOUT=${_out}/example_${ex} "-DFILES=${_all_files}" -P ${_cli}/expect_outputs.cmake)
endforeach()

# --help on every command, --version.
foreach(cmd run demo map)
  add_test(NAME cli_help_${cmd} COMMAND vlt ${cmd} --help)
  set_tests_properties(cli_help_${cmd} PROPERTIES PASS_REGULAR_EXPRESSION "Usage:.*${cmd}")
endforeach()
add_test(NAME cli_version COMMAND vlt --version)
set_tests_properties(cli_version PROPERTIES
  PASS_REGULAR_EXPRESSION "^vlt [0-9]+\\.[0-9]+\\.[0-9]+ \\(commit [0-9a-z-]+, [A-Za-z]+ build\\)")
# `vlt demo --help` names the folder the demo writes to.
add_test(NAME cli_help_demo_folder COMMAND vlt demo --help)
set_tests_properties(cli_help_demo_folder PROPERTIES PASS_REGULAR_EXPRESSION "Output directory \\(default: ./vlt-demo\\)")
# model show: a gauge's nominal length in mm with all its digits, its u in um (GUM H.1).
add_test(NAME cli_model_show_units COMMAND vlt model show gum_h1_end_gauge)
set_tests_properties(cli_model_show_units PROPERTIES PASS_REGULAR_EXPRESSION "l_s +\\[m\\]  50\\.000623 mm  u = 0\\.025 µm")
add_test(NAME cli_demo_show_job COMMAND vlt demo --show-job)
set_tests_properties(cli_demo_show_job PROPERTIES PASS_REGULAR_EXPRESSION "model = \"mirror\"")

# The report without Monte Carlo (no verdicts, null MCM fields) and a box map (slice selector)
# must draw as well.
set_tests_properties(cli_run_good_no_mcm PROPERTIES FIXTURES_SETUP vlt_good_no_mcm)
add_test(NAME report_browser_no_mcm
  COMMAND ${CMAKE_COMMAND} -DPAGE=${_out}/good_no_mcm/report.html -DPROFILE=${_out}/chromium-profile-no-mcm
          -DMIN_PLOTS=3 -P ${_cli}/report_browser.cmake)
add_test(NAME cli_map_box
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=map;${_jobs}/good.toml;--box;-1,1,-1,1,-1,1;--step;0.5;-o;${_out}/map_box"
          -DOUT=${_out}/map_box "-DFILES=map.csv;map.html"
          "-DEXPECT_STDOUT=over 120 nodes.*Skipped 5 node" -P ${_cli}/expect_outputs.cmake)
set_tests_properties(cli_map_box PROPERTIES FIXTURES_SETUP vlt_map_box)
add_test(NAME report_browser_map_box
  COMMAND ${CMAKE_COMMAND} -DPAGE=${_out}/map_box/map.html -DPROFILE=${_out}/chromium-profile-map-box
          -DMIN_PLOTS=1 -P ${_cli}/report_browser.cmake)
set_tests_properties(report_browser_no_mcm PROPERTIES FIXTURES_REQUIRED vlt_good_no_mcm TIMEOUT 300)
set_tests_properties(report_browser_map_box PROPERTIES FIXTURES_REQUIRED vlt_map_box TIMEOUT 300)

# Station planning (docs/planning.md): the example, its report, and `vlt run` on the job it
# writes gives the objective it reports; bad [optimize] input is one line, exit 2, nothing written.
add_test(NAME cli_plan_example
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=plan;${CMAKE_SOURCE_DIR}/examples/station_plan.toml;--threads;2;-o;${_out}/plan"
          -DOUT=${_out}/plan "-DFILES=plan.json;station_map.csv;station_map.html;planned_job.toml"
          "-DEXPECT_STDOUT=recommended +x = [-0-9.]+ m, y = [-0-9.]+ m, z = [-0-9.]+ m: objective [0-9.]+ µm.*job's station"
          -P ${_cli}/expect_outputs.cmake)
set_tests_properties(cli_plan_example PROPERTIES FIXTURES_SETUP vlt_plan)
add_test(NAME cli_plan_reproduced_by_run
  COMMAND ${Python3_EXECUTABLE} ${_cli}/plan_reproduced.py $<TARGET_FILE:vlt> ${_out}/plan ${_out}/plan_run)
add_test(NAME report_browser_station_map
  COMMAND ${CMAKE_COMMAND} -DPAGE=${_out}/plan/station_map.html -DPROFILE=${_out}/chromium-profile-plan
          -DMIN_PLOTS=1 -P ${_cli}/report_browser.cmake)
set_tests_properties(cli_plan_reproduced_by_run report_browser_station_map PROPERTIES FIXTURES_REQUIRED vlt_plan TIMEOUT 300)
vlt_cli_error(plan_unknown_task plan_unknown_task.toml
              "plan_unknown_task\\.toml: optimize\\.objective: no task 'bore' \\(tasks: AB\\)")
# vlt_cli_command_error(NAME REGEX ARGS...): `vlt ARGS -o DIR` must fail (one line, exit 2, nothing written).
function(vlt_cli_command_error name regex)
  add_test(NAME cli_error_${name}
    COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt> "-DARGS=${ARGN};-o;${_out}/error_${name}"
            -DOUT=${_out}/error_${name} "-DEXPECT=${regex}" -P ${_cli}/expect_error.cmake)
endfunction()
vlt_cli_command_error(plan_no_feasible_station
  "plan_no_station\\.toml: optimize: no feasible station in the region .*below min_range" plan ${_jobs}/plan_no_station.toml)
vlt_cli_command_error(plan_without_optimize
  "good\\.toml: optimize: the job has no \\[optimize\\] section" plan ${_jobs}/good.toml)

# The Monte Carlo map and the per-source layers: every kind of layer draws (map.html#layer=N).
add_test(NAME cli_map_mcm
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=map;${_jobs}/good.toml;--plane;z=0;--extent;2,5,-1,1;--step;0.5;--mcm;--trials;10000;-o;${_out}/map_mcm"
          -DOUT=${_out}/map_mcm "-DFILES=map.csv;map.html"
          "-DEXPECT_STDOUT=Dominant source: .*Monte Carlo \\(10000 trials, seed 7\\): GUM validated at [0-9]+ node"
          -P ${_cli}/expect_outputs.cmake)
set_tests_properties(cli_map_mcm PROPERTIES FIXTURES_SETUP vlt_map_mcm)
foreach(layer 1 2 3 4 8)
  add_test(NAME report_browser_map_layer_${layer}
    COMMAND ${CMAKE_COMMAND} -DPAGE=${_out}/map_mcm/map.html -DFRAGMENT=layer=${layer}
            -DPROFILE=${_out}/chromium-profile-map-layer-${layer} -DMIN_PLOTS=1 -P ${_cli}/report_browser.cmake)
  set_tests_properties(report_browser_map_layer_${layer} PROPERTIES FIXTURES_REQUIRED vlt_map_mcm TIMEOUT 300)
endforeach()

# vlt as a library (docs/library.md): install, then build and run examples/consumer with
# find_package(vlt) and with pkg-config, and its Python twin against the installed module. Not in the sanitizer build (its libvlt.a needs the
# sanitizer runtime, which a consumer does not link).
if(NOT VLT_SANITIZE AND NOT VLT_FUZZ)
  add_test(NAME cli_consumer_install
    COMMAND ${CMAKE_COMMAND} -DBUILD_DIR=${CMAKE_BINARY_DIR} -DSOURCE_DIR=${CMAKE_SOURCE_DIR}
            -DOUT=${_out}/consumer -DCXX=${CMAKE_CXX_COMPILER}
            $<$<TARGET_EXISTS:vlt_python>:-DPYTHON=${Python3_EXECUTABLE}> -P ${_cli}/consumer.cmake)
  set_tests_properties(cli_consumer_install PROPERTIES TIMEOUT 600 RESOURCE_LOCK vlt_install)
endif()

# Files that are not files (issue 32 item 2): a symbolic-link loop, a name over 255 bytes, a FIFO,
# /dev/zero, a directory and a missing file, as the job file, a readings CSV, a plan CSV, a
# calibration file and a network station's readings: each one line, exit 2, nothing written, no wait.
add_test(NAME cli_hostile_files
  COMMAND bash ${_cli}/hostile_files.sh $<TARGET_FILE:vlt> ${CMAKE_SOURCE_DIR} ${_out}/hostile_files)
set_tests_properties(cli_hostile_files PROPERTIES TIMEOUT 300)
# Hostile contents (a deep dotted key, a 10^6-column header, a NUL byte, map bounds of 1e300 m, an
# empty -o, a missing declared column, a byte order mark, a 250-byte directory name): refused in
# one line or run, never a crash, a hang or inf (tests/cli/hostile_inputs.sh says each).
add_test(NAME cli_hostile_inputs
  COMMAND bash ${_cli}/hostile_inputs.sh $<TARGET_FILE:vlt> ${CMAKE_SOURCE_DIR} ${_out}/hostile_inputs)
set_tests_properties(cli_hostile_inputs PROPERTIES TIMEOUT 300)

# points.npy ([output] arrays = true) read by numpy, not by vlt: every field the number points.jsonl
# and budget.csv hold (full detail, a plan job with Monte Carlo and an online job without), and the
# compact points.csv of a 2*10^4-point scan row by row the rounded record, its dominant input the
# largest of the budget fields (docs/results.md "Detail of the per-point files").
add_test(NAME cli_points_npy_plan_full
  COMMAND ${Python3_EXECUTABLE} ${_cli}/check_points_npy.py $<TARGET_FILE:vlt> ${_out}/npy_plan full
          ${CMAKE_SOURCE_DIR}/examples/panel_station.toml --trials 20000)
add_test(NAME cli_points_npy_online_full
  COMMAND ${Python3_EXECUTABLE} ${_cli}/check_points_npy.py $<TARGET_FILE:vlt> ${_out}/npy_online full
          ${CMAKE_SOURCE_DIR}/examples/online_readings.toml --no-mcm)
add_test(NAME cli_points_npy_scan_compact
  COMMAND ${Python3_EXECUTABLE} ${_cli}/check_points_npy.py $<TARGET_FILE:vlt> ${_out}/npy_scan compact 20000)
