#pragma once
// The F/T+IMU sensor seam used by the daemon (docs/architecture.md) and its CAN implementation.
//
//   auto sensor = ftid::drivers::can::openCanSensor(config);          // set-up: may throw
//   ftid::drivers::can::SensorSample s;                                // preallocated
//   ftid::Status st = sensor->tryReadLatest(s);              // each cycle: drain, never blocks
//   if (st == ftid::Status::kOk) { /* s.valid is true */ }
//
// tryReadLatest drains every pending frame (bounded per call), assembles samples and returns the
// newest one: no allocation, no exception, no blocking. Call it and health() from one thread.
#include <array>
#include <cstdint>
#include <memory>
#include <string>

#include "ftid/common/status.hpp"
#include "ftid/drivers/can/sensor_layout.hpp"
#include "ftid/drivers/can/sensor_sample.hpp"
#include "ftid/drivers/can/transport.hpp"

namespace ftid::drivers::can {

class FtImuSensor {
 public:
  virtual ~FtImuSensor() = default;
  FtImuSensor() = default;
  FtImuSensor(const FtImuSensor&) = delete;
  FtImuSensor& operator=(const FtImuSensor&) = delete;

  /// Drains pending data and writes the newest sample to `out` (always written; check the status
  /// or out.valid). `now_ns` is CLOCK_REALTIME ns, the clock of out.rx_time_ns. Returns
  ///   kOk           out.valid: a complete, in-range, fresh-enough sample (out.fresh: new one)
  ///   kStale        nothing complete within the stale timeout (or never)
  ///   kInvalidInput the newest sample is invalid (out-of-range value, status fault, repeat...)
  ///   kFault        bus-off or the transport failed/closed
  virtual Status tryReadLatest(SensorSample& out, std::int64_t now_ns) noexcept = 0;
  Status tryReadLatest(SensorSample& out) noexcept { return tryReadLatest(out, realtimeNowNs()); }
  virtual const SensorHealthCounters& health() const noexcept = 0;
};

/// Maps a sample's flags to the loop's Status (the rule tryReadLatest uses).
Status statusOf(const SensorSample& sample) noexcept;

class CanFtImuSensor final : public FtImuSensor {
 public:
  /// Frames drained per tryReadLatest call at most (bounds the call's run time).
  static constexpr int kMaxFramesPerRead = 4096;

  CanFtImuSensor(std::unique_ptr<CanTransport> transport, const SensorLayout& layout,
                 const SensorHealthOptions& options = {});

  Status tryReadLatest(SensorSample& out, std::int64_t now_ns) noexcept override;
  using FtImuSensor::tryReadLatest;
  const SensorHealthCounters& health() const noexcept override { return assembler_.health(); }
  CanTransport& transport() noexcept { return *transport_; }
  const SensorLayout& layout() const noexcept { return assembler_.layout(); }

 private:
  std::unique_ptr<CanTransport> transport_;
  SampleAssembler assembler_;
  std::array<ReceivedFrame, 64> batch_{};  ///< one recvmmsg() worth of frames
};

/// Everything needed to open the sensor (the daemon fills it from its YAML config).
struct CanSensorConfig {
  /// "seqpacket:/run/ftid/ftsensor.sock" (stand-in), "socketcan:can0", or "candump:FILE.log".
  std::string endpoint = "seqpacket:/run/ftid/ftsensor.sock";
  std::string dbc_path = "config/ftsensor.dbc";
  SensorSignalNames names;
  SensorHealthOptions health;
  int receive_buffer_bytes = 1 << 18;  ///< SO_RCVBUF: > sensor rate x worst-case cycle x 16 B
};

/// Opens the transport named by config.endpoint and compiles the DBC layout. Throws ConfigError
/// (bad endpoint), DataError (DBC) or DriverError (socket).
std::unique_ptr<CanFtImuSensor> openCanSensor(const CanSensorConfig& config);

/// Opens just a transport from an endpoint string (as above).
std::unique_ptr<CanTransport> openCanTransport(const std::string& endpoint,
                                               int receive_buffer_bytes = 0);

}  // namespace ftid::drivers::can
