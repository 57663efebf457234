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
  # The source and build trees' paths come from ftid_test_paths (test/support/test_paths.hpp),
  # not from compile definitions: an absolute path in a test's command would make every clone
  # recompile it despite the compiler cache (docs/testing.md, "Time").
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} ftid_test_paths GTest::gtest GTest::gmock
                        GTest::gtest_main)
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

# The sanitizer build's one exception, -fno-sanitize=vptr for the translation units that use LCM's
# member-function subscription (LCM::subscribe(channel, &Class::method, object)). GCC 12 emits
# the vptr check of LCM's handler call `(subs->handler->*subs->handlerMethod)(...)`
# (lcm-cpp-impl.hpp, cb_func) on an uninitialised register, so UBSan reports "invalid vptr" (or
# the check itself crashes) in a correct program: test/unit/transport/gcc_vptr_pmf_repro.cpp
# reproduces it without LCM, and clang's -fsanitize=undefined (vptr included) is clean on the same
# code (docs/testing.md "Sanitizers"). These files keep AddressSanitizer and every other UBSan
# check. Each entry is TARGET:SOURCE (relative to the repository root); a new file that subscribes
# with a member function goes here, or subscribes with subscribeFunction (src/transport/lcm_outbox.cpp).
set(FTID_GCC_VPTR_PMF_SOURCES
  ftid_daemon_client:src/daemon/client.cpp
  ftid_cell:src/cell/cycle_recorder.cpp
  ftid_cell:src/cell/demo.cpp
  ftid_cell:src/cell/demo_payload.cpp
  daemon_test:test/unit/daemon/client_test.cpp)
function(ftid_apply_sanitizer_exceptions)
  if(NOT FTID_SANITIZE OR NOT CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
    return()
  endif()
  foreach(entry IN LISTS FTID_GCC_VPTR_PMF_SOURCES)
    string(REPLACE ":" ";" parts "${entry}")
    list(GET parts 0 target)
    list(GET parts 1 file)
    if(NOT EXISTS ${PROJECT_SOURCE_DIR}/${file})
      message(FATAL_ERROR "FTID_GCC_VPTR_PMF_SOURCES (cmake/FtidDefaults.cmake): ${file} does not exist")
    endif()
    if(TARGET ${target})
      set_source_files_properties(${PROJECT_SOURCE_DIR}/${file} TARGET_DIRECTORY ${target}
                                  PROPERTIES COMPILE_OPTIONS -fno-sanitize=vptr)
    endif()
  endforeach()
endfunction()

