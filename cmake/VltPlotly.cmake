# plotly.js for vlt's self-contained report.html.
#
# The version is pinned in package.json / package-lock.json at the top of the repository (npm
# registry package `plotly.js-dist-min`, integrity hash in the lock file). At configure time
# `npm ci` installs it into <build>/npm/node_modules; runtime/src/output/plotly.cc then compiles
# the minified script INTO libvlt_runtime (assembler .incbin), so the `vlt` binary needs no file at
# run time and every report.html it writes opens offline.
#
# -DVLT_PLOTLY_JS=/path/to/plotly.min.js skips npm (e.g. for an offline build with a copy of the
# same file).
set(VLT_PLOTLY_JS "" CACHE FILEPATH "plotly.min.js to embed (empty: npm ci from package-lock.json)")

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
    find_program(VLT_NPM npm)
    if(NOT VLT_NPM)
      message(FATAL_ERROR "vlt: npm not found (needed once to fetch plotly.js for report.html). "
              "Install the Debian packages: apt-get install nodejs npm")
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
