#include <gtest/gtest.h>

#include "ftid/common/error.hpp"
#include "ftid/drivers/ur/servo_program.hpp"

using namespace ftid::drivers::ur;

TEST(ServoProgram, UsesConfiguredRegistersAndParameters) {
  ServoProgramConfig c;
  c.register_offset = 24;
  c.step_time = 0.002;
  c.lookahead_time = 0.05;
  c.gain = 500;
  const std::string p = buildServoProgram(c);
  EXPECT_EQ(p.rfind("def ftid_servo():\n", 0), 0u);
  EXPECT_EQ(p.substr(p.size() - 4), "end\n");
  EXPECT_NE(p.find("read_input_integer_register(24)"), std::string::npos);
  EXPECT_NE(p.find("read_input_float_register(29)"), std::string::npos);  // q6
  EXPECT_NE(p.find("rtde_set_watchdog(\"input_int_register_24\""), std::string::npos);
  EXPECT_NE(p.find("servoj(q, 0, 0, t, lh, g)"), std::string::npos);
  EXPECT_NE(p.find("global ftid_t = 0.002"), std::string::npos);
  EXPECT_NE(p.find("global ftid_gain = 500"), std::string::npos);
  EXPECT_EQ(p.find("read_input_integer_register(0)"), std::string::npos);
}

TEST(ServoProgram, RejectsOutOfRangeParameters) {
  ServoProgramConfig c;
  c.register_offset = 5;
  EXPECT_THROW(buildServoProgram(c), ftid::ConfigError);
  c = {};
  c.gain = 50;
  EXPECT_THROW(buildServoProgram(c), ftid::ConfigError);
  c = {};
  c.lookahead_time = 0.5;
  EXPECT_THROW(buildServoProgram(c), ftid::ConfigError);
}
