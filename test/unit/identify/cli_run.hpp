#pragma once
// Test helper: runs the built `ftid` binary (binaryPath("/apps/ftid/ftid")) from the source tree
// and captures its exit code, stdout and stderr (the identify CLI tests).
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

#include "test_paths.hpp"

namespace ftid::test {

struct CliRun {
  int code = -1;
  std::string out;
  std::string err;
};

// CTest runs each test of this file as its own process, in parallel: every file a test writes
// (including the captured stderr) carries the test's name so two tests never share one.
inline std::string dir() {
  return ftid::test::binaryPath("/identify_cli_test_") +
         ::testing::UnitTest::GetInstance()->current_test_info()->name() + "_";
}

inline CliRun ftidRun(const std::string& args) {
  const std::string err_file = dir() + "stderr.txt";
  const std::string cmd = "cd " + ftid::test::sourceDir() + " && " +
                          ftid::test::binaryPath("/apps/ftid/ftid ") + args + " 2>" + err_file;
  CliRun r;
  FILE* p = popen(cmd.c_str(), "r");
  if (p == nullptr) return r;
  std::array<char, 4096> buf{};
  std::size_t n = 0;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) r.out.append(buf.data(), n);
  const int status = pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream e(err_file);
  std::stringstream ss;
  ss << e.rdbuf();
  r.err = ss.str();
  return r;
}

inline double jsonValue(const std::string& json, const std::string& key) {
  const std::string pat = "\"" + key + "\":{\"value\":";
  const auto at = json.find(pat);
  if (at == std::string::npos) return std::nan("");
  return std::stod(json.substr(at + pat.size()));
}

inline bool fileExists(const std::string& path) { return std::ifstream(path).good(); }

}  // namespace ftid::test
