# Writes OUT (build/main/provenance.json): what made this build, for every
# run's run.json (provenance). Run at every build (the afm_provenance
# target); the file is rewritten only when its text changes.
# -D: OUT, SRC, BUILD_TYPE, C_COMPILER, CXX_COMPILER, OPENCV, EIGEN, LCM, YAML_CPP, NLOHMANN_JSON
set(commit "unknown")
set(dirty "null")
find_program(GIT git)
if(GIT AND EXISTS "${SRC}/.git")
  execute_process(COMMAND "${GIT}" -C "${SRC}" rev-parse HEAD OUTPUT_VARIABLE c RESULT_VARIABLE rc
                  OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
  if(rc EQUAL 0)
    set(commit "${c}")
    execute_process(COMMAND "${GIT}" -C "${SRC}" status --porcelain --untracked-files=no OUTPUT_VARIABLE st
                    RESULT_VARIABLE rc2 ERROR_QUIET)
    if(rc2 EQUAL 0)
      if(st STREQUAL "")
        set(dirty "false")
      else()
        set(dirty "true")
      endif()
    endif()
  endif()
endif()
set(text "{\n  \"commit\": \"${commit}\",\n  \"dirty\": ${dirty},\n  \"build_type\": \"${BUILD_TYPE}\",\n  \"compilers\": {\"c\": \"${C_COMPILER}\", \"cxx\": \"${CXX_COMPILER}\"},\n  \"libraries\": {\"opencv\": \"${OPENCV}\", \"eigen\": \"${EIGEN}\", \"lcm\": \"${LCM}\", \"yaml_cpp\": \"${YAML_CPP}\", \"nlohmann_json\": \"${NLOHMANN_JSON}\"}\n}\n")
set(old "")
if(EXISTS "${OUT}")
  file(READ "${OUT}" old)
endif()
if(NOT old STREQUAL text)
  file(WRITE "${OUT}" "${text}")
endif()
