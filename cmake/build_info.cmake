# Writes OUT (build_info.cpp) from IN with the git commit of SRC; run at every build by the
# granflow_build_info target (configure_file rewrites OUT only when its text changes, so an
# unchanged commit recompiles nothing). Outside a git checkout (a release tarball) the commit
# is "unknown" and the version is the project version alone.
set(GIT_COMMIT "unknown")
set(GIT_DIRTY "")
find_package(Git QUIET)
if(GIT_FOUND)
  execute_process(COMMAND ${GIT_EXECUTABLE} -C ${SRC} rev-parse HEAD
                  RESULT_VARIABLE rc OUTPUT_VARIABLE commit ERROR_QUIET
                  OUTPUT_STRIP_TRAILING_WHITESPACE)
  if(rc EQUAL 0 AND commit)
    set(GIT_COMMIT "${commit}")
    # Tracked files changed since the commit: the binary is not exactly that commit.
    execute_process(COMMAND ${GIT_EXECUTABLE} -C ${SRC} status --porcelain --untracked-files=no
                    RESULT_VARIABLE rc OUTPUT_VARIABLE changes ERROR_QUIET)
    if(rc EQUAL 0 AND NOT "${changes}" STREQUAL "")
      set(GIT_DIRTY "-dirty")
    endif()
  endif()
endif()
if(GIT_COMMIT STREQUAL "unknown")
  set(GRANFLOW_VERSION_STRING "${VERSION} (not a git checkout)")
else()
  string(SUBSTRING "${GIT_COMMIT}" 0 12 short)
  set(GRANFLOW_VERSION_STRING "${VERSION}+g${short}${GIT_DIRTY}")
endif()
set(GRANFLOW_GIT_COMMIT "${GIT_COMMIT}${GIT_DIRTY}")
configure_file(${IN} ${OUT} @ONLY)
