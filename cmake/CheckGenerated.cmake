# Run by CTest: regenerate into OUT and compare with the checked-in generated/ tree.
file(REMOVE_RECURSE ${OUT})
file(MAKE_DIRECTORY ${OUT})
execute_process(COMMAND ${VLT_GEN} --models ${MODELS} --out ${OUT} --spec-prefix models/
                RESULT_VARIABLE gen_rc)
if(NOT gen_rc EQUAL 0)
  message(FATAL_ERROR "vlt-gen failed (exit ${gen_rc})")
endif()
execute_process(COMMAND diff -ru ${CHECKED_IN} ${OUT}
                RESULT_VARIABLE diff_rc OUTPUT_VARIABLE diff_out ERROR_VARIABLE diff_err)
if(NOT diff_rc EQUAL 0)
  message(FATAL_ERROR "generated/ differs from what vlt-gen writes from models/ "
          "(run `cmake --build build --target regenerate`, or undo the hand edit):\n"
          "${diff_out}${diff_err}")
endif()
message(STATUS "generated/ is byte-identical to vlt-gen's output")
