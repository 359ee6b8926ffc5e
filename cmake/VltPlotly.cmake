# plotly.js for vlt's self-contained report.html.
#
# Where the script comes from, the first that applies:
#  1. -DVLT_PLOTLY_JS=/path/to/plotly.min.js: that file (an offline build with a copy of it);
#  2. the version pinned in package.json / package-lock.json at the top of the repository (npm
#     registry package `plotly.js-dist-min`, integrity hash in the lock file), installed by `npm ci`
#     into <build>/npm/node_modules (once; again when the lock file changes) — the build vlt is
#     tested with;
#  3. where npm is missing or `npm ci` cannot reach its registry (an air-gapped lab): the copy that
#     Debian's package python3-plotly ships, /usr/share/python3-plotly/plotly.js (plotly.js v2.6.3
#     in Debian 12, not minified: the reports grow by about 4 MB), with a warning. The test
#     report_browser_demo_debian_plotly draws the run report with it.
# runtime/src/output/plotly.cc then compiles the script INTO libvlt_runtime (cmake/vlt_embed.cc),
# so the `vlt` binary needs no file at run time and every report.html it writes opens offline.
set(VLT_PLOTLY_JS "" CACHE FILEPATH "plotly.js to embed (empty: npm ci from package-lock.json, else Debian's python3-plotly copy)")
set(VLT_DEBIAN_PLOTLY_JS /usr/share/python3-plotly/plotly.js CACHE FILEPATH
    "plotly.js embedded where npm is missing or fails (Debian package python3-plotly)")

# The pinned npm package in <build>/npm when its lock file matches the repository's; else "".
function(vlt_pinned_plotly out)
  set(_dir ${CMAKE_BINARY_DIR}/npm)
  set(_plotly ${_dir}/node_modules/plotly.js-dist-min/plotly.min.js)
  file(SHA256 ${CMAKE_SOURCE_DIR}/package-lock.json _want)
  set(${out} "" PARENT_SCOPE)
  if(EXISTS ${_dir}/package-lock.json AND EXISTS ${_plotly})
    file(SHA256 ${_dir}/package-lock.json _have)  # the lock file copied beside node_modules: a stamp
    if(_have STREQUAL _want)
      set(${out} ${_plotly} PARENT_SCOPE)
    endif()
  endif()
endfunction()

# Runs `npm ci` for the pinned package; sets `error` to why it failed ("" when it worked).
function(vlt_npm_ci error)
  set(_dir ${CMAKE_BINARY_DIR}/npm)
  find_program(VLT_NPM npm)
  if(NOT VLT_NPM)
    set(${error} "npm not found (Debian packages nodejs and npm)" PARENT_SCOPE)
    return()
  endif()
  file(MAKE_DIRECTORY ${_dir})
  configure_file(${CMAKE_SOURCE_DIR}/package.json ${_dir}/package.json COPYONLY)
  configure_file(${CMAKE_SOURCE_DIR}/package-lock.json ${_dir}/package-lock.json COPYONLY)
  message(STATUS "vlt: npm ci (plotly.js-dist-min, pinned in package-lock.json)")
  # An unreachable registry can keep npm retrying for minutes: at most 5 minutes, then the fallback.
  execute_process(COMMAND ${VLT_NPM} ci --no-audit --no-fund --ignore-scripts WORKING_DIRECTORY ${_dir}
                  RESULT_VARIABLE _rc OUTPUT_VARIABLE _out ERROR_VARIABLE _err TIMEOUT 300)
  if(NOT _rc EQUAL 0 OR NOT EXISTS ${_dir}/node_modules/plotly.js-dist-min/plotly.min.js)
    file(REMOVE ${_dir}/package-lock.json)  # no stamp: the next configure tries again
    set(${error} "`npm ci` in ${_dir} failed (exit ${_rc}; it needs the npm registry once):\n${_out}${_err}"
        PARENT_SCOPE)
  else()
    set(${error} "" PARENT_SCOPE)
  endif()
endfunction()

if(VLT_PLOTLY_JS)
  if(NOT EXISTS ${VLT_PLOTLY_JS})
    message(FATAL_ERROR "vlt: VLT_PLOTLY_JS=${VLT_PLOTLY_JS} does not exist")
  endif()
  set(VLT_PLOTLY_JS_FILE ${VLT_PLOTLY_JS})
else()
  vlt_pinned_plotly(VLT_PLOTLY_JS_FILE)
  if(NOT VLT_PLOTLY_JS_FILE)
    vlt_npm_ci(_vlt_npm_error)
    vlt_pinned_plotly(VLT_PLOTLY_JS_FILE)
  endif()
  if(NOT VLT_PLOTLY_JS_FILE)
    if(EXISTS ${VLT_DEBIAN_PLOTLY_JS})
      message(WARNING "vlt: ${_vlt_npm_error}\nEmbedding Debian's python3-plotly copy of plotly.js "
              "(${VLT_DEBIAN_PLOTLY_JS}) instead of the version pinned in package-lock.json.")
      set(VLT_PLOTLY_JS_FILE ${VLT_DEBIAN_PLOTLY_JS})
    else()
      message(FATAL_ERROR "vlt: plotly.js for report.html: ${_vlt_npm_error}\nInstall the Debian packages "
              "nodejs and npm (with the npm registry reachable once), or python3-plotly (its copy of "
              "plotly.js is used without npm), or pass -DVLT_PLOTLY_JS=/path/to/plotly.min.js.")
    endif()
  endif()
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
