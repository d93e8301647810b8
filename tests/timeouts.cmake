# The tests' tiers and time limits for ctest, from tests/timeouts.json (the
# one list of limits: a test's is tests.NAME there, else its tier's).
#   afm_test_tier(TEST TIER [LABEL...])
#     TIER is unit or e2e (the fast tier is the unit label: tests/run.sh
#     --fast); further labels follow (slow: the longest e2e files). Sets the
#     test's LABELS and TIMEOUT, and AFM_TEST_BUDGET_S (the limit less
#     margin_s: when the test's own waits must have ended) in its
#     environment. Called in the folder that added the test. In a cross
#     build a unit test's limit is tier unit_qemu's (the emulated board is
#     slower than the host).
set(AFM_TIMEOUTS_FILE "${CMAKE_CURRENT_LIST_DIR}/timeouts.json")
set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS "${AFM_TIMEOUTS_FILE}")
file(READ "${AFM_TIMEOUTS_FILE}" AFM_TIMEOUTS_JSON)

# The whole number at KEY... of the file, or a configure error naming the key.
function(afm_timeouts_get out)
  string(JSON v ERROR_VARIABLE err GET "${AFM_TIMEOUTS_JSON}" ${ARGN})
  string(REPLACE ";" "." key "${ARGN}")
  if(err)
    message(FATAL_ERROR "${AFM_TIMEOUTS_FILE}: ${key}: missing")
  endif()
  if(NOT v MATCHES "^[1-9][0-9]*$")
    message(FATAL_ERROR "${AFM_TIMEOUTS_FILE}: ${key}: a whole number of seconds > 0, got '${v}'")
  endif()
  set(${out} ${v} PARENT_SCOPE)
endfunction()

function(afm_test_tier test tier)
  if(NOT tier MATCHES "^(unit|e2e)$")
    message(FATAL_ERROR "afm_test_tier(${test}): tier '${tier}' is not unit or e2e")
  endif()
  string(JSON own ERROR_VARIABLE none GET "${AFM_TIMEOUTS_JSON}" tests ${test})
  if(none)
    set(key ${tier})
    if(CMAKE_CROSSCOMPILING AND tier STREQUAL "unit")
      set(key unit_qemu)
    endif()
    afm_timeouts_get(limit tiers ${key})
  else()
    afm_timeouts_get(limit tests ${test})
  endif()
  afm_timeouts_get(margin margin_s)
  math(EXPR budget "${limit} - ${margin}")
  if(budget LESS 1)
    message(FATAL_ERROR "${AFM_TIMEOUTS_FILE}: the limit of ${test} (${limit} s) leaves nothing past margin_s (${margin} s)")
  endif()
  set(labels ${tier} ${ARGN})
  set_tests_properties(${test} PROPERTIES LABELS "${labels}" TIMEOUT ${limit})
  set_property(TEST ${test} APPEND PROPERTY ENVIRONMENT "AFM_TEST_BUDGET_S=${budget}")
endfunction()
