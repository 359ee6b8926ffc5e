# The house rules of docs/README.md, checked on every run of the suite:
#  - layering: the table "| folder | holds | may use |" against the includes of runtime/src,
#    runtime/cli and python/, and against the symbols the runtime's object files need and define;
#  - function_length: no function of runtime/ or symbolic/ over 150 lines.
find_package(Python3 COMPONENTS Interpreter REQUIRED)
add_test(NAME layering
  COMMAND ${Python3_EXECUTABLE} ${CMAKE_CURRENT_SOURCE_DIR}/house/check_layering.py ${CMAKE_SOURCE_DIR}
          ${CMAKE_BINARY_DIR}/runtime/CMakeFiles/vlt_runtime_objects.dir)
add_test(NAME function_length
  COMMAND ${Python3_EXECUTABLE} ${CMAKE_CURRENT_SOURCE_DIR}/house/check_function_length.py ${CMAKE_SOURCE_DIR} 150)
set_tests_properties(layering function_length PROPERTIES TIMEOUT 300)
add_test(NAME house_rules_selftest
  COMMAND ${Python3_EXECUTABLE} ${CMAKE_CURRENT_SOURCE_DIR}/house/selftest.py)
# scripts/lib.sh's Fedora names: one for every Debian package, and dnf asked for the missing ones.
add_test(NAME setup_fedora_names COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/house/check_fedora_names.sh ${CMAKE_SOURCE_DIR})
set_tests_properties(setup_fedora_names PROPERTIES PASS_REGULAR_EXPRESSION "ok: [0-9]+ Debian packages have Fedora names")
