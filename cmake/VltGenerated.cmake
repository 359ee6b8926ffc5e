# generated/ is checked in and must be exactly what vlt-gen writes from models/.
#  - test `generated_is_up_to_date`: regenerate into the build tree, fail with a diff if different
#  - target `regenerate`: rewrite generated/ on purpose
#  - -DVLT_REGENERATE=ON: regenerate generated/ before building whenever a spec or vlt-gen changed
file(GLOB VLT_MODEL_SPECS CONFIGURE_DEPENDS ${CMAKE_SOURCE_DIR}/models/*.toml)
set(VLT_GENERATED_DIR ${CMAKE_SOURCE_DIR}/generated)

add_custom_target(regenerate
  COMMAND vlt-gen --models ${CMAKE_SOURCE_DIR}/models --out ${VLT_GENERATED_DIR}
          --spec-prefix models/
  DEPENDS vlt-gen
  COMMENT "vlt-gen: rewriting generated/ from models/"
  VERBATIM)

if(VLT_REGENERATE)
  set(_stamp ${CMAKE_BINARY_DIR}/generated.stamp)
  add_custom_command(OUTPUT ${_stamp}
    COMMAND vlt-gen --models ${CMAKE_SOURCE_DIR}/models --out ${VLT_GENERATED_DIR}
            --spec-prefix models/
    COMMAND ${CMAKE_COMMAND} -E touch ${_stamp}
    DEPENDS vlt-gen ${VLT_MODEL_SPECS}
    COMMENT "vlt-gen: models/ or the generator changed, regenerating generated/"
    VERBATIM)
  add_custom_target(vlt_regenerate_if_needed DEPENDS ${_stamp})
endif()

if(VLT_BUILD_TESTS)
  add_test(NAME generated_is_up_to_date
    COMMAND ${CMAKE_COMMAND}
      -DVLT_GEN=$<TARGET_FILE:vlt-gen>
      -DMODELS=${CMAKE_SOURCE_DIR}/models
      -DCHECKED_IN=${VLT_GENERATED_DIR}
      -DOUT=${CMAKE_BINARY_DIR}/regenerated
      -P ${CMAKE_SOURCE_DIR}/cmake/CheckGenerated.cmake)
endif()
