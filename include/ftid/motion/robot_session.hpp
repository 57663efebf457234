#pragma once
// One complete motion session on a UR controller (real or ftid sim-robot): RTDE connect, upload
// ftid's servo program, run the MotionRunner (whose real-time loop arms the program's RTDE watchdog
// in its first cycles), stop the program, disconnect.
#include <atomic>
#include <string>
#include <vector>

#include "ftid/drivers/ur/rtde_arm.hpp"
#include "ftid/motion/motion_runner.hpp"

namespace ftid::motion {

struct RobotSessionConfig {
  drivers::ur::RtdeArmConfig arm{};
  MotionConfig motion{};
};

struct SessionResult {
  RunResult run;
  std::vector<RecordedTick> recording;
  std::string controller_version;  ///< "3.15.8.106339"
  double period = 0.0;             ///< controller period [s]
};

/// Throws DriverError / ConfigError / RealtimeSetupError for set-up failures (nothing moved).
/// Everything after the program upload ends in a SessionResult (the program is stopped).
SessionResult runOnRobot(const RobotSessionConfig& config, const JointTrajectorySource& trajectory,
                         const std::atomic<bool>* abort = nullptr, CycleHook hook = nullptr,
                         void* hook_context = nullptr);

}  // namespace ftid::motion
