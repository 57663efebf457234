#pragma once
// Maps a DBC onto the F/T+IMU sample, groups frames into samples and checks health (pure code:
// no I/O, no clocks; times are passed in). docs/sensor.md describes the layout and health rules.
#include <array>
#include <cstdint>
#include <string>

#include "ftid/drivers/can/codec.hpp"
#include "ftid/drivers/can/dbc.hpp"
#include "ftid/drivers/can/sensor_sample.hpp"
#include "ftid/drivers/can/transport.hpp"

namespace ftid::drivers::can {

/// The quantities of a sample, in SensorSample order.
enum SensorField : int {
  kFieldFx, kFieldFy, kFieldFz, kFieldTx, kFieldTy, kFieldTz,
  kFieldAccX, kFieldAccY, kFieldAccZ,
  kFieldWx, kFieldWy, kFieldWz,
  kFieldAlphaX, kFieldAlphaY, kFieldAlphaZ,
  kFieldTemperature, kFieldStatus,
  kFieldCount
};

/// DBC signal names of each field and of the per-message rolling counter (defaults match
/// config/ftsensor.dbc). Wrench fields are required; the IMU fields all or none; temperature and
/// status optional (an empty name means "not sent").
struct SensorSignalNames {
  std::array<std::string, kFieldCount> fields = {
      "Fx", "Fy", "Fz", "Tx", "Ty", "Tz", "AccX", "AccY", "AccZ", "GyroX", "GyroY", "GyroZ",
      "AngAccX", "AngAccY", "AngAccZ", "Temperature", "StatusWord"};
  std::string counter = "Counter";  ///< must be present, same length, in every sample message
};

/// The sensor's rated wrench range from the DBC (issue 26, parameter plausibility): per wrench
/// axis Fx..Tz the smaller of |minimum| and |maximum| of the signal's [min|max]; infinity where
/// the DBC gives no range. Throws DataError naming the DBC if a wrench signal is missing.
std::array<double, 6> ratedWrenchRange(const DbcDatabase& dbc, const SensorSignalNames& names = {});

/// The frames making up one sample, compiled from a DBC (set-up time; throws DataError naming the
/// DBC file and the missing/inconsistent signal).
class SensorLayout {
 public:
  static constexpr int kMaxMessages = 8;

  struct Message {
    std::uint32_t can_id = 0;  ///< with CAN_EFF_FLAG for extended ids (as in can_frame::can_id)
    int dlc = 8;
    SignalCodec counter;
    std::array<SignalCodec, kFieldCount> fields{};  ///< valid where field_mask has the bit
    std::uint32_t field_mask = 0;                   ///< bit i: this message carries field i
  };

  static SensorLayout fromDbc(const DbcDatabase& dbc, const SensorSignalNames& names = {});

  int messageCount() const noexcept { return message_count_; }
  const Message& message(int i) const noexcept { return messages_[static_cast<std::size_t>(i)]; }
  /// Index of the message with this can_id (flags as in can_frame), or -1.
  int findMessage(std::uint32_t can_id) const noexcept;
  /// Modulus of the rolling counter (2^bits).
  std::uint32_t counterModulus() const noexcept { return counter_modulus_; }
  bool hasImu() const noexcept { return has_imu_; }
  bool hasTemperature() const noexcept { return has_temperature_; }
  bool hasStatus() const noexcept { return has_status_; }
  /// Codec of a field (and whether it is present).
  bool fieldCodec(SensorField field, SignalCodec& out) const noexcept;

 private:
  std::array<Message, kMaxMessages> messages_{};
  int message_count_ = 0;
  std::uint32_t counter_modulus_ = 256;
  bool has_imu_ = false;
  bool has_temperature_ = false;
  bool has_status_ = false;
};

struct SensorHealthOptions {
  /// No complete sample for this long -> stale (invalid). Default 20 ms (20 periods at 1 kHz).
  std::int64_t stale_timeout_ns = 20'000'000;
  /// Status word bits that mean "do not trust the values" (default: every bit).
  std::uint32_t status_fault_mask = 0xFFFFFFFFu;
  bool counter_gap_invalidates = false;  ///< a sample after lost samples is itself fine by default
  bool error_frame_invalidates = false;  ///< error frames are flagged; data integrity is per frame
  /// Frame groups kept open while waiting for their remaining frames (older ones are abandoned).
  int max_open_groups = 4;
};

/// Groups frames by rolling counter into samples and applies the health rules. Allocation-free
/// and noexcept after construction.
class SampleAssembler {
 public:
  explicit SampleAssembler(const SensorLayout& layout, const SensorHealthOptions& options = {});

  /// Feeds one received frame. Returns true if it completed a sample (then latest() is it).
  bool feed(const ReceivedFrame& frame) noexcept;

  /// The newest complete sample with the staleness rule applied at `now_ns` (CLOCK_REALTIME ns,
  /// same clock as rx timestamps). `fresh` is true once per new sample. Bus-off and transport
  /// problems are reflected as flags.
  void readLatest(SensorSample& out, std::int64_t now_ns) noexcept;
  /// Marks the transport as down (sets kHealthTransportDown until the next complete sample).
  void noteTransportProblem() noexcept;

  const SensorSample& latest() const noexcept { return latest_; }
  const SensorHealthCounters& health() const noexcept { return health_; }
  const SensorLayout& layout() const noexcept { return layout_; }

 private:
  struct Group {
    bool open = false;
    std::uint32_t counter = 0;
    std::uint32_t received_mask = 0;
    std::uint64_t age = 0;  ///< order of opening
    std::array<double, kFieldCount> values{};
    bool out_of_range = false;
    std::int64_t last_rx_ns = 0;
  };
  void completeGroup(Group& group) noexcept;
  Group* findOrOpenGroup(std::uint32_t counter) noexcept;

  SensorLayout layout_;
  SensorHealthOptions options_;
  std::uint32_t all_messages_mask_ = 0;
  std::array<Group, 16> groups_{};
  std::uint64_t group_age_ = 0;
  SensorSample latest_;
  SensorHealthCounters health_;
  bool have_sample_ = false;
  std::uint32_t pending_flags_ = 0;  ///< gap / error-frame flags not yet reported by a read
  bool bus_off_ = false;
  bool transport_down_ = false;
  bool stale_reported_ = false;
  std::uint64_t last_read_sequence_ = 0;
};

/// Values to encode for one sample (the sensor simulator's side).
struct SensorValues {
  Wrench wrench_S = Wrench::Zero();
  Vec3 acc_S = Vec3::Zero();
  Vec3 w_S = Vec3::Zero();
  Vec3 alpha_S = Vec3::Zero();
  double temp_degC = 25.0;
  std::uint32_t status_word = 0;
};

/// Encodes one sample into the layout's frames (one per message, same counter). Returns the number
/// of frames written to `out`. Values beyond the raw range saturate; `saturated` (optional) is set
/// if any did.
int encodeSample(const SensorLayout& layout, const SensorValues& values, std::uint32_t counter,
                 std::array<can_frame, SensorLayout::kMaxMessages>& out,
                 bool* saturated = nullptr) noexcept;

}  // namespace ftid::drivers::can
