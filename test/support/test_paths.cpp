// The only test source compiled with the absolute paths of the source and build trees
// (FTID_SOURCE_DIR, FTID_BINARY_DIR: test/support/CMakeLists.txt). Plain character arrays, so
// they are constant-initialised and usable from other files' static initialisers.
#include "test_paths.hpp"

#ifndef FTID_SOURCE_DIR
#error "test_paths.cpp needs FTID_SOURCE_DIR (test/support/CMakeLists.txt)"
#endif
#ifndef FTID_BINARY_DIR
#error "test_paths.cpp needs FTID_BINARY_DIR (test/support/CMakeLists.txt)"
#endif

namespace ftid::test {

namespace {
constexpr char kSourceDir[] = FTID_SOURCE_DIR;
constexpr char kBinaryDir[] = FTID_BINARY_DIR;
}  // namespace

std::string sourceDir() { return kSourceDir; }

std::string binaryDir() { return kBinaryDir; }

std::string sourcePath(std::string_view rest) { return std::string(kSourceDir).append(rest); }

std::string binaryPath(std::string_view rest) { return std::string(kBinaryDir).append(rest); }

}  // namespace ftid::test
