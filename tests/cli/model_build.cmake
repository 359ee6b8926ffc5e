# Run by CTest (tests/model_build.cmake): a model that is not compiled into vlt, built and used from an
# installed prefix (issue 31; docs/custom-models.md "Without rebuilding vlt"). Install the build tree
# into a fresh prefix; with that prefix's vlt (which finds vlt-gen beside itself and the headers in
# <prefix>/include), build tests/models/jcgm101_comparison_loss.toml into a fresh model cache, find it
# there the second time, and run JCGM 101 9.4 with it, r = 0 and r = 0.9: the Monte Carlo mean and
# u(y) against the exact moments of the quadratic form (x^T x + tr V, 2 tr(V^2) + 4 x^T V x), the
# GUM's first order against its closed form (y = x^T x, u = 2 |V^(1/2) x|). A changed spec is
# rebuilt; a bad spec and a missing compiler are one line, exit 2.
#   -DBUILD_DIR=... -DSOURCE_DIR=... -DOUT=... -DCXX=...
cmake_minimum_required(VERSION 3.25)
file(REMOVE_RECURSE ${OUT})
set(prefix ${OUT}/prefix)
set(ENV{VLT_MODEL_CACHE} ${OUT}/cache)
unset(ENV{VLT_GEN})
unset(ENV{VLT_INCLUDE_DIR})
set(ENV{CXX} ${CXX})
macro(run what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${what} failed (${rc}):\n${out}\n${err}")
  endif()
endmacro()
macro(refused what expect)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 2 OR NOT err MATCHES "^vlt: error: [^\n]*${expect}[^\n]*\n$")
    message(FATAL_ERROR "${what}: expected exit 2 and one line matching '${expect}', got ${rc}:\n${out}\n${err}")
  endif()
endmacro()
run("cmake --install" ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix})
foreach(f bin/vlt bin/vlt-gen include/vlt/model_info.h)
  if(NOT EXISTS ${prefix}/${f})
    message(FATAL_ERROR "cmake --install did not install ${f}")
  endif()
endforeach()
set(vlt ${prefix}/bin/vlt)
set(spec ${SOURCE_DIR}/tests/models/jcgm101_comparison_loss.toml)

run("vlt model build" ${vlt} model build ${spec})
if(NOT out MATCHES "Built model 'jcgm101_comparison_loss' \\(custom, 2 inputs, 1 output\\)")
  message(FATAL_ERROR "unexpected build output:\n${out}")
endif()
run("vlt model build (again)" ${vlt} model build ${spec})
if(NOT out MATCHES "Model 'jcgm101_comparison_loss' is up to date in the cache")
  message(FATAL_ERROR "the second build did not find the cache:\n${out}")
endif()
run("vlt model list" ${vlt} model list)
if(NOT out MATCHES "jcgm101_comparison_loss +custom +2 +1 +\\(built\\)")
  message(FATAL_ERROR "vlt model list does not show the built model:\n${out}")
endif()

# JCGM 101 9.4: x1 = 0.010, x2 = 0, u = 0.005, r = 0 and 0.9.
function(check_job r expect_mean expect_u)
  set(job ${OUT}/loss_${r}.toml)
  set(text "[job]\nname = \"loss\"\n[model]\nname = \"jcgm101_comparison_loss\"\n[monte_carlo]\ntrials = 1000000\nseed = 1\n")
  if(NOT r STREQUAL "0")
    string(APPEND text "[correlations.reflection]\ninputs = [\"x1\", \"x2\"]\nmatrix = [[1, ${r}], [${r}, 1]]\n")
  endif()
  file(WRITE ${job} "${text}")
  run("vlt run (r = ${r})" ${vlt} run ${job} -q -o ${OUT}/run_${r})
  file(READ ${OUT}/run_${r}/results.json json)
  string(JSON gum_y GET "${json}" outputs 0 gum estimate)
  string(JSON gum_u GET "${json}" outputs 0 gum u)
  string(JSON mcm_y GET "${json}" outputs 0 mcm mean)
  string(JSON mcm_u GET "${json}" outputs 0 mcm u)
  # GUM first order: y = 1e-4, u = 2 x1 u(x1) = 1e-4 (r does not enter: dy/dx2 = 0).
  foreach(pair "gum_y;1e-4;1e-12" "gum_u;1e-4;1e-12" "mcm_y;${expect_mean};3e-7" "mcm_u;${expect_u};5e-7")
    list(GET pair 0 name)
    list(GET pair 1 want)
    list(GET pair 2 tolerance)
    set(got ${${name}})
    # |got - want| <= tolerance (awk: CMake has no floating-point arithmetic).
    execute_process(COMMAND awk "BEGIN { exit !((${got} - ${want}) <= ${tolerance} && (${want} - ${got}) <= ${tolerance}) }"
                    RESULT_VARIABLE close)
    if(NOT close EQUAL 0)
      message(FATAL_ERROR "r = ${r}: ${name} = ${got}, expected ${want} within ${tolerance}")
    endif()
  endforeach()
endfunction()
# Exact: mean = x1^2 + 2 u^2 = 1.5e-4; variance = 2 tr(V^2) + 4 x^T V x:
# r = 0: 2 * 2 u^4 + 4 x1^2 u^2 = 1.25e-8 -> u = 1.1180e-4; r = 0.9: 2 u^4 (2 + 2 r^2) + 4 x1^2 u^2
# = 1.4525e-8 -> u = 1.2052e-4. With 10^6 trials (seed 1) the sampling error is 1.2e-7 in the mean and
# ~0.15 % in u: tolerances 3e-7 and 5e-7 (vlt gave 1.50086e-4 and 1.1175e-4, 1.2040e-4).
check_job(0 1.5e-4 1.1180e-4)
check_job(0.9 1.5e-4 1.2052e-4)

# A job may name the spec instead of the model ([model] spec, relative to the job file): the cache
# holds it (the same bytes), so the run starts at once.
file(COPY ${spec} DESTINATION ${OUT}/spec_job)
file(WRITE ${OUT}/spec_job/job.toml "[model]\nspec = \"jcgm101_comparison_loss.toml\"\n[monte_carlo]\ntrials = 10000\n")
run("vlt run with [model] spec" ${vlt} run ${OUT}/spec_job/job.toml -q -o ${OUT}/spec_job/out)
file(READ ${OUT}/spec_job/out/results.json json)
string(JSON gum_u GET "${json}" outputs 0 gum u)
if(NOT gum_u STREQUAL "0.0001")
  message(FATAL_ERROR "[model] spec: u = ${gum_u}, expected 0.0001")
endif()

# A changed spec is built again (the key is its bytes).
file(READ ${spec} text)
string(REPLACE "JCGM 101 9.4 comparison loss" "JCGM 101 9.4 comparison loss (edited)" text "${text}")
file(WRITE ${OUT}/edited/jcgm101_comparison_loss.toml "${text}")
run("vlt model build (edited)" ${vlt} model build ${OUT}/edited/jcgm101_comparison_loss.toml)
if(NOT out MATCHES "Built model")
  message(FATAL_ERROR "an edited spec was not built again:\n${out}")
endif()
# Refusals: a spec error names its file and key; no compiler; a built-in model's name.
string(REPLACE "expression = \"x1^2 + x2^2\"" "expression = \"x1^2 + x3\"" bad "${text}")
file(WRITE ${OUT}/bad/jcgm101_comparison_loss.toml "${bad}")
refused("a bad spec" "jcgm101_comparison_loss\\.toml: .*x3" ${vlt} model build ${OUT}/bad/jcgm101_comparison_loss.toml)
set(ENV{CXX} ${OUT}/no-such-compiler)
file(WRITE ${OUT}/other/jcgm101_comparison_loss.toml "${text}\n# another byte\n")
refused("no compiler" "no C.. compiler found" ${vlt} model build ${OUT}/other/jcgm101_comparison_loss.toml)
set(ENV{CXX} ${CXX})
string(REPLACE "name = \"jcgm101_comparison_loss\"" "name = \"mirror\"" clash "${text}")
file(WRITE ${OUT}/clash/mirror.toml "${clash}")
refused("a built-in name" "a built-in model is called 'mirror'" ${vlt} model build ${OUT}/clash/mirror.toml)
# Two builds of one spec at once (CMake runs the COMMANDs of one execute_process side by side): both
# succeed, one builds and the other waits for it and finds the cache. CMake pipes the first's
# standard output into the second, which reads none and may have ended: the first is --quiet
# (a line written into the closed pipe was a SIGPIPE, now and then).
file(READ ${spec} base)
file(WRITE ${OUT}/twice/jcgm101_comparison_loss.toml "${base}\n# built twice at once\n")
execute_process(COMMAND ${vlt} --quiet model build ${OUT}/twice/jcgm101_comparison_loss.toml
                COMMAND ${vlt} model build ${OUT}/twice/jcgm101_comparison_loss.toml
                RESULTS_VARIABLE codes OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT codes STREQUAL "0;0")
  message(FATAL_ERROR "two builds at once: exit codes ${codes}:\n${out}\n${err}")
endif()
# vlt-gen failing without a message is said so; a text with a control character is a spec error.
set(ENV{VLT_GEN} /bin/false)
file(WRITE ${OUT}/gen_fails/jcgm101_comparison_loss.toml "${base}\n# another\n")
refused("vlt-gen fails" "vlt-gen failed .exit 1." ${vlt} model build ${OUT}/gen_fails/jcgm101_comparison_loss.toml)
unset(ENV{VLT_GEN})
string(REPLACE "description = \"Real part" "description = \"Real\\r part" cr "${base}")
file(WRITE ${OUT}/cr/jcgm101_comparison_loss.toml "${cr}")
refused("a control character" "input.0..*description: must be one line without control characters"
        ${vlt} model build ${OUT}/cr/jcgm101_comparison_loss.toml)
# An entry others may write is not loaded (a library in it would run their code).
file(CHMOD ${OUT}/cache/jcgm101_comparison_loss DIRECTORY_PERMISSIONS OWNER_READ OWNER_WRITE OWNER_EXECUTE GROUP_READ
     GROUP_WRITE GROUP_EXECUTE)
refused("an entry others may write" "writable by nobody else" ${vlt} run ${OUT}/loss_0.toml -q -o ${OUT}/run_refused)
file(CHMOD ${OUT}/cache/jcgm101_comparison_loss DIRECTORY_PERMISSIONS OWNER_READ OWNER_WRITE OWNER_EXECUTE)
run("vlt run after the entry is the user's again" ${vlt} run ${OUT}/loss_0.toml -q --no-mcm -o ${OUT}/run_again)
message(STATUS "vlt model build from ${prefix}: built, cached, JCGM 101 9.4 (r = 0, 0.9) against the exact moments")
