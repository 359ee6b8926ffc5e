# The project's own code builds with -Wall -Wextra; third-party headers are SYSTEM. Warnings are
# errors where vlt is developed (CI: .ci/run exports VLT_WARNINGS_AS_ERRORS=ON, scripts/lib.sh
# passes it on), not where it is only built: a newer compiler's new warning must not stop a
# user's build (issue 34).
option(VLT_WARNINGS_AS_ERRORS "Treat warnings in vlt's own code as errors (CI)" OFF)
function(vlt_target_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra $<$<BOOL:${VLT_WARNINGS_AS_ERRORS}>:-Werror>)
endfunction()
