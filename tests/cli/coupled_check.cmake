# Setup II coupled 2D [0, 0.2] / 1D [0.2, 0.7] / 2D [0.7, 1] against the full 2D run at a coarse
# resolution (10 mm, 2D Drucker-Prager chute with Coulomb sliding), to t = 0.5 s, through the
# XML interface and granflow-study (the paper's error measures).
file(REMOVE_RECURSE coupled_check_ndam coupled_check_coupled coupled_check_cmp)
foreach(m ndam coupled)
  execute_process(COMMAND ${EXE} ${SRC}/coupled_check_${m}.xml RESULT_VARIABLE code
                  OUTPUT_QUIET ERROR_QUIET)
  if(NOT code EQUAL 0)
    message(FATAL_ERROR "coupled_check_${m}.xml exited with ${code}")
  endif()
endforeach()
execute_process(COMMAND ${STUDY} compare coupled_check_ndam coupled_check_coupled
                        --times 0.25 0.5 --out coupled_check_cmp
                RESULT_VARIABLE code OUTPUT_VARIABLE out)
message("${out}")
if(NOT code EQUAL 0)
  message(FATAL_ERROR "granflow-study compare exited with ${code}")
endif()
# Velocity averaged over [0, 0.2] m (the paper's Fig. 14 measure, around the 2D-1D interface):
# measured 0.11 % (t = 0.25 s) and 0.22 % (t = 0.5 s) (0.48 / 0.64 % before the 2D side of the
# 2D-to-1D interface continued the velocity gradient at its outflow, issue 5); the paper reports a
# few per cent for interfaces at x_IF >= 4 cm. Asserted 1 %.
file(STRINGS coupled_check_cmp/average_velocity.csv rows REGEX "^0\\.")
foreach(r ${rows})
  string(REPLACE "," ";" f "${r}")
  list(GET f 3 rel)
  if(rel GREATER 0.01)
    message(FATAL_ERROR "averaged velocity error ${rel} > 1 % (${r})")
  endif()
endforeach()
# Mean velocity over the flowing channel, L2 ratio: measured 1.0 % at 0.25 s and 2.0 % at 0.5 s
# (7.1 % at 0.5 s before the fixes of the interfaces, issue 5), where
# most of it sits at the front, which the 1D and 2D models shape differently (the paper's
# explanation of its Fig. 14 early-time errors). Asserted 5 %: a broken interface (reflection,
# lost inflow, the slowed top row) gives errors of 7 % to O(1) behind the 1D-2D interface.
file(STRINGS coupled_check_cmp/compare_errors.csv rows REGEX "^0\\.[0-9]*,u_mean,")
foreach(r ${rows})
  string(REPLACE "," ";" f "${r}")
  list(GET f 3 l2)
  if(l2 GREATER 0.05)
    message(FATAL_ERROR "u_mean L2 error ${l2} > 5 % (${r})")
  endif()
endforeach()
# granflow-study layout takes the channel length from the run; a --length that is not the run's
# (an independent run: reversed intervals and intervals beyond the channel, exit 0) or a
# negative margin is refused with exit 2, naming the option and what is allowed.
execute_process(COMMAND ${STUDY} layout coupled_check_ndam RESULT_VARIABLE code OUTPUT_VARIABLE out)
if(NOT code EQUAL 0 OR NOT out MATCHES "a priori layout from coupled_check_ndam")
  message(FATAL_ERROR "granflow-study layout without --length: exit ${code}: ${out}")
endif()
foreach(bad "--length;0.5;the run's channel is 1 m long" "--margin;-0.1;allowed: a length >= 0 m")
  list(GET bad 0 opt)
  list(GET bad 1 val)
  list(GET bad 2 msg)
  execute_process(COMMAND ${STUDY} layout coupled_check_ndam ${opt} ${val}
                  RESULT_VARIABLE code OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT code EQUAL 2 OR NOT err MATCHES "${opt} ${val}: .*${msg}")
    message(FATAL_ERROR "granflow-study layout ${opt} ${val}: exit ${code}, '${err}'")
  endif()
endforeach()
# compare refuses a time that is not an output of both runs before it writes anything (an
# independent run found header-only CSV files left behind)
file(REMOVE_RECURSE coupled_check_bad)
execute_process(COMMAND ${STUDY} compare coupled_check_ndam coupled_check_coupled --times 0.33
                        --out coupled_check_bad
                RESULT_VARIABLE code OUTPUT_QUIET ERROR_VARIABLE err)
if(NOT code EQUAL 2 OR NOT err MATCHES "time 0.33 s is not an output time of both runs" OR
   EXISTS coupled_check_bad)
  message(FATAL_ERROR "compare --times 0.33: exit ${code}, '${err}', or files left behind")
endif()
# compare refuses options out of their range (an independent run: --average-length 5 on this
# 1 m channel divided the integral over [0, 1] m by 5 m with exit 0, 0 and -1 gave averages of 0
# with an error of 0, a negative --h-min and --times 1e-400, read as 0, were taken)
foreach(bad "--average-length;5;allowed: a length in \\(0, 1\\] m" "--average-length;0;allowed: a length in"
            "--h-min;-1;allowed: a depth >= 0 m" "--u-min;-1;allowed: a speed >= 0 m/s")
  list(GET bad 0 opt)
  list(GET bad 1 val)
  list(GET bad 2 msg)
  execute_process(COMMAND ${STUDY} compare coupled_check_ndam coupled_check_coupled ${opt} ${val}
                          --out coupled_check_bad
                  RESULT_VARIABLE code OUTPUT_QUIET ERROR_VARIABLE err)
  if(NOT code EQUAL 2 OR NOT err MATCHES "${opt} ${val}: ${msg}" OR EXISTS coupled_check_bad)
    message(FATAL_ERROR "compare ${opt} ${val}: exit ${code}, '${err}', or files left behind")
  endif()
endforeach()
# a negative time is a value of --times, refused as such (it was taken for an unknown option)
execute_process(COMMAND ${STUDY} compare coupled_check_ndam coupled_check_coupled --times 0.25 -0.2
                RESULT_VARIABLE code OUTPUT_QUIET ERROR_VARIABLE err)
if(NOT code EQUAL 2 OR NOT err MATCHES "--times -0.2: allowed: output times >= 0 s")
  message(FATAL_ERROR "compare --times 0.25 -0.2: exit ${code}, '${err}'")
endif()
execute_process(COMMAND ${STUDY} compare coupled_check_ndam coupled_check_coupled --times 1e-400
                RESULT_VARIABLE code OUTPUT_QUIET ERROR_VARIABLE err)
if(NOT code EQUAL 2 OR NOT err MATCHES "needs a decimal number a double can hold, got '1e-400'")
  message(FATAL_ERROR "compare --times 1e-400: exit ${code}, '${err}'")
endif()
# Where the reference has no flowing point (here --h-min above every depth; also t = 0 before
# anything flows) the relative errors are undefined: empty fields and "-" in the table, not an
# error of 0 (an independent run).
file(REMOVE_RECURSE coupled_check_deep)
execute_process(COMMAND ${STUDY} compare coupled_check_ndam coupled_check_coupled --times 0.5
                        --h-min 10 --out coupled_check_deep
                RESULT_VARIABLE code OUTPUT_VARIABLE out ERROR_QUIET)
file(STRINGS coupled_check_deep/compare_errors.csv deep REGEX "^0\\.5,")
if(NOT code EQUAL 0 OR NOT deep STREQUAL "0.5,h,,,0;0.5,u_mean,,,0" OR
   NOT out MATCHES "0.5 \\|          - \\|")
  message(FATAL_ERROR "compare --h-min 10: exit ${code}, rows '${deep}', table '${out}'")
endif()
