# Each bad-input scene must stop before the run with exit code 2 and a message that names the
# parameter, the value and what is allowed. run_cli.cmake runs granflow and checks both.
set(_cli ${CMAKE_CURRENT_SOURCE_DIR}/cli)
function(granflow_cli_test name expected_code regex)
  string(REPLACE ";" " " _args "${ARGN}")  # one -DARGS value; run_cli.cmake splits it again
  add_test(NAME cli.${name}
           COMMAND ${CMAKE_COMMAND} -DEXE=$<TARGET_FILE:granflow> "-DARGS=${_args}"
                   -DEXPECTED_CODE=${expected_code} -DREGEX=${regex}
                   -P ${_cli}/run_cli.cmake
           WORKING_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR})
  set_tests_properties(cli.${name} PROPERTIES LABELS "cli")
endfunction()

# usage and reference
granflow_cli_test(help 0 "usage: granflow" --help)
granflow_cli_test(no_arguments 1 "usage: granflow")
granflow_cli_test(unknown_option 1 "unknown option '--frobnicate'" --frobnicate)
# bad input (scene files in tests/cli/)
granflow_cli_test(missing_file 2 "cannot open scene file '.*does_not_exist.xml'"
                  ${_cli}/does_not_exist.xml)
granflow_cli_test(malformed_xml 2 "not a valid ParameterList XML" ${_cli}/bad_malformed.xml)
granflow_cli_test(misspelt_name 2 "Bed fricton angle.*(valid|Valid)" ${_cli}/bad_misspelt.xml)
granflow_cli_test(wrong_type 2 "wrong type.*Cells" ${_cli}/bad_wrong_type.xml)
granflow_cli_test(out_of_range 2 "CFL.*Max: 0\\.5.*Value entered: 0\\.8" ${_cli}/bad_out_of_range.xml)
granflow_cli_test(bad_enum 2 "Scheme.*Minmod, Beam-Warming.*Value entered: Superbee" ${_cli}/bad_enum.xml)
granflow_cli_test(delta_above_phi 2 "Bed friction angle' = 35.*Internal friction angle' = 30"
                  ${_cli}/bad_delta_above_phi.xml)
granflow_cli_test(inflow_on_wall 2 "Left boundary->Inflow depth.*Wall.*allowed only with Type = Inflow"
                  ${_cli}/bad_inflow_on_wall.xml)
granflow_cli_test(one_sided_periodic 2 "Right boundary->Type' = Outflow.*periodic"
                  ${_cli}/bad_one_sided_periodic.xml)
granflow_cli_test(missing_series_file 2 "Inflow series file' = .*no_such_series.csv.*cannot open"
                  ${_cli}/bad_missing_series.xml)
granflow_cli_test(unknown_model 2 "Model' = Navier.*allowed" ${_cli}/bad_unknown_model.xml)
granflow_cli_test(ic_parameter_of_other_type 2 "Initial condition->Left depth.*not used by initial condition Type 'Uniform'"
                  ${_cli}/bad_ic_mismatch.xml)
granflow_cli_test(dam_position_outside 2 "Position' = 2.*outside the channel.*\\[0, 1\\]"
                  ${_cli}/bad_position.xml)

# a valid run completes and writes the output contract
granflow_cli_test(good_run 0 "completed at t = 0.2 s" ${_cli}/good_run.xml)
# a run whose stable step collapses stops with a diagnosis and exit code 3
granflow_cli_test(diverged_min_dt 3 "stable time step .* fell below 'Min time step'.*last good output and checkpoint are kept"
                  ${_cli}/diverge_min_dt.xml)
# a 2D run whose nonlinear pressure solve fails stops with the Newton diagnosis and exit code 3
granflow_cli_test(diverged_newton 3 "nonlinear pressure system did not converge.*Newton.*last good output and checkpoint are kept"
                  ${_cli}/diverge_newton.xml)
granflow_cli_test(newton_method_not_jfnk 2 "Pressure Newton->Method' = Newton-Krylov \\(analytic Jacobian\\).*allowed: Jacobian-free"
                  ${_cli}/bad_newton_method.xml)
add_test(NAME cli.restart_reproduces_straight_run
         COMMAND ${CMAKE_COMMAND} -DEXE=$<TARGET_FILE:granflow> -DSRC=${_cli} -P ${_cli}/restart.cmake
         WORKING_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR})
add_test(NAME cli.parameters_doc_up_to_date
         COMMAND ${CMAKE_COMMAND} -DEXE=$<TARGET_FILE:granflow> -DDOC=${PROJECT_SOURCE_DIR}/docs/parameters.md
                 -P ${_cli}/params_doc.cmake)
set_tests_properties(cli.restart_reproduces_straight_run cli.parameters_doc_up_to_date PROPERTIES LABELS "cli")

# Run record (issue 13): restart checks, run-directory ownership, interrupts, memory estimate.
# bash scripts (record_lib.sh) with h5ls/h5dump of hdf5-tools; each a few seconds.
function(granflow_record_test name script)
  add_test(NAME cli.${name}
           COMMAND ${CMAKE_COMMAND} -E env EXE=$<TARGET_FILE:granflow> SRC=${_cli} ${ARGN}
                   bash ${_cli}/${script}
           WORKING_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR})
  set_tests_properties(cli.${name} PROPERTIES LABELS "cli" TIMEOUT 120)
endfunction()
granflow_record_test(restart_refuses_other_scene_or_damaged_checkpoint restart_checks.sh)
granflow_record_test(run_directory_owned_by_one_scene run_directory.sh)
granflow_record_test(interrupt_writes_checkpoint_and_summary interrupt.sh)
granflow_record_test(interrupt_np2_all_ranks_stop interrupt.sh NP=2)
set_tests_properties(cli.interrupt_np2_all_ranks_stop PROPERTIES LABELS "cli;mpi" PROCESSORS 2)
granflow_record_test(memory_estimate memory.sh)

# coupled model: decomposition checks
# a 2D subdomain with the default (closed-box, no free surface) N-DAM cannot take the gate inflow
granflow_cli_test(coupled_2d_without_free_surface 2 "Left boundary->Type' = Inflow.*closed at x = 0.*allowed: Wall"
                  ${_cli}/bad_coupled_2d.xml)
granflow_cli_test(coupled_count_mismatch 2 "Decomposition->Models.*one entry more than 'Interfaces'"
                  ${_cli}/bad_coupled_count.xml)
granflow_cli_test(coupled_bad_kind 2 "Models.*3D" ${_cli}/bad_coupled_kind.xml)
# a 1D bed friction angle (delta_1D) above phi
granflow_cli_test(coupled_delta1d_above_phi 2 "DAM->Bed friction angle' = 34.*must not exceed.*Internal friction angle = 33"
                  ${_cli}/bad_delta1d_above_phi.xml)
# decreasing interface positions (equal ones are allowed: a zero-length subdomain is left out)
granflow_cli_test(coupled_interfaces_decrease 2 "Decomposition->Interfaces.*0.7, 0.2.*must not decrease"
                  ${_cli}/bad_coupled_order.xml)

# coupled 2D/1D/2D against full 2D (Setup II, coarse)
add_test(NAME coupled.setup2_against_full_2d
         COMMAND ${CMAKE_COMMAND} -DEXE=$<TARGET_FILE:granflow> -DSTUDY=$<TARGET_FILE:granflow-study>
                 -DSRC=${_cli} -P ${_cli}/coupled_check.cmake
         WORKING_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR})
set_tests_properties(coupled.setup2_against_full_2d PROPERTIES LABELS "coupling" TIMEOUT 300)

# every shipped scene validates and builds its model (granflow --check)
file(GLOB _scenes ${PROJECT_SOURCE_DIR}/inputs/*.xml)
foreach(_s ${_scenes})
  get_filename_component(_n ${_s} NAME_WE)
  granflow_cli_test(scene_${_n} 0 "valid scene '${_n}'" --check ${_s})
endforeach()
