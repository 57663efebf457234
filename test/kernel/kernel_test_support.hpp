#pragma once
// Helpers shared by the two sources of ftid_kernel_test (kernel_test.cpp: the kernel features;
// kernel_ftidd_test.cpp: ftidd end to end). Runs only inside scripts/kernel-rig.sh.
#include <gtest/gtest.h>

#include <net/if.h>

#include <fstream>
#include <sstream>
#include <string>

#include "ftid/drivers/can/socketcan.hpp"
#include "ftid/common/types.hpp"
#include "test_paths.hpp"

namespace ftid::kerneltest {

inline const std::string kSrc = ftid::test::sourceDir();
inline const char* const kIface = "vcan0";

inline std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

inline JointVector homeQ() {
  return (JointVector() << 0.0, -1.5708, 1.5708, -1.5708, -1.5708, 0.0).finished();
}

inline void requireVcan() {
  std::string why;
  ASSERT_TRUE(drivers::can::socketCanAvailable(&why)) << why;
  ASSERT_NE(if_nametoindex(kIface), 0u) << "no interface " << kIface << " (the rig creates it)";
}

}  // namespace ftid::kerneltest
