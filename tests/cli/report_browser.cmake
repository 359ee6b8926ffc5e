# Run by CTest (tests/cli.cmake): render an HTML page written by vlt in headless Chromium and
# fail unless every plot drew and no JavaScript error was logged. The page's own script sets
# <div id="vlt-status"> to "plots-ok" after all Plotly.newPlot promises resolved, every plot div
# holds a drawn figure and the 3-D scene has a WebGL context; window.onerror counts errors into
# data-errors. A missing Chromium is a FAILURE (scripts/test.sh installs the Debian package).
#   -DPAGE=/abs/path/report.html -DPROFILE=/abs/tmp/dir [-DCHROMIUM=/usr/bin/chromium]
#   [-DMAX_BYTES=N] (the page may not be larger) [-DFRAGMENT=layer=3] (appended as #...)
#   [-DSWAP_PLOTLY=/abs/embedded.js -DWITH_PLOTLY=/abs/other.js -DSWAPPED=/abs/copy.html]: draw a copy
#   of the page whose embedded plotly.js is replaced by another (the copy a build without npm embeds,
#   cmake/VltPlotly.cmake); "SKIPPED:" when WITH_PLOTLY is not on this machine.
cmake_minimum_required(VERSION 3.25)
if(NOT CHROMIUM)
  find_program(CHROMIUM NAMES chromium chromium-browser google-chrome)
endif()
if(NOT CHROMIUM)
  message(FATAL_ERROR "Chromium not found: install the Debian package `chromium` (scripts/test.sh does)")
endif()
if(NOT EXISTS ${PAGE})
  message(FATAL_ERROR "page ${PAGE} does not exist")
endif()
if(DEFINED MAX_BYTES)
  file(SIZE ${PAGE} page_bytes)
  if(page_bytes GREATER MAX_BYTES)
    message(FATAL_ERROR "${PAGE} has ${page_bytes} bytes, more than ${MAX_BYTES}")
  endif()
endif()
if(DEFINED SWAP_PLOTLY)
  if(NOT EXISTS ${WITH_PLOTLY})
    message(STATUS "SKIPPED: ${WITH_PLOTLY} is not on this machine")
    return()
  endif()
  file(READ ${PAGE} _page)
  file(READ ${SWAP_PLOTLY} _embedded)
  file(READ ${WITH_PLOTLY} _other)
  string(FIND "${_page}" "${_embedded}" _at)
  if(_at EQUAL -1)
    message(FATAL_ERROR "${PAGE} does not embed ${SWAP_PLOTLY}")
  endif()
  string(REPLACE "${_embedded}" "${_other}" _page "${_page}")
  file(WRITE ${SWAPPED} "${_page}")
  set(PAGE ${SWAPPED})
endif()
set(_fragment "")
if(DEFINED FRAGMENT)
  set(_fragment "#${FRAGMENT}")  # e.g. layer=3: what map.html shows first
endif()
file(REMOVE_RECURSE ${PROFILE})
file(MAKE_DIRECTORY ${PROFILE})
execute_process(
  COMMAND ${CHROMIUM} --headless --no-sandbox --disable-gpu --enable-unsafe-swiftshader --disable-quic
          --no-first-run --disable-background-networking --disable-component-update --disable-sync
          --user-data-dir=${PROFILE} --virtual-time-budget=60000 --dump-dom file://${PAGE}${_fragment}
  RESULT_VARIABLE rc OUTPUT_VARIABLE dom ERROR_VARIABLE log TIMEOUT 240)
file(REMOVE_RECURSE ${PROFILE})
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "chromium failed (exit ${rc}):\n${log}")
endif()
string(REGEX MATCH "<div id=\"vlt-status\"[^>]*>[^<]*</div>" status "${dom}")
if(NOT status)
  message(FATAL_ERROR "no vlt-status marker in the rendered page (the page script did not run)")
endif()
if(NOT status MATCHES "data-errors=\"0\"" OR NOT status MATCHES ">plots-ok<")
  message(FATAL_ERROR "the page did not draw every plot or logged a JavaScript error: ${status}")
endif()
string(REGEX MATCH "data-plots=\"([0-9]+)\"" _ "${status}")
if(CMAKE_MATCH_1 LESS 1)
  message(FATAL_ERROR "no plot drawn: ${status}")
endif()
if(DEFINED MIN_PLOTS AND CMAKE_MATCH_1 LESS MIN_PLOTS)
  message(FATAL_ERROR "only ${CMAKE_MATCH_1} plots drawn, expected at least ${MIN_PLOTS}: ${status}")
endif()
message(STATUS "ok: ${status}")
