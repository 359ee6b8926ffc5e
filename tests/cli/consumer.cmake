# Run by CTest (tests/cli.cmake cli_consumer_install): install the build tree into a fresh prefix,
# then build examples/consumer against it twice — with find_package(vlt) and with pkg-config — and
# run both: they must run the demo job through the installed library and print its results; with
# PYTHON, the installed Python module must print the same.
#   -DBUILD_DIR=... -DSOURCE_DIR=... -DOUT=... -DCXX=... [-DPYTHON=python3: also the installed Python module]
cmake_minimum_required(VERSION 3.25)
file(REMOVE_RECURSE ${OUT})
set(prefix ${OUT}/prefix)
macro(run what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${what} failed (${rc}):\n${out}\n${err}")
  endif()
endmacro()
run("cmake --install" ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix})
foreach(f include/vlt/results.h lib/libvlt.a lib/cmake/vlt/vltConfig.cmake lib/cmake/vlt/vltConfigVersion.cmake
          lib/cmake/vlt/vltTargets.cmake lib/pkgconfig/vlt.pc bin/vlt)
  if(NOT EXISTS ${prefix}/${f})
    message(FATAL_ERROR "cmake --install did not install ${f}")
  endif()
endforeach()
# 1. CMake: find_package(vlt) -> vlt::vlt with its dependencies.
run("configure the consumer" ${CMAKE_COMMAND} -S ${SOURCE_DIR}/examples/consumer -B ${OUT}/build
    -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_BUILD_TYPE=Release)
run("build the consumer" ${CMAKE_COMMAND} --build ${OUT}/build)
run("run the consumer" ${OUT}/build/vlt_consumer)
if(NOT out MATCHES "job 'vlt-demo', [0-9]+ points.*worst point .*: \\|U\\| = [0-9.]+ µm.*task ")
  message(FATAL_ERROR "unexpected consumer output:\n${out}")
endif()
set(cmake_out "${out}")
# 2. pkg-config: the same program from `pkg-config --cflags --libs vlt`.
set(ENV{PKG_CONFIG_PATH} ${prefix}/lib/pkgconfig)
run("pkg-config" pkg-config --cflags --libs vlt)
separate_arguments(flags UNIX_COMMAND "${out}")
run("compile with pkg-config" ${CXX} -std=c++20 -O1 ${SOURCE_DIR}/examples/consumer/main.cc -o ${OUT}/consumer_pc ${flags})
run("run the pkg-config consumer" ${OUT}/consumer_pc)
if(NOT out STREQUAL cmake_out)
  message(FATAL_ERROR "the two consumers differ:\n${cmake_out}\n${out}")
endif()
# 3. Python: the installed module runs the same job (written by the installed `vlt demo
# --show-job`) and prints the same lines (examples/consumer/consumer.py).
if(PYTHON)
  file(GLOB module ${prefix}/lib/python3*/dist-packages/vlt*.so)
  if(NOT module)
    message(FATAL_ERROR "cmake --install did not install the Python module into lib/python3.X/dist-packages")
  endif()
  get_filename_component(module_dir "${module}" DIRECTORY)
  run("vlt demo --show-job" ${prefix}/bin/vlt demo --show-job)
  file(WRITE ${OUT}/vlt-demo.toml "${out}")
  set(ENV{PYTHONPATH} ${module_dir})
  run("the Python consumer" ${PYTHON} ${SOURCE_DIR}/examples/consumer/consumer.py ${OUT}/vlt-demo.toml)
  if(NOT out STREQUAL cmake_out)
    message(FATAL_ERROR "the Python consumer differs from the C++ one:\n${cmake_out}\n${out}")
  endif()
  # Without a job it says how to run it (exit 2), not a Python traceback.
  execute_process(COMMAND ${PYTHON} ${SOURCE_DIR}/examples/consumer/consumer.py RESULT_VARIABLE rc
                  OUTPUT_VARIABLE usage_out ERROR_VARIABLE usage_err)
  if(NOT rc EQUAL 2 OR NOT usage_err MATCHES "usage: python3 consumer.py JOB.toml" OR usage_err MATCHES "Traceback")
    message(FATAL_ERROR "consumer.py without a job: exit ${rc}, expected 2 and its usage:\n${usage_err}")
  endif()
endif()
message(STATUS "ok:\n${out}")
