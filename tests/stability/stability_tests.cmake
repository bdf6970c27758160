# Stability suite (issue 12 item 1; tests/stability/stability.py states every case's required
# outcome). One ctest test per case under the label `stability` (the whole label: see
# docs/validation.md, "Stability suite", for its run time); the short ones also carry no `long`
# label and so run in the default suite:  ctest --test-dir build -L stability -j2
find_package(Python3 COMPONENTS Interpreter)
if(Python3_Interpreter_FOUND)
  set(_stab ${CMAKE_CURRENT_SOURCE_DIR}/stability/stability.py)
  execute_process(COMMAND ${Python3_EXECUTABLE} ${_stab} list
                  OUTPUT_VARIABLE _stab_all OUTPUT_STRIP_TRAILING_WHITESPACE)
  execute_process(COMMAND ${Python3_EXECUTABLE} ${_stab} list --default
                  OUTPUT_VARIABLE _stab_default OUTPUT_STRIP_TRAILING_WHITESPACE)
  set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${_stab})
  foreach(_c IN LISTS _stab_all)
    add_test(NAME stability.${_c}
             COMMAND ${Python3_EXECUTABLE} ${_stab} run ${_c} --exe $<TARGET_FILE:granflow>
                     --work ${CMAKE_CURRENT_BINARY_DIR}/stability)
    if(_c IN_LIST _stab_default)
      set_tests_properties(stability.${_c} PROPERTIES LABELS "stability" TIMEOUT 300)
    else()
      # not in the default suite (`-LE long` skips it), only under -L stability
      set_tests_properties(stability.${_c} PROPERTIES LABELS "stability;long" TIMEOUT 600)
    endif()
  endforeach()
else()
  message(WARNING "python3 not found: the stability suite is not registered")
endif()
