# Run by CTest (tests/calibration.cmake): the calibration file vlt just wrote (NEW) must equal the
# one shipped in examples/ (OLD) except for the lines that record when and from where it was made
# (created, vlt_version, data file paths): the shipped example is what vlt computes today.
#   -DNEW=... -DOLD=...
cmake_minimum_required(VERSION 3.25)
foreach(which NEW OLD)
  file(STRINGS ${${which}} lines)
  list(FILTER lines EXCLUDE REGEX "^(created|vlt_version|file) = ")
  set(${which}_lines "${lines}")
endforeach()
if(NOT NEW_lines STREQUAL OLD_lines)
  message(FATAL_ERROR "${NEW} differs from ${OLD}: regenerate the example (docs/calibration.md) or find the regression")
endif()
message(STATUS "ok: ${NEW} matches ${OLD}")
