# Cylinders and cones from the command line (docs/tasks.md "Cylinder and cone"): the example runs
# with its decisions, the form of nominal points is judged from Monte Carlo alone with its GUM U
# printed as n/a, and bad input is one line naming the file and the task, exit 2, nothing written.
if(NOT TARGET vlt)
  return()
endif()

set(_ft_cli ${CMAKE_CURRENT_SOURCE_DIR}/cli)
set(_ft_jobs ${_ft_cli}/features)
set(_ft_out ${CMAKE_BINARY_DIR}/cli-tests)
set(_ft_ex ${CMAKE_SOURCE_DIR}/examples/features)

# The shaft line: two 600 mm bores and a 1:15 taper planned from one station. Radii conform with
# their +-0.05 mm band, the cylindricity of a perfect bore is an MCM interval of some um with no
# GUM U, and the taper's half-angle is -atan(1/30) = -1.909152 deg (narrowing along +x). The form
# tasks by minimum zone (cylindricity, roundness) print both forms, Monte Carlo only.
add_test(NAME cli_features_shaft_line
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=run;${_ft_ex}/shaft_line.toml;--trials;2000;-o;${_ft_out}/features_shaft_line"
          -DOUT=${_ft_out}/features_shaft_line
          "-DFILES=points.csv;tasks.csv;results.json;report.html"
          "-DEXPECT_STDOUT=aft_bore +cylinder +radius +300[.]0000 mm +[0-9.]+ µm .*aft_bore +cylinder +cylindricity +0[.]0000 mm +n/a +[[][0-9.]+, [0-9.]+[]] µm  GUM n/a [(]not differentiable[)].*shaft_taper +cone +half_angle +-1[.]909152 deg .*aft_bore_form +cylindricity +cylindricity +0[.]0000 mm +n/a +[[][0-9.]+, [0-9.]+[]] µm  GUM n/a.*aft_bore_form +cylindricity +cylindricity_least_squares +0[.]0000 mm +n/a .*aft_section_1 +roundness +roundness +0[.]0000 mm +n/a .*aft_bore radius [[]299[.]95, 300[.]05[]] mm: conforms.*aft_bore_form cylindricity <= 0[.]05 mm: conforms [(]probability of conformity 1 Monte Carlo[)]"
          "-DEXPECT_FILE_REGEX=tasks.csv:shaft_taper,cone,radius,mm,243[.]3333333[0-9]*,"
          -P ${_ft_cli}/expect_outputs.cmake)

function(vlt_features_error name job regex)
  add_test(NAME cli_error_features_${name}
    COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
            "-DARGS=run;${_ft_jobs}/${job};-o;${_ft_out}/error_features_${name}"
            -DOUT=${_ft_out}/error_features_${name} "-DEXPECT=${regex}"
            -P ${_ft_cli}/expect_error.cmake)
endfunction()
vlt_features_error(one_ring one_ring.toml
                   "one_ring\\.toml: task\\[0\\]: .*cylinder: the points lie in one plane [(]one cross-section[)]: they do not determine the axis; a circle task fits one section")
vlt_features_error(cone_five_points cone_five_points.toml
                   "cone_five_points\\.toml: task\\[0\\].*: cone needs at least 6 points, 5 given")
