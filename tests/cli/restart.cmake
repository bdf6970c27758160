# Checkpoint/restart: a run to 0.1 s resumed to 0.2 s must reproduce a straight run to 0.2 s
# bit for bit (the checkpoint stores the full state, including the staggered-grid parity and
# the mass ledger, and the scheme is deterministic).
# Fresh run directories (a rerun of the same scene would replace its files anyway).
file(REMOVE_RECURSE restart_first restart_second restart_full)
foreach(s restart_first restart_second restart_full)
  execute_process(COMMAND ${EXE} ${SRC}/${s}.xml RESULT_VARIABLE code OUTPUT_QUIET ERROR_QUIET)
  if(NOT code EQUAL 0)
    message(FATAL_ERROR "${s} exited with ${code}")
  endif()
endforeach()
file(STRINGS restart_second/profiles.csv a REGEX "^0\\.2,")
file(STRINGS restart_full/profiles.csv b REGEX "^0\\.2,")
list(LENGTH a na)
if(na EQUAL 0)
  message(FATAL_ERROR "no t = 0.2 rows in restart_second/profiles.csv")
endif()
if(NOT "${a}" STREQUAL "${b}")
  message(FATAL_ERROR "restarted run differs from the straight run at t = 0.2 s")
endif()
message("restart reproduces the straight run: ${na} rows identical")
