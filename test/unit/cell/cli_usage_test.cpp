// Issue 14, "Messages name the real cause": a bad number for --script-port is a usage error
// (exit 2, naming the option), not "error: stoi" with exit 1.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <string>

namespace {

int runFtid(const std::string& args, std::string* output) {
  const std::string cmd = std::string(FTID_BINARY_DIR "/apps/ftid/ftid ") + args + " 2>&1";
  FILE* p = ::popen(cmd.c_str(), "r");
  if (p == nullptr) return -1;
  std::array<char, 4096> buf{};
  while (std::fgets(buf.data(), static_cast<int>(buf.size()), p) != nullptr) *output += buf.data();
  const int status = ::pclose(p);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

TEST(CellIdentifyCli, BadPortNumbersAreUsageErrors) {
  if (::access(FTID_BINARY_DIR "/apps/ftid/ftid", X_OK) != 0) GTEST_SKIP() << "ftid not built";
  for (const std::string bad : {"--script-port abc", "--script-port 70000", "--script-port 12x",
                                 "--register-offset 7"}) {
    std::string out;
    EXPECT_EQ(runFtid("--identify " + bad + " --config /nonexistent.yaml", &out), 2) << bad << "\n" << out;
    EXPECT_NE(out.find(bad.substr(0, bad.find(' '))), std::string::npos) << out;
    EXPECT_EQ(out.find("stoi"), std::string::npos) << out;
  }
}

}  // namespace
