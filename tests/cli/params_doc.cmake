# docs/parameters.md is generated from the code (granflow --parameters); fail if it drifted.
execute_process(COMMAND ${EXE} --parameters OUTPUT_VARIABLE generated RESULT_VARIABLE code)
if(NOT code EQUAL 0)
  message(FATAL_ERROR "granflow --parameters exited with ${code}")
endif()
file(READ ${DOC} committed)
if(NOT generated STREQUAL committed)
  message(FATAL_ERROR "docs/parameters.md is out of date: regenerate with\n"
                      "  build/apps/granflow --parameters > docs/parameters.md")
endif()
