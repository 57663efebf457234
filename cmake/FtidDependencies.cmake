# All dependencies come from Debian 12 packages (see scripts/setup.sh for the list).
find_package(Threads REQUIRED)
find_package(Eigen3 3.4 REQUIRED NO_MODULE)
find_package(orocos_kdl REQUIRED)
if(NOT TARGET ftid_kdl)
  add_library(ftid_kdl INTERFACE)
  target_include_directories(ftid_kdl SYSTEM INTERFACE ${orocos_kdl_INCLUDE_DIRS})
  target_link_libraries(ftid_kdl INTERFACE ${orocos_kdl_LIBRARIES} Eigen3::Eigen)
  add_library(ftid::kdl ALIAS ftid_kdl)
endif()
find_package(urdfdom REQUIRED)
if(NOT TARGET ftid_urdfdom)
  add_library(ftid_urdfdom INTERFACE)
  target_include_directories(ftid_urdfdom SYSTEM INTERFACE ${urdfdom_INCLUDE_DIRS})
  target_link_libraries(ftid_urdfdom INTERFACE ${urdfdom_LIBRARIES})
  add_library(ftid::urdfdom ALIAS ftid_urdfdom)
endif()
# Debian ships two NLoptConfig.cmake files (C and C++); pin the C++ one.
find_package(NLopt REQUIRED CONFIG NO_DEFAULT_PATH
  PATHS /usr/lib/${CMAKE_LIBRARY_ARCHITECTURE}/cmake/nlopt_cxx /usr/lib/cmake/nlopt_cxx)
if(NOT TARGET NLopt::nlopt_cxx)
  message(FATAL_ERROR "NLopt C++ target NLopt::nlopt_cxx not found: install libnlopt-cxx-dev")
endif()
find_package(yaml-cpp REQUIRED)
# rosbag2 storage (src/logio/rosbag2.cpp): libsqlite3-dev.
find_package(SQLite3 REQUIRED)
# Header-only: nlohmann-json3-dev (JSON output), libcli11-dev (apps/ argument parsing).
find_package(nlohmann_json 3.11 REQUIRED)
find_package(CLI11 2.1 REQUIRED)
find_package(PkgConfig REQUIRED)
pkg_check_modules(SYSTEMD IMPORTED_TARGET libsystemd)

# LCM 1.3.1 (Debian) ships no CMake config: find the header, library and lcm-gen by hand.
find_program(LCM_GEN lcm-gen REQUIRED)
find_path(LCM_INCLUDE_DIR lcm/lcm-cpp.hpp REQUIRED)
find_library(LCM_LIBRARY lcm REQUIRED)
if(NOT TARGET lcm::lcm)
  add_library(lcm::lcm UNKNOWN IMPORTED)
  set_target_properties(lcm::lcm PROPERTIES IMPORTED_LOCATION "${LCM_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${LCM_INCLUDE_DIR}")
endif()

if(FTID_BUILD_TESTS)
  find_package(GTest REQUIRED)
  include(GoogleTest)
endif()
