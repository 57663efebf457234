// demo::jerkTicks (src/cell/demo_cell.hpp): the ticks of a recording where the arm's acceleration
// exceeded kJerkRadps2 on some joint, read from a run's run.csv as from a motion runner's CSV;
// `ftid demo` runs a refused identification again only when its recording holds one.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <string>

#include "demo_cell.hpp"

namespace ftid::cell::demo {
namespace {

std::string writeCsv(const std::string& name, const std::string& rows) {
  const std::string path = ::testing::TempDir() + name;
  std::ofstream(path) << "t,q1,qdd1,qdd2,qdd3,qdd4,qdd5,qdd6,fx\n" << rows;
  return path;
}

TEST(JerkTicks, CountsTheTicksBeyondTheLimitOnAnyJoint) {
  const std::string calm = writeCsv("jerk_calm.csv", "0,0,6.5,0,0,0,0,-6.5,1\n0.008,0,0,0,0,0,0,0,1\n");
  EXPECT_EQ(jerkTicks(calm), 0u);
  const std::string jerky =
      writeCsv("jerk_two.csv", "0,0,0,0,0,0,0,0,1\n0.008,0,0,0,-40,0,0,0,1\n0.016,0,0,0,0,0,25,21,1\n");
  EXPECT_EQ(jerkTicks(jerky), 2u);  // one tick per row, whatever the number of joints
  EXPECT_EQ(jerkTicks(::testing::TempDir() + "jerk_missing.csv"), 0u);  // unreadable: 0
  std::remove(calm.c_str());
  std::remove(jerky.c_str());
}

}  // namespace
}  // namespace ftid::cell::demo
