// Issue 14, item 3, end to end through the `ftid` binary: outputs never replace a symlink or a
// device node, parameter files are never written with non-finite values (previous file and its
// .bak untouched), and FIFOs, directories and implausible values as input give exit 1 naming the
// file (and line), never a hang. Each command runs under `timeout` so a regression fails fast.
#include <gtest/gtest.h>

#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "ftid/logio/log.hpp"
#include "paper_cell.hpp"
#include "scratch.hpp"
#include "test_paths.hpp"

namespace {

using ftid::test::ScratchDir;
using ftid::test::slurp;
using ftid::test::spit;

struct CliRun {
  int code = -1;
  std::string out;
  std::string err;
};

CliRun ftidRun(const ScratchDir& d, const std::string& args) {
  const std::string err_file = d / "stderr.txt";
  const std::string cmd = "cd " + ftid::test::sourceDir() + " && timeout 60 " +
                          ftid::test::binaryPath("/apps/ftid/ftid ") + args + " 2>" + err_file;
  CliRun r;
  FILE* p = popen(cmd.c_str(), "r");
  if (p == nullptr) return r;
  std::array<char, 4096> buf{};
  std::size_t n = 0;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) r.out.append(buf.data(), n);
  const int status = pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.err = slurp(err_file);
  std::filesystem::remove(err_file);
  return r;
}

bool isSymlink(const std::string& p) {
  struct stat st {};
  return ::lstat(p.c_str(), &st) == 0 && S_ISLNK(st.st_mode);
}

/// A small simulated measurement log (rest poses, so identification is fast).
std::string writeRunLog(const ScratchDir& d, const std::string& name = "run.csv") {
  ftid::sim::CellSimConfig cfg = ftid::test::paperConfig(true, 3);
  ftid::test::useRestPoses(cfg, 12, 5);
  const std::string path = d / name;
  ftid::logio::writeLog(path, ftid::sim::CellSim(cfg).run());
  return path;
}

/// The same log with column `col` replaced by `value` on every row (or only on data row `only_row`).
std::string withColumn(const std::string& log_text, const std::string& col, const std::string& value,
                       int only_row = -1) {
  std::istringstream in(log_text);
  std::string line, out;
  std::getline(in, line);
  out = line + "\n";
  std::size_t k = 0;
  {
    std::istringstream h(line);
    std::string name;
    while (std::getline(h, name, ',') && name != col) ++k;
  }
  int row = 0;
  while (std::getline(in, line)) {
    std::vector<std::string> f;
    std::istringstream r(line);
    std::string x;
    while (std::getline(r, x, ',')) f.push_back(x);
    if (only_row < 0 || row == only_row) f[k] = value;
    for (std::size_t i = 0; i < f.size(); ++i) out += (i ? "," : "") + f[i];
    out += "\n";
    ++row;
  }
  return out;
}

// tz = -1e300 on every row used to write a parameter file of `null`s, exit 0 and move the valid
// file to .bak.
TEST(FilesCli, ImplausibleLogNeverTouchesTheParameterFile) {
  ScratchDir d("files_cli");
  const std::string log = writeRunLog(d);
  const std::string params = d / "parameters.yaml";
  const CliRun ok = ftidRun(d, "identify --log " + log + " --method static --out " + params);
  ASSERT_EQ(ok.code, 0) << ok.err;
  const std::string before = slurp(params);
  ASSERT_FALSE(std::filesystem::exists(params + ".bak"));

  const std::string bad = d / "tz.csv";
  spit(bad, withColumn(slurp(log), "tz", "-1e300"));
  const CliRun r = ftidRun(d, "identify --log " + bad + " --method static --out " + params);
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find(bad + ":2:"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("column 'tz'"), std::string::npos) << r.err;
  EXPECT_EQ(slurp(params), before);
  EXPECT_FALSE(std::filesystem::exists(params + ".bak"));

  // q5 = 1e308 (exit 0 and a tilt of 80 degrees before) and a single fz = 1e308 cell ("rank 0").
  spit(bad, withColumn(slurp(log), "q5", "1e308"));
  const CliRun q = ftidRun(d, "identify --log " + bad + " --out " + params);
  EXPECT_EQ(q.code, 1) << q.err;
  EXPECT_NE(q.err.find("column 'q5'"), std::string::npos) << q.err;
  spit(bad, withColumn(slurp(log), "fz", "1e308", 17));
  const CliRun f = ftidRun(d, "identify --log " + bad + " --out " + params);
  EXPECT_EQ(f.code, 1) << f.err;
  EXPECT_NE(f.err.find(bad + ":19:"), std::string::npos) << f.err;
  EXPECT_NE(f.err.find("column 'fz'"), std::string::npos) << f.err;
  EXPECT_EQ(f.err.find("rank"), std::string::npos) << f.err;
  EXPECT_EQ(slurp(params), before);
  EXPECT_FALSE(std::filesystem::exists(params + ".bak"));
}

// `compensate --out d/null` (a device node) left a regular file in its place; `simulate --out
// LINK`, `identify --out` and `analyze --report` replaced symlinks.
TEST(FilesCli, OutputsRefuseDeviceNodesAndSymlinks) {
  ScratchDir d("files_cli");
  const std::string log = writeRunLog(d);
  const std::string params = d / "p.yaml";
  ASSERT_EQ(ftidRun(d, "identify --log " + log + " --method static --out " + params).code, 0);

  std::string dev = "/dev/null";
  if (::geteuid() == 0 && ::mknod((d / "null").c_str(), S_IFCHR | 0666, makedev(1, 3)) == 0) dev = d / "null";
  const CliRun c = ftidRun(d, "compensate --log " + log + " --params " + params + " --out " + dev);
  EXPECT_EQ(c.code, 1) << c.err;
  EXPECT_NE(c.err.find(dev + ": refusing to replace a character device"), std::string::npos) << c.err;
  struct stat st {};
  ASSERT_EQ(::lstat(dev.c_str(), &st), 0);
  EXPECT_TRUE(S_ISCHR(st.st_mode));

  spit(d / "victim.txt", "victim\n");
  ASSERT_EQ(::symlink("victim.txt", (d / "link").c_str()), 0);
  const std::string link = d / "link";
  for (const std::string& args :
       {"simulate --duration 1 --out " + link, "identify --log " + log + " --method static --out " + link,
        "compensate --log " + log + " --params " + params + " --out " + link,
        "analyze " + log + " --model paper --folds 2 --report " + link}) {
    const CliRun r = ftidRun(d, args);
    EXPECT_EQ(r.code, 1) << args << "\n" << r.err;
    EXPECT_NE(r.err.find(link + ": refusing to replace a symbolic link"), std::string::npos) << args << "\n" << r.err;
    EXPECT_TRUE(isSymlink(link)) << args;
    EXPECT_EQ(slurp(d / "victim.txt"), "victim\n") << args;
  }
  std::vector<std::string> left = d.entries();
  left.erase(std::remove(left.begin(), left.end(), "null"), left.end());
  // p.yaml and its exports (identify --out writes them beside it) were made by the set-up.
  EXPECT_EQ(left, (std::vector<std::string>{"link", "p.yaml", "p.yaml.ros2.yaml", "p.yaml.urscript", "run.csv",
                                            "victim.txt"}))
      << "no temporary files left";
}

// A FIFO given as a log or parameter file hung; a directory gave "empty log" or no file name.
TEST(FilesCli, FifoAndDirectoryInputsAreNamedAndNeverHang) {
  ScratchDir d("files_cli");
  const std::string log = writeRunLog(d);
  const std::string params = d / "p.yaml";
  ASSERT_EQ(ftidRun(d, "identify --log " + log + " --method static --out " + params).code, 0);
  const std::string fifo = d / "fifo";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const CliRun a = ftidRun(d, "identify --log " + fifo);
  EXPECT_EQ(a.code, 1) << a.err;
  EXPECT_NE(a.err.find(fifo + ": cannot read the log file: it is a FIFO"), std::string::npos) << a.err;
  const CliRun b = ftidRun(d, "compensate --log " + log + " --params " + fifo + " --out " + (d / "c.csv"));
  EXPECT_EQ(b.code, 1) << b.err;
  EXPECT_NE(b.err.find(fifo + ": cannot read the parameter file: it is a FIFO"), std::string::npos) << b.err;
  const CliRun c = ftidRun(d, "identify --log " + d.path());
  EXPECT_EQ(c.code, 1) << c.err;
  EXPECT_NE(c.err.find(d.path() + ": cannot read the log file: it is a directory"), std::string::npos) << c.err;
}

}  // namespace
