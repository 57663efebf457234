# ftid_target_defaults(<target>): warnings (as errors with FTID_WERROR), sanitizers, C++17.
# Applied to every target built from ftid's own sources; third-party headers are SYSTEM includes.
function(ftid_target_defaults target)
  target_compile_features(${target} PRIVATE cxx_std_17)
  target_compile_options(${target} PRIVATE
    -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wold-style-cast -Wcast-align
    -Woverloaded-virtual -Wnull-dereference -Wdouble-promotion -Wformat=2 -Wimplicit-fallthrough)
  if(FTID_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
  if(FTID_SANITIZE)
    target_compile_options(${target} PRIVATE -fsanitize=address,undefined -fno-omit-frame-pointer
                                              -fno-sanitize-recover=undefined)
    target_link_options(${target} PRIVATE -fsanitize=address,undefined)
  endif()
endfunction()

# ftid_add_library(<name> SOURCES ... PUBLIC_DEPS ... PRIVATE_DEPS ...)
# Creates ftid_<name> with alias ftid::<name>; include/ is its public include directory.
function(ftid_add_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  add_library(ftid_${name} STATIC ${ARG_SOURCES})
  add_library(ftid::${name} ALIAS ftid_${name})
  set_property(GLOBAL APPEND PROPERTY FTID_MODULE_TARGETS ftid_${name})
  set_target_properties(ftid_${name} PROPERTIES POSITION_INDEPENDENT_CODE ON)
  target_include_directories(ftid_${name} PUBLIC
    $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/include> $<INSTALL_INTERFACE:include>)
  target_link_libraries(ftid_${name} PUBLIC ${ARG_PUBLIC_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
  ftid_target_defaults(ftid_${name})
endfunction()

# ftid_add_test(<name> SOURCES ... DEPS ... [LABELS ...])
# One GoogleTest executable per module; tests are discovered individually by CTest.
function(ftid_add_test name)
  cmake_parse_arguments(ARG "" "TIMEOUT" "SOURCES;DEPS;LABELS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} GTest::gtest GTest::gmock GTest::gtest_main)
  target_compile_definitions(${name} PRIVATE
    FTID_SOURCE_DIR="${PROJECT_SOURCE_DIR}" FTID_BINARY_DIR="${PROJECT_BINARY_DIR}")
  ftid_target_defaults(${name})
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 300)
  endif()
  if(NOT "integration" IN_LIST ARG_LABELS)
    set_property(GLOBAL APPEND PROPERTY FTID_UNIT_TEST_TARGETS ${name})
  endif()
  gtest_discover_tests(${name} DISCOVERY_TIMEOUT 60
    PROPERTIES TIMEOUT ${ARG_TIMEOUT} LABELS "${ARG_LABELS}")
endfunction()
