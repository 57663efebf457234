#pragma once
// RTDE client (protocol v2, TCP 30004). Set-up calls (connect, negotiate, setup*, start, pause)
// are blocking with timeouts and throw DriverError with a clear message. The streaming calls
// tryReceiveState() and trySendInputs() are real-time safe: no allocation, no exceptions; they
// only use poll/recv/send on the already-connected socket.
//
// Typical read-only use (e.g. a sensor simulator learning the robot's joint state):
//   RtdeClient c;
//   c.connect("127.0.0.1", 30004, std::chrono::seconds(2));
//   c.negotiateProtocolVersion();
//   auto v = c.controllerVersion();
//   c.setupOutputs(v.major >= 5 ? 500.0 : 125.0, RtdeClient::defaultOutputNames());
//   c.start();
//   RtdeStatePackage s;
//   while (c.tryReceiveState(std::chrono::milliseconds(12), &s) == Status::kOk) { ... }
//
// One RtdeClient is used by one thread at a time (the loop thread while streaming).
#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "ftid/common/status.hpp"
#include "ftid/drivers/ur/rtde_state_package.hpp"
#include "ftid/drivers/ur/rtde_protocol.hpp"

namespace ftid::drivers::ur {

/// A registered input recipe. Field indices follow the order of the names given to setupInputs().
struct InputRecipe {
  std::uint8_t id = 0;
  std::vector<std::string> names;
  std::vector<rtde::DataType> types;
  std::vector<std::size_t> offsets;  ///< byte offset of each field in the payload after the id
  std::size_t payload_size = 0;      ///< bytes after the recipe id
};

/// Preallocated input data package for one recipe: set fields, then RtdeClient::trySendInputs().
/// Setters are real-time safe; a wrong index or type is ignored and returns false.
class InputPackage {
 public:
  InputPackage() = default;
  explicit InputPackage(const InputRecipe& recipe);
  bool setInt32(std::size_t field, std::int32_t value) noexcept;
  bool setUint32(std::size_t field, std::uint32_t value) noexcept;
  bool setDouble(std::size_t field, double value) noexcept;
  bool setBool(std::size_t field, bool value) noexcept;
  bool setVector6d(std::size_t field, const Joint6& value) noexcept;
  const std::uint8_t* data() const noexcept { return bytes_.data(); }
  std::size_t size() const noexcept { return bytes_.size(); }
  std::uint8_t recipeId() const noexcept { return bytes_.size() > 3 ? bytes_[3] : 0; }

 private:
  std::vector<std::uint8_t> bytes_;  // complete 'U' package, header included (sized once)
  std::vector<rtde::DataType> types_;
  std::vector<std::size_t> offsets_;  // absolute offsets in bytes_
};

struct RtdeClientStats {
  std::uint64_t packages_received = 0;  ///< 'U' packages decoded
  std::uint64_t packages_skipped = 0;   ///< older buffered 'U' packages dropped (drain-to-latest)
  std::uint64_t timeouts = 0;           ///< tryReceiveState() calls that timed out
  std::uint64_t text_messages = 0;      ///< 'M' packages received while streaming
  std::uint64_t send_failures = 0;
};

class RtdeClient {
 public:
  RtdeClient();
  ~RtdeClient();
  RtdeClient(const RtdeClient&) = delete;
  RtdeClient& operator=(const RtdeClient&) = delete;

  /// TCP connect with timeout (TCP_NODELAY set). Throws DriverError naming host:port.
  void connect(const std::string& host, std::uint16_t port = rtde::kDefaultPort,
               std::chrono::milliseconds timeout = std::chrono::milliseconds(2000));
  bool isConnected() const noexcept;
  /// Closes the socket (sends PAUSE first if streaming and the socket is still up).
  void disconnect() noexcept;

  /// 'V': requests protocol version 2. Returns false if the controller refused (then v1 applies).
  bool negotiateProtocolVersion(std::uint16_t version = rtde::kProtocolVersion2);
  int protocolVersion() const noexcept { return protocol_version_; }
  /// 'v': controller software version (cached after the first call is NOT done: always asks).
  rtde::ControllerVersion controllerVersion();

  /// 'O': output recipe. Returns the types in request order. Throws DriverError listing every
  /// NOT_FOUND variable. Names the decoder does not map into RtdeStatePackage are received and
  /// skipped.
  std::vector<std::string> setupOutputs(double frequency_hz, const std::vector<std::string>& names);
  /// 'I': input recipe. Throws DriverError on NOT_FOUND / IN_USE (reply id 0), naming the variables.
  InputRecipe setupInputs(const std::vector<std::string>& names);
  /// 'S' / 'P'. Throw DriverError if the controller does not accept.
  void start();
  void pause();
  bool isStreaming() const noexcept { return streaming_; }
  /// 'M' (v2 format). Non-RT.
  void sendTextMessage(const std::string& message, const std::string& source = "ftid",
                       std::uint8_t level = 3);

  /// Blocks until the next state package arrives or the timeout expires. If several packages are
  /// buffered, decodes the newest and counts the others in out->packages_skipped (drain-to-latest).
  /// Returns kOk, kTimeout, or kFault (connection closed or protocol error). Real-time safe.
  Status tryReceiveState(std::chrono::nanoseconds timeout, RtdeStatePackage* out) noexcept;
  /// Sends one input data package. Returns kOk or kFault. Real-time safe.
  Status trySendInputs(const InputPackage& package) noexcept;

  /// Text messages received while streaming (kept in a fixed ring; oldest dropped). Non-RT.
  std::vector<rtde::TextMessage> takeTextMessages();
  const RtdeClientStats& stats() const noexcept { return stats_; }
  /// Last error text of a failed RT call (static storage; no allocation). Non-RT readers only.
  const char* lastError() const noexcept { return last_error_; }

  /// The recipe ftid's loop uses: timestamp, actual_q, actual_qd, target_q, target_qd,
  /// target_qdd, actual_TCP_pose, robot_mode, safety_mode, runtime_state, robot_status_bits,
  /// safety_status_bits, speed_scaling, output_int_register_{off..off+1},
  /// output_double_register_{off..off+1}.
  static std::vector<std::string> defaultOutputNames(int register_offset = 0);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  int protocol_version_ = 1;
  bool streaming_ = false;
  RtdeClientStats stats_{};
  const char* last_error_ = "";
};

}  // namespace ftid::drivers::ur
