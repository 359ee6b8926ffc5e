# The part's frame from the command line (docs/tasks.md "Alignment to nominal", docs/job-file.md
# [nominal], [[alignment]], [[deviation]]): the example runs, its report draws, and each class of
# bad input is one line naming the file and the key, exit 2, nothing written.
if(NOT TARGET vlt)
  return()
endif()

set(_al_cli ${CMAKE_CURRENT_SOURCE_DIR}/cli)
set(_al_jobs ${_al_cli}/alignment)
set(_al_out ${CMAKE_BINARY_DIR}/cli-tests)
set(_al_ex ${CMAKE_SOURCE_DIR}/examples/alignment)

# The example: a panel aligned on four tooling holes (and in a 3-2-1 jig); S17 (made 0.21 mm proud)
# is rejected against the +-0.15 mm band and makes the surface profile 0.42 mm (> 0.3 mm); the
# holes' positions conform; T2's deviation along z in the jig's frame is exactly 0 (the jig holds it)
# and is judged at the numerical resolution, not on its rounding noise (docs/monte-carlo.md §9).
# Under the sanitizers (CI stage 2) 2000 trials: the same code paths, a tenth of the re-alignments
# (20000 took 38 s there).
if(VLT_SANITIZE)
  set(_al_trials 2000)
else()
  set(_al_trials 20000)
endif()
add_test(NAME cli_alignment_panel
  COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
          "-DARGS=run;${_al_ex}/panel_alignment.toml;--trials;${_al_trials};-o;${_al_out}/alignment_panel"
          -DOUT=${_al_out}/alignment_panel
          "-DFILES=points.csv;tasks.csv;results.json;report.html"
          "-DEXPECT_STDOUT=to_cad +best_fit +rz +[-0-9.]+ deg .*jig_321 +rps +tx .*skin[.]S17 +deviation +deviation +0[.]2[0-9]+ mm.*in_jig[.]T2 +deviation +deviation +0[.]0000 mm[^\n]*µm  validated\n.*skin_profile +profile +profile +0[.]42[0-9]+ mm.*skin_profile profile <= 0[.]3 mm: does not conform"
          "-DEXPECT_FILE_REGEX=tasks.csv:skin[.]S17,deviation,deviation,mm,0[.]21[0-9]*,[^\n]*,does not conform,"
          -P ${_al_cli}/expect_outputs.cmake)
set_tests_properties(cli_alignment_panel PROPERTIES FIXTURES_SETUP vlt_alignment_panel)
add_test(NAME report_browser_alignment
  COMMAND ${CMAKE_COMMAND} -DPAGE=${_al_out}/alignment_panel/report.html -DPROFILE=${_al_out}/chromium-profile-alignment
          -DMIN_PLOTS=3 -P ${_al_cli}/report_browser.cmake)
set_tests_properties(report_browser_alignment PROPERTIES FIXTURES_REQUIRED vlt_alignment_panel TIMEOUT 300)

function(vlt_alignment_error name job regex)
  add_test(NAME cli_error_alignment_${name}
    COMMAND ${CMAKE_COMMAND} -DVLT=$<TARGET_FILE:vlt>
            "-DARGS=run;${_al_jobs}/${job};-o;${_al_out}/error_alignment_${name};--no-mcm"
            -DOUT=${_al_out}/error_alignment_${name} "-DEXPECT=${regex}"
            -P ${_al_cli}/expect_error.cmake)
endfunction()
vlt_alignment_error(weighted_features weighted_features.toml
                    "weighted_features\\.toml: alignment\\[0\\]\\.weighting: a features alignment is not a least-squares fit")
vlt_alignment_error(weighted_twin_clash weighted_twin_clash.toml
                    "weighted_twin_clash\\.toml: alignment\\[0\\]\\.weighting: its weighted fit's name 'holes_weighted' is already a task's")
vlt_alignment_error(no_nominal no_nominal.toml "no_nominal\\.toml: nominal: required key is missing")
vlt_alignment_error(features_twice features_twice.toml
                    "features_twice\\.toml: alignment\\[0\\]\\.line: point 'T2' is already a datum point of this alignment")
vlt_alignment_error(features_two_plane_points features_two_plane_points.toml
                    "features_two_plane_points\\.toml: alignment\\[0\\]\\.plane: a datum plane needs at least 3 points, 2 given")
vlt_alignment_error(unknown_kind unknown_kind.toml
                    "unknown_kind\\.toml: alignment\\[0\\]\\.kind: unknown alignment kind 'plane_line_point' \\(expected best_fit, rps or features\\)")
vlt_alignment_error(two_points two_points.toml "two_points\\.toml: alignment\\[0\\]\\.points: task 'a': best_fit needs at least 3 points, 2 given")
vlt_alignment_error(no_normal no_normal.toml
                    "no_normal\\.toml: deviation\\[0\\]\\.points: point 'T1' has no nominal normal")
vlt_alignment_error(unknown_alignment unknown_alignment.toml
                    "unknown_alignment\\.toml: deviation\\[0\\]\\.alignment: no \\[\\[alignment\\]\\] named 'b'")
vlt_alignment_error(collinear collinear.toml "collinear\\.toml: alignment\\[0\\]: .*best_fit: the points are collinear")
vlt_alignment_error(bad_normal bad_normal.toml "zero_normal\\.csv: line 2: the normal \\(i, j, k\\) has no direction")
vlt_alignment_error(rps_free rps_free.toml
                    "rps_free\\.toml: alignment\\[0\\]: .*rps: the held directions do not fix the part")
vlt_alignment_error(rps_bad_axes rps_bad_axes.toml
                    "rps_bad_axes\\.toml: alignment\\[0\\]\\.rps\\.T2: expected the axes the point holds, each of x, y, z at most once")
vlt_alignment_error(rps_few rps_few.toml
                    "rps_few\\.toml: alignment\\[0\\]\\.rps: the points hold 4 directions; a part has 6 degrees of freedom")
vlt_alignment_error(empty_nominal empty_nominal.toml "empty\\.csv: no points \\(nominal CSV columns")
vlt_alignment_error(deviation_twice deviation_twice.toml "deviation_twice\\.toml: deviation\\[0\\]\\.points: point 'S01' listed twice")
vlt_alignment_error(rps_unknown_point rps_unknown_point.toml
                    "rps_unknown_point\\.toml: alignment\\[0\\]\\.rps: point 'Q9' has no nominal position")
vlt_alignment_error(deviation_not_measured deviation_not_measured.toml
                    "deviation_not_measured\\.toml: deviation\\[0\\]\\.points: task 'd[.]X1': point 'X1' not measured")
