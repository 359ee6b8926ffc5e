# Run by CTest (tests/cli.cmake setup_plotly_fallback): where `npm ci` cannot run (no npm, or no
# registry: npm here is /bin/false), cmake/VltPlotly.cmake embeds the copy of plotly.js a
# distribution package ships (VLT_DEBIAN_PLOTLY_JS, here a stand-in file) with a warning; with
# neither it stops with one message naming the three ways.
#   -DSOURCE_DIR=<repository> -DOUT=<scratch directory>
cmake_minimum_required(VERSION 3.25)
file(REMOVE_RECURSE ${OUT})
file(MAKE_DIRECTORY ${OUT}/project/third_party)
file(WRITE ${OUT}/project/CMakeLists.txt
     "cmake_minimum_required(VERSION 3.25)\nproject(plotly_fallback NONE)\ninclude(${SOURCE_DIR}/cmake/VltPlotly.cmake)\n")
foreach(f package.json package-lock.json third_party/plotly.js-LICENSE)
  configure_file(${SOURCE_DIR}/${f} ${OUT}/project/${f} COPYONLY)
endforeach()
file(WRITE ${OUT}/packaged-plotly.js "/**\n* plotly.js v9.8.7\n*/\nvar Plotly = {};\n")
# 1. npm fails, a packaged copy exists: a warning, and that copy is embedded.
execute_process(COMMAND ${CMAKE_COMMAND} -S ${OUT}/project -B ${OUT}/with_copy -DVLT_NPM=/bin/false
                        -DVLT_DEBIAN_PLOTLY_JS=${OUT}/packaged-plotly.js
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
# (CMake wraps a warning's lines where it likes: compare with the whitespace folded.)
string(REGEX REPLACE "[ \n]+" " " err_flat "${err}")
if(NOT rc EQUAL 0 OR NOT out MATCHES "embedding plotly.js v9[.]8[.]7 from ${OUT}/packaged-plotly.js"
   OR NOT err_flat MATCHES "npm ci. in .* failed.*Embedding Debian's python3-plotly copy")
  message(FATAL_ERROR "npm failing with a packaged copy: exit ${rc}\n${out}\n${err}")
endif()
# 2. Neither: the configuration stops and says how to get plotly.js.
execute_process(COMMAND ${CMAKE_COMMAND} -S ${OUT}/project -B ${OUT}/without -DVLT_NPM=/bin/false
                        -DVLT_DEBIAN_PLOTLY_JS=${OUT}/no-such-file.js
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
string(REGEX REPLACE "[ \n]+" " " err_flat "${err}")
if(rc EQUAL 0 OR NOT err_flat MATCHES "Install the Debian packages nodejs and npm .*python3-plotly .*-DVLT_PLOTLY_JS=")
  message(FATAL_ERROR "neither npm nor a packaged copy: exit ${rc}, expected a failure naming the ways\n${err}")
endif()
message(STATUS "ok")
