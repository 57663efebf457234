#include "ftid/motion/robot_session.hpp"

#include "ftid/rt/rt_setup.hpp"

namespace ftid::motion {

SessionResult runOnRobot(const RobotSessionConfig& config, const JointTrajectorySource& trajectory,
                         const std::atomic<bool>* abort, CycleHook hook, void* hook_context) {
  SessionResult out;
  // Lock memory before connecting: mlockall can take long. The servo program's RTDE watchdog is
  // armed by the runner's real-time loop in its first cycles, not here: a stall of this thread
  // between the upload and the loop (load, page faults, the pre-motion check) must not fire it.
  rt::RealtimeReport early;
  rt::lockProcessMemory(config.motion.realtime, &early);
  drivers::ur::RtdeArm arm(config.arm);
  arm.connect();
  out.controller_version = arm.controllerVersion().toString();
  out.period = arm.period();
  arm.uploadProgram();
  MotionRunner runner(arm, config.motion, MotionRunner::capacityFor(trajectory.duration(), arm.period()));
  out.run = runner.run(trajectory, abort, hook, hook_context);
  if (out.run.status == RunStatus::kTargetRejected) {
    out.run.message += std::string(" (last-hop check: ") + drivers::ur::servoRejectName(arm.lastReject()) +
                       ", joint " + std::to_string(arm.lastRejectJoint() + 1) + ")";
  }
  arm.stopProgram();
  arm.disconnect();
  out.recording = runner.recording();
  return out;
}

}  // namespace ftid::motion
