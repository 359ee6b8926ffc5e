# Run by CTest (tests/cli.cmake): print report.html to PDF in headless Chromium ("print to PDF", as
# a user files it) and check the pages with pdftotext (Debian poppler-utils): at least MIN_PAGES
# pages; the provenance header (created, commit, SHA-256 of the job file as results.json gives it);
# the task results before the points; every section; every task and every point of points.csv in
# the text (tables unrolled, not clipped by scroll boxes); the 3-D view as a picture.
#   -DDIR=/abs/run/dir (report.html, results.json, points.csv, tasks.csv) -DPROFILE=/abs/tmp/dir
#   [-DMIN_PAGES=N]
cmake_minimum_required(VERSION 3.25)
find_program(CHROMIUM NAMES chromium chromium-browser google-chrome)
find_program(PDFTOTEXT pdftotext)
if(NOT CHROMIUM OR NOT PDFTOTEXT)
  message(FATAL_ERROR "chromium and pdftotext are needed: install the Debian packages chromium and poppler-utils (scripts/test.sh does)")
endif()
set(pdf ${DIR}/report-printed.pdf)
file(REMOVE ${pdf})
file(REMOVE_RECURSE ${PROFILE})
file(MAKE_DIRECTORY ${PROFILE})
execute_process(
  COMMAND ${CHROMIUM} --headless --no-sandbox --disable-gpu --enable-unsafe-swiftshader --disable-quic
          --no-first-run --disable-background-networking --disable-component-update --disable-sync
          --user-data-dir=${PROFILE} --virtual-time-budget=60000 --run-all-compositor-stages-before-draw
          --no-pdf-header-footer --print-to-pdf=${pdf} file://${DIR}/report.html
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE log TIMEOUT 240)
file(REMOVE_RECURSE ${PROFILE})
if(NOT rc EQUAL 0 OR NOT EXISTS ${pdf})
  message(FATAL_ERROR "chromium could not print (exit ${rc}):\n${log}")
endif()
execute_process(COMMAND ${PDFTOTEXT} -layout ${pdf} - RESULT_VARIABLE rc OUTPUT_VARIABLE text)
string(ASCII 12 form_feed)
string(REPLACE "${form_feed}" "\n" text "${text}")   # page breaks
execute_process(COMMAND pdfinfo ${pdf} OUTPUT_VARIABLE info)
string(REGEX MATCH "Pages: +([0-9]+)" _ "${info}")
set(pages ${CMAKE_MATCH_1})
if(NOT pages OR (DEFINED MIN_PAGES AND pages LESS MIN_PAGES))
  message(FATAL_ERROR "the printed report has ${pages} pages, expected at least ${MIN_PAGES}")
endif()
# Images: the 3-D view is printed as a picture (a WebGL canvas does not print).
execute_process(COMMAND pdfimages -list ${pdf} OUTPUT_VARIABLE images)
if(NOT images MATCHES "image")
  message(FATAL_ERROR "the printed report holds no image (the 3-D view did not print)")
endif()
file(READ ${DIR}/results.json json)
string(JSON sha GET "${json}" job input_files 0 sha256)
string(JSON commit GET "${json}" vlt_commit)
string(JSON created GET "${json}" created)
string(SUBSTRING "${sha}" 0 20 sha_start)
foreach(expected "created" "${created}" "${commit}" "SHA-256" "${sha_start}" "Tasks" "Points" "Uncertainty budget of one point"
        "Points and coverage ellipsoids" "Inputs")
  string(FIND "${text}" "${expected}" at)
  if(at LESS 0)
    message(FATAL_ERROR "the printed report does not show '${expected}'")
  endif()
endforeach()
# The heading "Points" (a line of its own, after a page break) comes after "Tasks".
string(FIND "${text}" "Tasks" at_tasks)
string(SUBSTRING "${text}" 0 ${at_tasks} before_tasks)
if(before_tasks MATCHES "\nPoints *\n")
  message(FATAL_ERROR "the task results do not come before the points")
endif()
if(NOT text MATCHES "\nPoints *\n")
  message(FATAL_ERROR "the printed report has no heading 'Points'")
endif()
# Every point and every task of the run, whole: the tables are unrolled.
foreach(csv points.csv tasks.csv)
  file(READ ${DIR}/${csv} content)
  string(REPLACE ";" "," content "${content}")   # CMake lists split on ';' (free text has some)
  string(REGEX REPLACE "\n$" "" content "${content}")
  string(REPLACE "\n" ";" lines "${content}")
  list(REMOVE_AT lines 0)
  foreach(line ${lines})
    string(REGEX MATCH "^[^,]+" name "${line}")
    string(FIND "${text}" "${name}" at)
    if(at LESS 0)
      message(FATAL_ERROR "the printed report misses '${name}' of ${csv}")
    endif()
  endforeach()
endforeach()
message(STATUS "ok: ${pages} pages, every point and task, provenance, the 3-D view as a picture")
