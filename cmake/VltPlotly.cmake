# plotly.js for vlt's self-contained report.html.
#
# Where the script comes from, the first that applies:
#  1. -DVLT_PLOTLY_JS=/path/to/plotly.min.js: that file (an offline build with a copy of it);
#  2. npm: the version pinned in package.json / package-lock.json at the top of the repository (npm
#     registry package `plotly.js-dist-min`, integrity hash in the lock file), installed by `npm ci`
#     into <build>/npm/node_modules — the build vlt is tested with;
#  3. no npm on the machine (an air-gapped lab): the copy Debian's package python3-plotly ships,
#     /usr/share/python3-plotly/plotly.js (plotly.js v2.6.3 in Debian 12, not minified: the reports
#     grow by about 4 MB). The test report_browser_demo_debian_plotly draws the run report with it.
# runtime/src/output/plotly.cc then compiles the script INTO libvlt_runtime (cmake/vlt_embed.cc),
# so the `vlt` binary needs no file at run time and every report.html it writes opens offline.
set(VLT_PLOTLY_JS "" CACHE FILEPATH "plotly.js to embed (empty: npm ci from package-lock.json, or Debian's python3-plotly copy without npm)")
set(VLT_DEBIAN_PLOTLY_JS /usr/share/python3-plotly/plotly.js)
find_program(VLT_NPM npm)
if(NOT VLT_PLOTLY_JS AND NOT VLT_NPM AND EXISTS ${VLT_DEBIAN_PLOTLY_JS})
  message(STATUS "vlt: npm not found: embedding Debian's python3-plotly copy of plotly.js")
  set(VLT_PLOTLY_JS ${VLT_DEBIAN_PLOTLY_JS})
endif()

if(NOT VLT_PLOTLY_JS)
  set(_vlt_npm_dir ${CMAKE_BINARY_DIR}/npm)
  set(_vlt_plotly ${_vlt_npm_dir}/node_modules/plotly.js-dist-min/plotly.min.js)
  # Reinstall when the lock file changes (copied next to node_modules as a stamp).
  set(_vlt_lock_stamp ${_vlt_npm_dir}/package-lock.json)
  file(SHA256 ${CMAKE_SOURCE_DIR}/package-lock.json _vlt_lock_hash)
  set(_vlt_have_hash "")
  if(EXISTS ${_vlt_lock_stamp} AND EXISTS ${_vlt_plotly})
    file(SHA256 ${_vlt_lock_stamp} _vlt_have_hash)
  endif()
  if(NOT _vlt_have_hash STREQUAL _vlt_lock_hash)
    if(NOT VLT_NPM)
      message(FATAL_ERROR "vlt: npm not found (needed once to fetch plotly.js for report.html). "
              "Install the Debian packages nodejs and npm, or python3-plotly (its copy of plotly.js is "
              "used without npm), or pass -DVLT_PLOTLY_JS=/path/to/plotly.min.js")
    endif()
    file(MAKE_DIRECTORY ${_vlt_npm_dir})
    configure_file(${CMAKE_SOURCE_DIR}/package.json ${_vlt_npm_dir}/package.json COPYONLY)
    configure_file(${CMAKE_SOURCE_DIR}/package-lock.json ${_vlt_npm_dir}/package-lock.json COPYONLY)
    message(STATUS "vlt: npm ci (plotly.js-dist-min, pinned in package-lock.json)")
    execute_process(COMMAND ${VLT_NPM} ci --no-audit --no-fund --ignore-scripts
                    WORKING_DIRECTORY ${_vlt_npm_dir}
                    RESULT_VARIABLE _vlt_npm_rc OUTPUT_VARIABLE _vlt_npm_out ERROR_VARIABLE _vlt_npm_err)
    if(NOT _vlt_npm_rc EQUAL 0 OR NOT EXISTS ${_vlt_plotly})
      message(FATAL_ERROR "vlt: `npm ci` in ${_vlt_npm_dir} failed (exit ${_vlt_npm_rc}); it needs "
              "the npm registry once. Or pass -DVLT_PLOTLY_JS=/path/to/plotly.min.js.\n"
              "${_vlt_npm_out}${_vlt_npm_err}")
    endif()
  endif()
  set(VLT_PLOTLY_JS_FILE ${_vlt_plotly})
else()
  if(NOT EXISTS ${VLT_PLOTLY_JS})
    message(FATAL_ERROR "vlt: VLT_PLOTLY_JS=${VLT_PLOTLY_JS} does not exist")
  endif()
  set(VLT_PLOTLY_JS_FILE ${VLT_PLOTLY_JS})
endif()
# plotly.js's MIT licence text travels with every page that embeds it: the package's own LICENSE
# when it is there, else the copy in third_party/.
get_filename_component(_vlt_plotly_dir ${VLT_PLOTLY_JS_FILE} DIRECTORY)
if(EXISTS ${_vlt_plotly_dir}/LICENSE)
  set(VLT_PLOTLY_LICENSE_FILE ${_vlt_plotly_dir}/LICENSE)
else()
  set(VLT_PLOTLY_LICENSE_FILE ${CMAKE_SOURCE_DIR}/third_party/plotly.js-LICENSE)
endif()
# Read the version from the banner ("* plotly.js v4.1.2") for the report's footer.
file(STRINGS ${VLT_PLOTLY_JS_FILE} _vlt_plotly_banner LIMIT_COUNT 3 REGEX "plotly\\.js v")
string(REGEX MATCH "v[0-9][0-9.]*" VLT_PLOTLY_VERSION "${_vlt_plotly_banner}")
message(STATUS "vlt: embedding plotly.js ${VLT_PLOTLY_VERSION} from ${VLT_PLOTLY_JS_FILE}")
