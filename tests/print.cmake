# One print design for every report (issue 34 item 1; docs/results.md "Printing"): each kind of
# page vlt writes — a run, a map, a station search, vlt test, vlt calibrate, vlt network, vlt
# prior — printed to PDF by headless Chromium on A4 and on US Letter must carry "Page i of N" and
# the report's name on every page, keep every word on the paper and have no two words overlapping
# (tests/cli/check_print.py, pdftotext -bbox-layout).
if(NOT TARGET vlt)
  return()
endif()
set(_out ${CMAKE_BINARY_DIR}/cli-tests)
# kind -> page (under cli-tests/) and the fixture of the run that writes it
set(_print_pages
    "run:demo/report.html:vlt_demo_outputs"
    "map:demo/map.html:vlt_demo_outputs"
    "plan:plan/station_map.html:vlt_plan"
    "test:cal_test/report.html:vlt_cal_test"
    "calibrate:cal_calibrate/report.html:vlt_cal_calibrate"
    "network:network_simulated/report.html:vlt_network_simulated"
    "prior:prior_leica-at500/prior/report.html:vlt_prior_leica-at500")
foreach(entry ${_print_pages})
  string(REPLACE ":" ";" entry "${entry}")
  list(GET entry 0 kind)
  list(GET entry 1 page)
  list(GET entry 2 fixture)
  foreach(paper A4 Letter)
    add_test(NAME report_print_${kind}_${paper}
      COMMAND ${Python3_EXECUTABLE} ${CMAKE_CURRENT_SOURCE_DIR}/cli/check_print.py chromium ${_out}/${page}
              ${_out}/print_${kind} ${paper})
    set_tests_properties(report_print_${kind}_${paper} PROPERTIES FIXTURES_REQUIRED ${fixture} TIMEOUT 300
      PASS_REGULAR_EXPRESSION "ok: .* prints on ${paper}: [0-9]+ pages, numbered, named, no overlapping words")
  endforeach()
endforeach()
