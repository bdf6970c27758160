# GRANFLOW_SANITIZE: compile the sanitizers' runtime defaults (default_options.cpp) into every
# executable of the project, so that a plain `ctest` (and `mpiexec ... granflow`) of the
# sanitizer build runs with them; ASAN_OPTIONS / UBSAN_OPTIONS from the
# environment still override them option by option.
function(_granflow_executables dir out)
  get_property(targets DIRECTORY ${dir} PROPERTY BUILDSYSTEM_TARGETS)
  set(exes)
  foreach(t IN LISTS targets)
    get_target_property(type ${t} TYPE)
    if(type STREQUAL "EXECUTABLE")
      list(APPEND exes ${t})
    endif()
  endforeach()
  get_property(subdirs DIRECTORY ${dir} PROPERTY SUBDIRECTORIES)
  foreach(d IN LISTS subdirs)
    _granflow_executables(${d} sub)
    list(APPEND exes ${sub})
  endforeach()
  set(${out} ${exes} PARENT_SCOPE)
endfunction()

function(granflow_sanitizer_defaults)
  set(src ${PROJECT_SOURCE_DIR}/cmake/sanitizers/default_options.cpp)
  _granflow_executables(${PROJECT_SOURCE_DIR} exes)
  foreach(t IN LISTS exes)
    target_sources(${t} PRIVATE ${src})
  endforeach()
  message(STATUS "granflow: ASan+UBSan build of ${exes}")
endfunction()
