# Fails if any firmware source or header names a floating-point type, uses
# the heap, or stdio (the firmware's rules: fixed point, no heap, no OS).
# cmake -DFW_DIR=firmware -P check_no_float.cmake
file(GLOB_RECURSE files "${FW_DIR}/*.c" "${FW_DIR}/*.h")
set(bad "")
foreach(f ${files})
  file(STRINGS "${f}" hits REGEX "(^|[^A-Za-z_])(float|double|long double|_Complex)([^A-Za-z_]|$)|(^|[^A-Za-z_])(malloc|calloc|realloc|free|printf|fprintf|puts)[ ]*\\(|#[ ]*include[ ]*<stdio\\.h>|#[ ]*include[ ]*<stdlib\\.h>")
  if(hits)
    list(APPEND bad "${f}: ${hits}")
  endif()
endforeach()
if(bad)
  message(FATAL_ERROR "floating point, heap or stdio in firmware/:\n${bad}")
endif()
list(LENGTH files n)
message(STATUS "no float/double, heap or stdio in ${n} firmware files")
