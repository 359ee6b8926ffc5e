# Run by CTest (tests/cli.cmake): the run report carries the exact bytes of the plotly.js file and of
# its licence that the build embedded (cmake/vlt_embed.cc writes them as string literals: an escape
# written wrong, a piece lost or a CR/UTF-8 byte changed by the compiler would show here).
#   -DPAGE=/abs/report.html -DPLOTLY=/abs/plotly.min.js -DLICENSE=/abs/LICENSE
cmake_minimum_required(VERSION 3.25)
foreach(_file PAGE PLOTLY LICENSE)
  if(NOT EXISTS "${${_file}}")
    message(FATAL_ERROR "${_file}=${${_file}} does not exist")
  endif()
endforeach()
file(READ "${PAGE}" _page)
foreach(_asset PLOTLY LICENSE)
  file(READ "${${_asset}}" _bytes)
  string(LENGTH "${_bytes}" _size)
  file(SIZE "${${_asset}}" _file_size)
  if(NOT _size EQUAL _file_size)
    message(FATAL_ERROR "${${_asset}}: read ${_size} of its ${_file_size} bytes (a NUL byte?)")
  endif()
  string(FIND "${_page}" "${_bytes}" _at)
  if(_at EQUAL -1)
    message(FATAL_ERROR "${PAGE} does not hold the ${_size} bytes of ${${_asset}} unchanged")
  endif()
  message(STATUS "ok: the ${_size} bytes of ${${_asset}} at offset ${_at}")
endforeach()
