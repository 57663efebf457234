// The command lines of both executables (CLI11, apps/common/cli_args.hpp): a bad number is a usage
// error (exit 2) whose first line names the option, never "error: stoi" with exit 1 (issue 14);
// unknown options are usage errors; every sub-command's --help exits 0 with its own text.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cctype>
#include <fstream>
#include <cstdio>
#include <string>
#include <vector>

#include "test_paths.hpp"

namespace {

const std::string kFtid = ftid::test::binaryPath("/apps/ftid/ftid");
const std::string kFtidd = ftid::test::binaryPath("/apps/ftidd/ftidd");

int run(const std::string& exe, const std::string& args, std::string* output) {
  const std::string cmd = "timeout 30 " + exe + " " + args + " 2>&1 </dev/null";
  FILE* p = ::popen(cmd.c_str(), "r");
  if (p == nullptr) return -1;
  std::array<char, 4096> buf{};
  while (std::fgets(buf.data(), static_cast<int>(buf.size()), p) != nullptr) *output += buf.data();
  const int status = ::pclose(p);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string firstLine(const std::string& s) { return s.substr(0, s.find('\n')); }

bool built() { return ::access(kFtid.c_str(), X_OK) == 0 && ::access(kFtidd.c_str(), X_OK) == 0; }

TEST(CellIdentifyCli, BadPortNumbersAreUsageErrors) {
  if (!built()) GTEST_SKIP() << "ftid not built";
  for (const std::string bad : {"--script-port abc", "--script-port 70000", "--script-port 12x",
                                 "--script-port=", "--register-offset 7", "--register-offset 0x18"}) {
    std::string out;
    EXPECT_EQ(run(kFtid, "--identify " + bad + " --config /nonexistent.yaml", &out), 2) << bad << "\n" << out;
    // The error line itself (the usage text printed after it lists every option) names the option.
    EXPECT_NE(firstLine(out).find(bad.substr(0, bad.find_first_of(" ="))), std::string::npos) << out;
    EXPECT_EQ(out.find("stoi"), std::string::npos) << out;
  }
}

// One bad value per number parser that the commands had by hand before CLI11: trailing
// characters, out of range, not finite, octal-looking or negative where unsigned.
TEST(FtidCli, BadNumbersNameTheOptionAndExit2) {
  if (!built()) GTEST_SKIP() << "ftid not built";
  // Each command also gets arguments that would make it fail with exit 1 (a missing file) if the
  // number were accepted, so exit 2 can only come from the number.
  const std::string sim = "simulate --out /nonexistent/dir/run.csv --robot /nonexistent.urdf ";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {sim + "--rate 125Hz", "--rate"},
      {sim + "--rate -5", "--rate"},
      {sim + "--duration nan", "--duration"},
      {sim + "--duration 1e400", "--duration"},
      {sim + "--seed -1", "--seed"},
      {sim + "--seed 1.5", "--seed"},
      {sim + "--noise-oversample 0", "--noise-oversample"},
      {sim + "--static-poses 2x", "--static-poses"},
      {sim + "--com 1,2", "--com"},
      {sim + "--com 1,2,x", "--com"},
      {sim + "--mass 1kg", "--mass"},
      {sim + "--effect sensor_delay:tau=0.01s", "--effect sensor_delay tau"},
      {sim + "--effect cable:k=5,anchor=1/2", "--effect cable anchor"},
      {"identify --log /nonexistent.csv --max-delay 0", "--max-delay"},
      {"identify --log /nonexistent.csv --max-delay 2s", "--max-delay"},
      {"identify --log /nonexistent.csv --method fast", "--method"},
      {"identify --log /nonexistent.csv --wrench-frame tool", "--wrench-frame"},
      {"identify --log /nonexistent.csv --qdd-source measured", "--qdd-source"},
      {"identify --log /nonexistent.csv --ur-payload 1,2", "--ur-payload"},
      {"analyze /nonexistent.csv --wrench-time-offset 1s", "--wrench-time-offset"},
      {"convert /nonexistent.csv out.csv --ur-payload 1,x,0,0", "--ur-payload"},
      {"analyze /nonexistent.csv --folds 1", "--folds"},
      {"analyze /nonexistent.csv --folds 5.0", "--folds"},
      {"analyze /nonexistent.csv --alpha 1", "--alpha"},
      {"analyze /nonexistent.csv --glitch-sigma -1", "--glitch-sigma"},
      {"design --robot /nonexistent.urdf --harmonics 1", "--harmonics"},
      {"design --robot /nonexistent.urdf --duration 0", "--duration"},
      {"design --robot /nonexistent.urdf --q0 0,0,0,0,0", "--q0"},
      {"design --robot /nonexistent.urdf --joints 4,7", "--joints"},
      {"design --robot /nonexistent.urdf --seed 12abc", "--seed"},
      {"check-trajectory /nonexistent.yaml --dt 0", "--dt"},
      {"decode-candump /nonexistent.log --stale-ms 20ms", "--stale-ms"},
      {"sim-robot --rtde-port 99999", "--rtde-port"},
      {"sim-robot --q0 0,0,0,0,0,0,0", "--q0"},
      {"sim-robot --fault-after 1x:protective_stop", "--fault-after"},
      {"sim-sensor --config /nonexistent.yaml --rtde-port 0", "--rtde-port"},
      {"sim-sensor --config /nonexistent.yaml --fault 1:silent:0", "--fault"},
      {"run-trajectory /nonexistent.yaml --out /nonexistent/x.csv --approach-speed 2", "--approach-speed"},
      {"run-trajectory /nonexistent.yaml --out /nonexistent/x.csv --gain 3e", "--gain"},
      {"demo --offline --robot /nonexistent.urdf --seed x1", "--seed"},
  };
  for (const auto& [args, option] : cases) {
    std::string out;
    EXPECT_EQ(run(kFtid, args, &out), 2) << args << "\n" << out;
    EXPECT_NE(firstLine(out).find(option), std::string::npos) << args << "\n" << out;
  }
}

TEST(FtidCli, UnknownOptionsAndStrayArgumentsAreUsageErrors) {
  if (!built()) GTEST_SKIP() << "ftid not built";
  for (const std::string args : {"identify --log /nonexistent.csv --bogus", "analyze a.csv b.csv",
                                 "simulate --out /nonexistent/x.csv --nosie-force 1", "export --params p --ros",
                                 "demo --offline --workdir /tmp/x", "demo --full-physics"}) {
    std::string out;
    EXPECT_EQ(run(kFtid, args, &out), 2) << args << "\n" << out;
  }
  std::string out;
  EXPECT_EQ(run(kFtid, "no-such-command", &out), 2) << out;
  EXPECT_NE(out.find("unknown command 'no-such-command'"), std::string::npos) << out;
}

TEST(FtidCli, EverySubCommandsHelpExitsZeroWithItsUsage) {
  if (!built()) GTEST_SKIP() << "ftid not built";
  std::string overview;
  ASSERT_EQ(run(kFtid, "--help", &overview), 0) << overview;
  // The command names are the first word of each line of the overview's command list.
  std::vector<std::string> names;
  const auto list = overview.find("commands:\n");
  ASSERT_NE(list, std::string::npos) << overview;
  std::size_t at = list + 10;
  while (at < overview.size() && overview.compare(at, 2, "  ") == 0) {
    const std::size_t start = at + 2;
    const std::size_t end = overview.find(' ', start);
    names.push_back(overview.substr(start, end - start));
    at = overview.find('\n', at) + 1;
  }
  ASSERT_GE(names.size(), 14u) << overview;
  for (const auto& name : names) {
    for (const char* flag : {"--help", "-h"}) {
      std::string out;
      EXPECT_EQ(run(kFtid, name + " " + flag, &out), 0) << name << "\n" << out;
      EXPECT_EQ(out.rfind("usage: ftid ", 0), 0u) << name << "\n" << out;
      // Every help text says what its exit codes mean ("Exit status: 0 ..., 1 ..., 2 ...").
      std::string lower = out;
      for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
      EXPECT_NE(lower.find("exit"), std::string::npos) << name << " --help lists no exit codes\n" << out;
    }
  }
  std::string out;
  EXPECT_EQ(run(kFtid, "--identify --help", &out), 0) << out;
  EXPECT_EQ(out.rfind("usage: ftid --identify", 0), 0u) << out;
}

// The exit codes the --help texts of the simulators and converters promise, one per path that can
// be reached without a robot or a recording: 2 usage, 1 a bad file / value / port, 0 a clean stop.
TEST(FtidCli, SimulatorAndConverterExitCodes) {
  if (!built()) GTEST_SKIP() << "ftid not built";
  const std::string dir = ::testing::TempDir();
  const std::string tag = std::to_string(::getpid());
  const std::string bad_candump = dir + "/bad_" + tag + ".candump";
  const std::string empty_candump = dir + "/empty_" + tag + ".candump";
  std::ofstream(bad_candump) << "(1700000000.000000) can0 123#00\nnot a candump line\n";
  std::ofstream{empty_candump};
  const std::string csv = dir + "/out_" + tag + ".csv";
  const std::string ports = " --rtde-port 0 --dashboard-port 0 --script-port 0";
  const std::vector<std::pair<std::string, int>> cases = {
      {"lcm-to-csv --out " + csv, 2},                                  // no log
      {"lcm-to-csv /nonexistent.lcm", 2},                              // no --out
      {"lcm-to-csv a.lcm b.lcm --out " + csv, 2},                      // two logs
      {"lcm-to-csv /nonexistent.lcm --out " + csv, 1},                 // unreadable log
      {"decode-candump", 2},                                           // no log
      {"decode-candump " + empty_candump + " --bogus", 2},             // unknown option
      {"decode-candump /nonexistent.candump", 1},                      // unreadable log
      {"decode-candump " + bad_candump, 1},                            // malformed line
      {"decode-candump " + empty_candump + " --dbc /nonexistent.dbc", 1},
      {"decode-candump " + empty_candump + " --output /nonexistent/dir/x.csv", 1},
      {"decode-candump " + empty_candump, 0},                          // nothing to decode is no error
      {"sim-robot --model ur5" + ports, 1},                            // unknown model
      {"sim-robot --fault-after 1:meteor" + ports, 1},                 // unknown fault kind
      {"sim-robot --host localhost" + ports, 1},                       // not an IPv4 address
      {"sim-robot --bogus", 2},
      {"sim-sensor --config /nonexistent.yaml --socket " + dir + "/s_" + tag, 1},
      {"sim-sensor --effect meteor --socket " + dir + "/s_" + tag, 1},
      {"sim-sensor --fault 1:meteor --socket " + dir + "/s_" + tag, 1},
      {"sim-sensor --bogus", 2},
  };
  for (const auto& [args, code] : cases) {
    std::string out;
    EXPECT_EQ(run(kFtid, args, &out), code) << args << "\n" << out;
  }
  // A clean stop: SIGTERM after 2 s (timeout --preserve-status returns the command's own status;
  // a signal that arrived before the command blocked it would give 143, not 0).
  for (const std::string& args : std::vector<std::string>{"sim-robot" + ports,
                                 "sim-sensor --robot-host 127.0.0.1 --rtde-port 9 --socket " + dir + "/s_" + tag}) {
    std::string out;
    EXPECT_EQ(run("timeout --preserve-status -s TERM 2 " + kFtid, args, &out), 0) << args << "\n" << out;
    EXPECT_NE(out.find("stopped"), std::string::npos) << args << "\n" << out;
  }
  std::remove(bad_candump.c_str());
  std::remove(empty_candump.c_str());
  std::remove(csv.c_str());
}

TEST(FtiddCli, BadNumbersUnknownOptionsAndHelp) {
  if (!built()) GTEST_SKIP() << "ftidd not built";
  for (const std::string bad : {"--connect-timeout abc", "--connect-timeout -1", "--connect-timeout 5s",
                                 "--connect-timeout inf", "--connect-timeout"}) {
    std::string out;
    EXPECT_EQ(run(kFtidd, "--config /nonexistent.yaml " + bad, &out), 2) << bad << "\n" << out;
    EXPECT_NE(firstLine(out).find("--connect-timeout"), std::string::npos) << out;
  }
  std::string out;
  EXPECT_EQ(run(kFtidd, "--config /nonexistent.yaml --bogus", &out), 2) << out;
  EXPECT_NE(out.find("--bogus"), std::string::npos) << out;
  out.clear();
  EXPECT_EQ(run(kFtidd, "--help", &out), 0) << out;
  EXPECT_EQ(out.rfind("usage: ftidd ", 0), 0u) << out;
  out.clear();
  EXPECT_EQ(run(kFtidd, "--version", &out), 0) << out;
  EXPECT_EQ(out.rfind("ftidd ", 0), 0u) << out;
}

}  // namespace
