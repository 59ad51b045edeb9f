# Writes the build-info header at every build, so that the commit recorded in output folders is the one
# the binary was built from (a commit taken once at configure time goes stale with the next `git
# commit` and an incremental build). "-dirty" marks a build from a tree with uncommitted changes to
# tracked files. configure_file leaves the header untouched when nothing changed, so an unchanged
# commit recompiles nothing.
# Inputs: SOURCE_DIR, TEMPLATE, OUTPUT, PROJECT_VERSION, CMAKE_BUILD_TYPE.
execute_process(COMMAND git rev-parse --short=7 HEAD WORKING_DIRECTORY ${SOURCE_DIR}
                OUTPUT_VARIABLE LRF_GIT_COMMIT OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET
                RESULT_VARIABLE rev_parse_failed)
if(rev_parse_failed OR NOT LRF_GIT_COMMIT)
  set(LRF_GIT_COMMIT "unknown")
else()
  execute_process(COMMAND git diff --quiet HEAD -- WORKING_DIRECTORY ${SOURCE_DIR}
                  RESULT_VARIABLE tree_differs OUTPUT_QUIET ERROR_QUIET)
  if(tree_differs)
    string(APPEND LRF_GIT_COMMIT "-dirty")
  endif()
endif()
configure_file(${TEMPLATE} ${OUTPUT} @ONLY)
