# Third-party dependencies of the bus, simulator and host processes.
# All come from Debian packages or the project's venv (tools/setup.sh); none is vendored.
set(AFM_VENV "${CMAKE_SOURCE_DIR}/.venv" CACHE PATH "The project's Python venv (tools/setup.sh)")
file(GLOB _afm_site "${AFM_VENV}/lib/python3*/site-packages")
if(NOT _afm_site)
  message(FATAL_ERROR "No venv at ${AFM_VENV}: run tools/setup.sh (./afm setup)")
endif()
list(GET _afm_site 0 AFM_SITE_PACKAGES)
set(AFM_PYTHON "${AFM_VENV}/bin/python" CACHE FILEPATH "venv python")

# LCM 1.5 from PyPI: its CMake config needs GLib2::glib defined first.
find_package(PkgConfig REQUIRED)
pkg_check_modules(GLIB2 REQUIRED IMPORTED_TARGET glib-2.0)
if(NOT TARGET GLib2::glib)
  add_library(GLib2::glib ALIAS PkgConfig::GLIB2)
endif()
find_package(lcm 1.5 REQUIRED CONFIG PATHS "${AFM_SITE_PACKAGES}/lib/lcm/cmake" NO_DEFAULT_PATH)
include(${LCM_USE_FILE})
set(AFM_LCM_JAR "${AFM_SITE_PACKAGES}/share/java/lcm.jar")
set(AFM_LCM_BIN "${AFM_SITE_PACKAGES}/bin")

find_package(Eigen3 3.3 REQUIRED NO_MODULE)
find_package(OpenCV REQUIRED COMPONENTS core imgproc imgcodecs videoio)
# PNG files read and the page's JPEGs written without OpenCV's imgcodecs
# (host/image/png_read.hpp, host/renderer/jpeg_file.hpp)
find_package(PNG REQUIRED)
find_package(JPEG REQUIRED)
find_package(yaml-cpp REQUIRED)
find_package(Threads REQUIRED)
find_package(Java 11 REQUIRED COMPONENTS Development)
include(UseJava)

set(AFM_CXX_WARNINGS -Wall -Wextra -Werror)
