# Run EXE with ARGS (a ;-list), require exit code EXPECTED_CODE and output matching REGEX.
separate_arguments(_args UNIX_COMMAND "${ARGS}")
execute_process(COMMAND ${EXE} ${_args}
                RESULT_VARIABLE _code OUTPUT_VARIABLE _out ERROR_VARIABLE _err)
set(_all "${_out}${_err}")
string(REPLACE "\n" " " _flat "${_all}")
message("exit code ${_code}\n${_all}")
if(NOT "${_code}" STREQUAL "${EXPECTED_CODE}")
  message(FATAL_ERROR "expected exit code ${EXPECTED_CODE}, got ${_code}")
endif()
if(NOT _flat MATCHES "${REGEX}")
  message(FATAL_ERROR "output does not match '${REGEX}'")
endif()
