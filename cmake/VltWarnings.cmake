# The project's own code builds with -Wall -Wextra -Werror; third-party headers are SYSTEM.
function(vlt_target_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Werror)
endfunction()
