#pragma once
// Where the tests find the source tree (config/, test data) and the build tree (the built `ftid`
// and `ftidd`, scratch files). The two absolute paths are compiled into test_paths.cpp only
// (test/support/CMakeLists.txt): a test source that carried them would hash differently in every
// clone and miss the compiler cache (docs/testing.md, "Time").
//
//   loadDbc(ftid::test::sourcePath("/config/ftsensor.dbc"));
//   const std::string ftid = ftid::test::binaryPath("/apps/ftid/ftid");
#include <string>
#include <string_view>

namespace ftid::test {

/// The repository root (CMake's PROJECT_SOURCE_DIR), without a trailing slash.
std::string sourceDir();
/// The build directory (CMake's PROJECT_BINARY_DIR), without a trailing slash.
std::string binaryDir();
/// sourceDir() followed by `rest`, which starts with '/' to name a path below it.
std::string sourcePath(std::string_view rest);
/// binaryDir() followed by `rest`, which starts with '/' to name a path below it.
std::string binaryPath(std::string_view rest);

}  // namespace ftid::test
