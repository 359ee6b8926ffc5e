# Numbers the docs quote from vlt's own runs, checked against a run (tests/docs/check_doc_numbers.py):
# a quoted result that the code no longer gives fails the suite instead of misleading a reader.
if(NOT TARGET vlt)
  return()
endif()
find_package(Python3 COMPONENTS Interpreter REQUIRED)
add_test(NAME doc_numbers
  COMMAND ${Python3_EXECUTABLE} ${CMAKE_CURRENT_SOURCE_DIR}/docs/check_doc_numbers.py $<TARGET_FILE:vlt>
          ${CMAKE_SOURCE_DIR} ${CMAKE_BINARY_DIR}/doc-numbers)
