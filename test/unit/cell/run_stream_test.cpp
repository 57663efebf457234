// Issue 14, "Data": `ftid --identify` streams the run to disk as it records. A SIGKILL keeps every
// row appended before it, and a failing disk keeps a valid file with the rows written so far.
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <string>

#include "ftid/cell/run_stream.hpp"
#include "ftid/common/error.hpp"
#include "ftid/logio/log.hpp"

namespace {

using ftid::CycleRecord;

CycleRecord rec(int k) {
  CycleRecord r;
  r.cycle = 100 + k;
  r.robot.robot_time = 50.0 + 0.008 * k;
  r.robot.valid = true;
  for (int i = 0; i < 6; ++i) {
    r.robot.q[i] = 0.1 * i + 0.001 * k;
    r.robot.qd[i] = 0.01 * k;
    r.robot.qdd[i] = -0.02 * i;
    r.sensor.wrench_S[i] = 1.0 + i + 1e-3 * k;
  }
  r.sensor.valid = true;
  r.sensor_age_us = 400;
  return r;
}

std::string scratch(const std::string& name) {
  const std::string p = ::testing::TempDir() + "ftid_stream_" + std::to_string(::getpid()) + "_" + name;
  ::unlink(p.c_str());
  return p;
}

TEST(RunStream, WritesAValidLogAndSkipsUnusableRecords) {
  const std::string p = scratch("ok.csv");
  {
    ftid::cell::RunStreamWriter w(p);
    for (int k = 0; k < 50; ++k) {
      CycleRecord r = rec(k);
      if (k == 10) r.sensor.valid = false;
      if (k == 11) r.sensor.health_flags = ftid::kHealthStale;
      if (k == 12) r.robot.q[2] = NAN;
      w.append(r);
      if (k == 20) w.append(r);  // duplicate time: skipped
    }
    w.finish();
    EXPECT_EQ(w.rows(), 47u);
    EXPECT_EQ(w.skipped(), 4u);
    EXPECT_FALSE(w.failed());
  }
  const auto log = ftid::logio::readLog(p);
  ASSERT_EQ(log.samples.size(), 47u);
  EXPECT_DOUBLE_EQ(log.samples[0].t, 50.0);
  EXPECT_DOUBLE_EQ(log.samples.back().wrench_S[5], 6.0 + 49e-3);
  EXPECT_EQ(log.extraIndex("cycle"), 0);
  EXPECT_EQ(log.extraIndex("sensor_age_ms"), 1);
  EXPECT_THROW(ftid::cell::RunStreamWriter again(p), ftid::Error);  // never replaces a file
  ::unlink(p.c_str());
}

TEST(RunStream, SigkillKeepsEveryRowAppendedBefore) {
  const std::string p = scratch("killed.csv");
  int ready[2];
  ASSERT_EQ(::pipe(ready), 0);
  const int n = 777;
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    ::close(ready[0]);
    ftid::cell::RunStreamWriter w(p, 3600.0);  // no fsync during the test: the kernel keeps it
    for (int k = 0; k < n; ++k) w.append(rec(k));
    const char c = 'x';
    (void)!::write(ready[1], &c, 1);
    for (;;) ::pause();  // killed here, without finish() or any destructor
  }
  ::close(ready[1]);
  char c = 0;
  ASSERT_EQ(::read(ready[0], &c, 1), 1);
  ::close(ready[0]);
  ::kill(child, SIGKILL);
  int status = 0;
  ::waitpid(child, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status));
  const auto log = ftid::logio::readLog(p);
  ASSERT_EQ(log.samples.size(), static_cast<std::size_t>(n));
  EXPECT_DOUBLE_EQ(log.samples.back().t, rec(n - 1).robot.robot_time);
  ::unlink(p.c_str());
}

TEST(RunStream, AWriteErrorKeepsTheCompleteRowsAndSaysSo) {
  const std::string p = scratch("full.csv");
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    // The file may not grow beyond 20 kB: write() fails with EFBIG like a full disk with ENOSPC.
    ::signal(SIGXFSZ, SIG_IGN);
    rlimit lim{20000, 20000};
    ::setrlimit(RLIMIT_FSIZE, &lim);
    ftid::cell::RunStreamWriter w(p);
    for (int k = 0; k < 1000; ++k) w.append(rec(k));
    w.finish();
    const bool ok = w.failed() && w.error().find(p) != std::string::npos &&
                    w.error().find("keeps the " + std::to_string(w.rows()) + " rows") != std::string::npos &&
                    w.rows() > 10 && w.rows() < 1000;
    std::printf("%s\nrows %zu\n", w.error().c_str(), w.rows());
    std::_Exit(ok ? 0 : 1);
  }
  int status = 0;
  ::waitpid(child, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0);
  const auto log = ftid::logio::readLog(p);  // still a valid log: no partial last row
  EXPECT_GT(log.samples.size(), 10u);
  EXPECT_LT(log.samples.size(), 1000u);
  ::unlink(p.c_str());
}

}  // namespace
