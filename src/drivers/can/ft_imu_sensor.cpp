// The CAN F/T+IMU sensor: transport + layout + assembler.
#include "ftid/drivers/can/ft_imu_sensor.hpp"

#include "ftid/common/error.hpp"
#include "ftid/drivers/can/candump.hpp"
#include "ftid/drivers/can/seqpacket.hpp"
#include "ftid/drivers/can/socketcan.hpp"

namespace ftid::drivers::can {

Status statusOf(const SensorSample& s) noexcept {
  if (s.valid) return Status::kOk;
  if (s.health_flags & (kHealthBusOff | kHealthTransportDown)) return Status::kFault;
  if (s.health_flags & kHealthStale) return Status::kStale;  // kHealthNoData comes with it
  return Status::kInvalidInput;
}

CanFtImuSensor::CanFtImuSensor(std::unique_ptr<CanTransport> transport, const SensorLayout& layout,
                               const SensorHealthOptions& options)
    : transport_(std::move(transport)), assembler_(layout, options) {
  if (!transport_) throw ConfigError("CanFtImuSensor needs a transport");
}

Status CanFtImuSensor::tryReadLatest(SensorSample& out, std::int64_t now_ns) noexcept {
  int total = 0;
  while (total < kMaxFramesPerRead) {
    IoResult status = IoResult::kOk;
    const int n = transport_->tryReceiveBatch(batch_.data(), static_cast<int>(batch_.size()), status);
    for (int i = 0; i < n; ++i) assembler_.feed(batch_[static_cast<std::size_t>(i)]);
    total += n;
    if (status == IoResult::kClosed || status == IoResult::kError) {
      assembler_.noteTransportProblem();
      break;
    }
    if (n < static_cast<int>(batch_.size())) break;  // drained
  }
  assembler_.readLatest(out, now_ns);
  return statusOf(out);
}

namespace {

std::unique_ptr<CanTransport> openTransport(const std::string& endpoint, int receive_buffer_bytes,
                                            const SensorLayout* layout) {
  const auto colon = endpoint.find(':');
  const std::string kind = endpoint.substr(0, colon);
  const std::string arg = colon == std::string::npos ? std::string() : endpoint.substr(colon + 1);
  if (arg.empty())
    throw ConfigError("sensor endpoint '" + endpoint +
                      "' must be seqpacket:PATH, socketcan:IFACE or candump:FILE");
  if (kind == "seqpacket") return std::make_unique<SeqpacketCanClient>(arg, receive_buffer_bytes);
  if (kind == "socketcan") {
    SocketCanOptions o;
    o.interface = arg;
    o.receive_buffer_bytes = receive_buffer_bytes;
    if (layout != nullptr) {  // receive only the sensor's data frames (plus error frames)
      for (int i = 0; i < layout->messageCount(); ++i) {
        can_filter f{};
        f.can_id = layout->message(i).can_id;
        f.can_mask = (f.can_id & CAN_EFF_FLAG) ? (CAN_EFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG)
                                               : (CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG);
        o.filters.push_back(f);
      }
    }
    return std::make_unique<SocketCanTransport>(o);
  }
  if (kind == "candump") return std::make_unique<CandumpReplayTransport>(arg, false);
  throw ConfigError("sensor endpoint '" + endpoint + "': unknown transport '" + kind +
                    "' (seqpacket, socketcan or candump)");
}

}  // namespace

std::unique_ptr<CanTransport> openCanTransport(const std::string& endpoint,
                                               int receive_buffer_bytes) {
  return openTransport(endpoint, receive_buffer_bytes, nullptr);
}

std::unique_ptr<CanFtImuSensor> openCanSensor(const CanSensorConfig& config) {
  const SensorLayout layout = SensorLayout::fromDbc(loadDbc(config.dbc_path), config.names);
  return std::make_unique<CanFtImuSensor>(
      openTransport(config.endpoint, config.receive_buffer_bytes, &layout), layout, config.health);
}

}  // namespace ftid::drivers::can
