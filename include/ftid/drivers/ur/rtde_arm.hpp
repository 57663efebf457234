#pragma once
// Production Arm: RTDE state + servo targets written to input registers, read by ftid's own
// URScript program (servo_program.hpp). Set-up calls are blocking and throw DriverError; the Arm
// methods are real-time safe.
//
//   RtdeArm arm(config);
//   arm.connect();                 // RTDE handshake, recipes, start streaming
//   arm.uploadProgram();           // URScript over 30003, waits until it reports ready
//   ... loop: sendArmWatchdog() / sendClearCommand() in its first cycles (the program stops the
//       arm if no input arrives for 1/f s from then on), then waitForState() / sendServoTarget() ...
//   arm.stopProgram();
#include <chrono>
#include <cstdint>
#include <string>

#include "ftid/common/status.hpp"
#include "ftid/drivers/ur/arm.hpp"
#include "ftid/drivers/ur/rtde_client.hpp"
#include "ftid/drivers/ur/servo_program.hpp"
#include "ftid/drivers/ur/servo_safety.hpp"

namespace ftid::drivers::ur {

struct RtdeArmConfig {
  std::string host = "127.0.0.1";
  std::uint16_t rtde_port = rtde::kDefaultPort;
  std::uint16_t script_port = kScriptPort;
  int register_offset = 0;          ///< 0 (ur_rtde default) or 24 (external-client range)
  double lookahead_time = 0.1;      ///< servoj lookahead [s]
  double gain = 300.0;              ///< servoj gain
  double watchdog_min_hz = 10.0;    ///< program stops if inputs arrive slower than this
  double servo_stop_deceleration = 4.0;  ///< [rad/s^2] for servoStop
  ServoLimits limits{};
  std::chrono::milliseconds connect_timeout{2000};
  std::chrono::milliseconds program_start_timeout{5000};
};

class RtdeArm final : public Arm {
 public:
  explicit RtdeArm(RtdeArmConfig config);
  ~RtdeArm() override;

  /// RTDE connect, protocol v2, controller version (sets the period), recipes, start.
  void connect();
  void disconnect() noexcept;
  const rtde::ControllerVersion& controllerVersion() const noexcept { return version_; }

  /// Uploads the servo program and waits until runtime_state == PLAYING and the program reports
  /// ready. Throws DriverError on timeout (naming the state seen).
  void uploadProgram();
  /// Non-RT: sends command 35 (watchdog on the command register at watchdog_min_hz), waits for
  /// "done", clears it and waits for "ready". The caller must then write the command register at
  /// least watchdog_min_hz times per second. The motion runner does not use this: it arms the
  /// watchdog from its real-time loop (sendArmWatchdog), so a stalled calling thread cannot fire it.
  void armWatchdog();
  /// Clears a pending command (0), sends 255 and waits (bounded, ~1.5 s) until the program has
  /// stopped. Never throws.
  void stopProgram() noexcept;
  /// Non-RT: receive states until `pred` holds or timeout; returns the last state seen.
  template <class Pred>
  bool waitUntil(Pred pred, std::chrono::milliseconds timeout, ArmState* last);

  // Arm interface (real-time safe).
  Status waitForState(std::chrono::nanoseconds timeout, ArmState* out) noexcept override;
  Status sendServoTarget(const JointVector& q) noexcept override;
  Status sendHold() noexcept override;
  Status sendServoStop() noexcept override;
  Status sendArmWatchdog() noexcept override;
  Status sendClearCommand() noexcept override;
  double period() const noexcept override { return period_; }

  /// Writes a bare command (e.g. kCmdNone) with one double argument. Real-time safe.
  Status sendCommand(std::int32_t command, double arg0 = 0.0) noexcept;
  void resetServoReference(const JointVector& q, const JointVector& qd) noexcept override;

  FaultWord& faults() noexcept { return faults_; }
  ServoReject lastReject() const noexcept { return last_reject_; }
  int lastRejectJoint() const noexcept { return safety_.failedJoint(); }
  const RtdeClient& client() const noexcept { return client_; }
  const RtdeArmConfig& config() const noexcept { return config_; }

 private:
  RtdeArmConfig config_;
  RtdeClient client_;
  rtde::ControllerVersion version_{};
  double period_ = 0.008;
  InputPackage servo_pkg_;
  InputPackage command_pkg_;
  ServoSafetyCheck safety_;
  ServoReject last_reject_ = ServoReject::kNone;
  FaultWord faults_;
  RtdeStatePackage raw_{};
  double last_timestamp_ = -1.0;
  double accepted_timestamp_ = -1.0;  // robot time of the state the last accepted target followed
};

template <class Pred>
bool RtdeArm::waitUntil(Pred pred, std::chrono::milliseconds timeout, ArmState* last) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    const Status s = waitForState(std::chrono::milliseconds(100), last);
    if (s == Status::kFault) return false;
    if (s == Status::kOk && pred(*last)) return true;
  }
  return false;
}

}  // namespace ftid::drivers::ur
