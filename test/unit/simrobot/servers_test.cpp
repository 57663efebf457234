// The text protocols of the dashboard and script-port servers, without sockets: replies are UR's
// texts (ur-interface-notes §3.3), and each command has its effect on the controller model.
#include <gtest/gtest.h>

#include <string>

#include "dashboard_server.hpp"  // src/simrobot (private)
#include "ftid/drivers/ur/rtde_protocol.hpp"
#include "script_server.hpp"

namespace sim = ftid::simrobot;
namespace rtde = ftid::drivers::ur::rtde;

namespace {
std::string ask(sim::Controller& k, const std::string& line) {
  bool close = false;
  const std::string r = sim::DashboardServer::execute(k, line, &close);
  EXPECT_FALSE(close) << line;
  return r;
}
}  // namespace

TEST(SimDashboard, RepliesAndEffects) {
  sim::SimRobotConfig cfg;
  cfg.model = sim::RobotModel::kUR10e;
  sim::Controller k(cfg);
  EXPECT_EQ(ask(k, "PolyscopeVersion"), "URSoftware 5.11.1.108318 (Mar 22 2021)");
  EXPECT_EQ(ask(k, "get serial number\r"), "20185500000");
  EXPECT_EQ(ask(k, "robotmode"), "Robotmode: RUNNING");
  EXPECT_EQ(ask(k, "get loaded program"), "No program loaded");
  EXPECT_EQ(ask(k, "play"), "Failed to execute: play");
  k.loadProgram("def ftid_servo():\nend\n");
  EXPECT_EQ(ask(k, "programState"), "PLAYING ftid_servo.urp");
  EXPECT_EQ(ask(k, "running"), "Program running: true");
  EXPECT_EQ(ask(k, "pause"), "Pausing program");
  EXPECT_EQ(k.runtimeState(), rtde::kRuntimePaused);
  EXPECT_EQ(ask(k, "programState"), "PAUSED ftid_servo.urp");
  EXPECT_EQ(ask(k, "stop"), "Stopped");
  EXPECT_EQ(k.runtimeState(), rtde::kRuntimeStopping);
  EXPECT_EQ(ask(k, "play"), "Starting program");
  EXPECT_EQ(k.runtimeState(), rtde::kRuntimePlaying);
  EXPECT_EQ(ask(k, "sim protective_stop"), "Sim: injected protective_stop");
  EXPECT_EQ(ask(k, "safetymode"), "Safetymode: PROTECTIVE_STOP");
  EXPECT_EQ(ask(k, "play"), "Failed to execute: play");
  EXPECT_EQ(ask(k, "unlock protective stop"), "Protective stop releasing");
  EXPECT_EQ(ask(k, "safetymode"), "Safetymode: NORMAL");
  EXPECT_EQ(ask(k, "power off"), "Powering off");
  EXPECT_EQ(k.robotMode(), rtde::kRobotModePowerOff);
  EXPECT_EQ(ask(k, "power on"), "Powering on");
  EXPECT_EQ(k.robotMode(), rtde::kRobotModeIdle);
  EXPECT_EQ(ask(k, "brake release"), "Brake releasing");
  EXPECT_EQ(k.robotMode(), rtde::kRobotModeRunning);
  EXPECT_EQ(ask(k, "sim stall 3"), "Sim: injected stall");
  EXPECT_FALSE(k.tick().advanced);
  EXPECT_EQ(ask(k, "sim meteor").rfind("Sim: unknown fault 'meteor'", 0), 0u);
  EXPECT_EQ(ask(k, "fly"), "could not understand: 'fly'");
  bool close = false;
  EXPECT_EQ(sim::DashboardServer::execute(k, "quit", &close), "Disconnected");
  EXPECT_TRUE(close);
}

TEST(SimScriptPort, ProgramsEndAtAColumnZeroEnd) {
  std::string rx = "def a():\n  if x:\n    y()\n  end\nend\ndef b():\n  z()\nen";
  auto programs = sim::ScriptServer::takePrograms(&rx);
  ASSERT_EQ(programs.size(), 1u);
  EXPECT_EQ(programs[0], "def a():\n  if x:\n    y()\n  end\nend");
  EXPECT_EQ(rx, "def b():\n  z()\nen");  // incomplete: stays buffered
  rx += "d\r\ndef c():\nend";
  programs = sim::ScriptServer::takePrograms(&rx);
  ASSERT_EQ(programs.size(), 2u);
  EXPECT_EQ(programs[0], "def b():\n  z()\nend");
  EXPECT_EQ(programs[1], "\ndef c():\nend");  // what followed the first program's end line
  EXPECT_EQ(rx, "");
}
