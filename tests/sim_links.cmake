# The simulator is the bench's truth: sim_afm links nothing from the card
# (firmware/, host/card/). LINKS names the file the configure step wrote
# (tests/CMakeLists.txt, afm_sim_link_graph): each target sim_afm links,
# directly or through another, with the folder of its sources. Fails
# naming each that lies under firmware/ or host/card/.
file(STRINGS "${LINKS}" rows)
if(NOT rows)
  message(FATAL_ERROR "sim_links: ${LINKS} names no target: the configure step did not walk sim_afm's links")
endif()
set(bad "")
foreach(row ${rows})
  string(REPLACE "\t" ";" parts "${row}")
  list(GET parts 0 target)
  list(GET parts 1 dir)
  file(RELATIVE_PATH rel "${SOURCE}" "${dir}")
  if(rel MATCHES "^firmware(/|$)" OR rel MATCHES "^host/card(/|$)" OR rel MATCHES "^board(/|$)")
    list(APPEND bad "${target} (${rel})")
  endif()
endforeach()
if(bad)
  string(REPLACE ";" ", " bad "${bad}")
  message(FATAL_ERROR "sim_links: sim_afm links the card's code: ${bad}")
endif()
list(LENGTH rows n)
message(STATUS "sim_links: sim_afm links ${n} targets, none from firmware/ or host/card/")
