#include "ftid/transport/codec.hpp"

#include <cstring>

namespace ftid::transport {
namespace {

template <int N, class Vec>
void copyOut(const Vec& v, double* out) noexcept {
  for (int i = 0; i < N; ++i) out[i] = v(i);
}
template <int N, class Vec>
void copyIn(const double* in, Vec* v) noexcept {
  for (int i = 0; i < N; ++i) (*v)(i) = in[i];
}

// A cursor over the big-endian LCM wire form that only checks lengths (findWireProblem).
class WireWalk {
 public:
  WireWalk(const void* buf, std::size_t size) noexcept
      : p_(static_cast<const std::uint8_t*>(buf)), size_(size) {}
  void skip(std::size_t n) noexcept {
    if (problem_ != nullptr) return;
    if (size_ - pos_ < n) {
      problem_ = "message truncated";
      return;
    }
    pos_ += n;
  }
  void string() noexcept {
    if (problem_ != nullptr) return;
    if (size_ - pos_ < 4) {
      problem_ = "message truncated";
      return;
    }
    const std::uint32_t u = (std::uint32_t{p_[pos_]} << 24) | (std::uint32_t{p_[pos_ + 1]} << 16) |
                            (std::uint32_t{p_[pos_ + 2]} << 8) | std::uint32_t{p_[pos_ + 3]};
    pos_ += 4;
    const auto len = static_cast<std::int32_t>(u);
    if (len < 1) {
      problem_ = "string length below 1 (an encoded string holds at least its terminating 0)";
    } else if (static_cast<std::size_t>(len) > size_ - pos_) {
      problem_ = "string length beyond the end of the message";
    } else if (p_[pos_ + static_cast<std::size_t>(len) - 1] != 0) {
      problem_ = "string not terminated by 0";
    } else if (std::memchr(p_ + pos_, 0, static_cast<std::size_t>(len) - 1) != nullptr) {
      // The decoder would keep it, every C API (paths, messages) would cut the string there.
      problem_ = "string with a 0 before its end";
    } else {
      pos_ += static_cast<std::size_t>(len);
    }
  }
  const char* finish() const noexcept {
    if (problem_ != nullptr) return problem_;
    return pos_ == size_ ? nullptr : "trailing bytes after the message";
  }

 private:
  const std::uint8_t* p_;
  std::size_t size_;
  std::size_t pos_ = 0;
  const char* problem_ = nullptr;
};

constexpr std::size_t kHashBytes = 8;

}  // namespace

const char* findWireProblem(const void* buf, std::size_t size, const ftid_lcm::command_t*) noexcept {
  WireWalk w(buf, size);
  w.skip(kHashBytes + 8 + 8 + 1);  // fingerprint, utime, request_id, command
  w.string();                      // argument
  w.skip(8 + 32);                  // sequence, mac
  return w.finish();
}

const char* findWireProblem(const void* buf, std::size_t size, const ftid_lcm::ack_t*) noexcept {
  WireWalk w(buf, size);
  w.skip(kHashBytes + 8 + 8 + 1 + 1 + 4);  // fingerprint, utime, request_id, command, ok, version
  w.string();                              // message
  w.skip(6 * 8);                           // offsets
  return w.finish();
}

const char* findWireProblem(const void* buf, std::size_t size,
                            const ftid_lcm::identification_result_t*) noexcept {
  WireWalk w(buf, size);
  w.skip(kHashBytes + 8);  // fingerprint, utime
  w.string();              // model
  w.skip(4);               // num_params
  for (int i = 0; i < 2 * 64; ++i) w.string();  // param_names, param_units
  w.skip((64 + 64 + 6) * 8 + 4);                // value, stddev, residual_rms, num_samples
  w.string();                                   // param_file
  w.string();                                   // data_file
  w.skip(1);                                    // ok
  w.string();                                   // message
  return w.finish();
}

void toLcm(const RobotStateRecord& in, ftid_lcm::robot_state_t* out) noexcept {
  out->recv_utime = in.recv_utime;
  out->robot_time = in.robot_time;
  copyOut<6>(in.q, out->q);
  copyOut<6>(in.qd, out->qd);
  copyOut<6>(in.qdd, out->qdd);
  out->valid = in.valid ? 1 : 0;
}

void toLcm(const SensorSampleRecord& in, ftid_lcm::sensor_sample_t* out) noexcept {
  out->recv_utime = in.recv_utime;
  out->counter = in.counter;
  copyOut<6>(in.wrench_S, out->wrench);
  copyOut<3>(in.imu_acc_S, out->imu_acc);
  copyOut<3>(in.imu_w_S, out->imu_w);
  copyOut<3>(in.imu_alpha_S, out->imu_alpha);
  out->temp_degC = in.temp_degC;
  out->has_imu = in.has_imu ? 1 : 0;
  out->has_temp = in.has_temp ? 1 : 0;
  out->status_word = in.status_word;
  out->health_flags = static_cast<std::int32_t>(in.health_flags);
  out->valid = in.valid ? 1 : 0;
}

void toLcm(const CycleRecord& in, ftid_lcm::cycle_sample_t* out) noexcept {
  out->utime = in.utime;
  out->cycle = in.cycle;
  toLcm(in.robot, &out->robot);
  toLcm(in.sensor, &out->sensor);
  out->sensor_age_us = in.sensor_age_us;
  out->fault_bits = static_cast<std::int32_t>(in.fault_bits);
}

void toLcm(const CycleRecord& in, ftid_lcm::compensated_wrench_t* out) noexcept {
  out->utime = in.utime;
  out->cycle = in.cycle;
  out->robot_time = in.robot.robot_time;
  out->sensor_recv_utime = in.sensor.recv_utime;
  out->sensor_age_us = in.sensor_age_us;
  copyOut<6>(in.sensor.wrench_S, out->raw);
  copyOut<6>(in.modelled_S, out->modelled);
  copyOut<6>(in.contact_S, out->contact);
  copyOut<6>(in.output, out->output);
  out->output_frame = in.output_frame;
  out->valid = in.wrench_valid ? 1 : 0;
  out->fault_bits = static_cast<std::int32_t>(in.fault_bits);
  out->sensor_health_flags = static_cast<std::int32_t>(in.sensor.health_flags);
  out->param_version = in.param_version;
}

void toLcm(const LoopStatsRecord& in, ftid_lcm::loop_stats_t* out) noexcept {
  out->utime = in.utime;
  out->uptime_s = in.uptime_s;
  out->cycles = in.cycles;
  out->missed_cycles = in.missed_cycles;
  out->overruns = in.overruns;
  out->compute_p50_us = in.compute_p50_us;
  out->compute_p999_us = in.compute_p999_us;
  out->compute_max_us = in.compute_max_us;
  out->valid_cycles = in.valid_cycles;
  out->invalid_cycles = in.invalid_cycles;
  out->stale_sensor_cycles = in.stale_sensor_cycles;
  out->robot_clock_faults = in.robot_clock_faults;
  out->robot_clock_invalid_cycles = in.robot_clock_invalid_cycles;
  out->publish_dropped = in.publish_dropped;
  out->published = in.published;
  out->reloads_applied = in.reloads_applied;
  out->reloads_failed = in.reloads_failed;
  out->param_version = in.param_version;
  out->commands_refused_auth = in.commands_refused_auth;
  out->commands_refused_stale = in.commands_refused_stale;
  out->commands_refused_replay = in.commands_refused_replay;
  out->commands_refused_malformed = in.commands_refused_malformed;
  out->tares_done = in.tares_done;
  out->tares_refused = in.tares_refused;
  out->fault_bits = static_cast<std::int32_t>(in.fault_bits);
  out->realtime = in.realtime ? 1 : 0;
  out->robot_link_up = in.robot_link_up ? 1 : 0;
  out->robot_reconnects = in.robot_reconnects;
  out->robot_link_down_s = in.robot_link_down_s;
  out->sensor_reconnects = in.sensor_reconnects;
}

void fromLcm(const ftid_lcm::robot_state_t& in, RobotStateRecord* out) noexcept {
  out->recv_utime = in.recv_utime;
  out->robot_time = in.robot_time;
  copyIn<6>(in.q, &out->q);
  copyIn<6>(in.qd, &out->qd);
  copyIn<6>(in.qdd, &out->qdd);
  out->valid = in.valid != 0;
}

void fromLcm(const ftid_lcm::sensor_sample_t& in, SensorSampleRecord* out) noexcept {
  out->recv_utime = in.recv_utime;
  out->counter = in.counter;
  copyIn<6>(in.wrench, &out->wrench_S);
  copyIn<3>(in.imu_acc, &out->imu_acc_S);
  copyIn<3>(in.imu_w, &out->imu_w_S);
  copyIn<3>(in.imu_alpha, &out->imu_alpha_S);
  out->temp_degC = in.temp_degC;
  out->has_imu = in.has_imu != 0;
  out->has_temp = in.has_temp != 0;
  out->status_word = in.status_word;
  out->health_flags = static_cast<std::uint32_t>(in.health_flags);
  out->valid = in.valid != 0;
}

void fromLcm(const ftid_lcm::cycle_sample_t& in, CycleRecord* out) noexcept {
  out->utime = in.utime;
  out->cycle = in.cycle;
  fromLcm(in.robot, &out->robot);
  fromLcm(in.sensor, &out->sensor);
  out->sensor_age_us = in.sensor_age_us;
  out->fault_bits = static_cast<std::uint32_t>(in.fault_bits);
}

void fromLcm(const ftid_lcm::compensated_wrench_t& in, CycleRecord* out) noexcept {
  out->utime = in.utime;
  out->cycle = in.cycle;
  out->robot.robot_time = in.robot_time;
  out->sensor.recv_utime = in.sensor_recv_utime;
  out->sensor_age_us = in.sensor_age_us;
  copyIn<6>(in.raw, &out->sensor.wrench_S);
  copyIn<6>(in.modelled, &out->modelled_S);
  copyIn<6>(in.contact, &out->contact_S);
  copyIn<6>(in.output, &out->output);
  out->output_frame = in.output_frame;
  out->wrench_valid = in.valid != 0;
  out->fault_bits = static_cast<std::uint32_t>(in.fault_bits);
  out->sensor.health_flags = static_cast<std::uint32_t>(in.sensor_health_flags);
  out->param_version = in.param_version;
}

void fromLcm(const ftid_lcm::loop_stats_t& in, LoopStatsRecord* out) noexcept {
  out->utime = in.utime;
  out->uptime_s = in.uptime_s;
  out->cycles = in.cycles;
  out->missed_cycles = in.missed_cycles;
  out->overruns = in.overruns;
  out->compute_p50_us = in.compute_p50_us;
  out->compute_p999_us = in.compute_p999_us;
  out->compute_max_us = in.compute_max_us;
  out->valid_cycles = in.valid_cycles;
  out->invalid_cycles = in.invalid_cycles;
  out->stale_sensor_cycles = in.stale_sensor_cycles;
  out->robot_clock_faults = in.robot_clock_faults;
  out->robot_clock_invalid_cycles = in.robot_clock_invalid_cycles;
  out->publish_dropped = in.publish_dropped;
  out->published = in.published;
  out->reloads_applied = in.reloads_applied;
  out->reloads_failed = in.reloads_failed;
  out->param_version = in.param_version;
  out->commands_refused_auth = in.commands_refused_auth;
  out->commands_refused_stale = in.commands_refused_stale;
  out->commands_refused_replay = in.commands_refused_replay;
  out->commands_refused_malformed = in.commands_refused_malformed;
  out->tares_done = in.tares_done;
  out->tares_refused = in.tares_refused;
  out->fault_bits = static_cast<std::uint32_t>(in.fault_bits);
  out->realtime = in.realtime != 0;
  out->robot_link_up = in.robot_link_up != 0;
  out->robot_reconnects = in.robot_reconnects;
  out->robot_link_down_s = in.robot_link_down_s;
  out->sensor_reconnects = in.sensor_reconnects;
}

void warmUpCodec() noexcept {
  (void)ftid_lcm::robot_state_t::getHash();
  (void)ftid_lcm::sensor_sample_t::getHash();
  (void)ftid_lcm::cycle_sample_t::getHash();
  (void)ftid_lcm::compensated_wrench_t::getHash();
  (void)ftid_lcm::loop_stats_t::getHash();
  (void)ftid_lcm::identification_result_t::getHash();
  (void)ftid_lcm::command_t::getHash();
  (void)ftid_lcm::ack_t::getHash();
}

int encodedSize(const ftid_lcm::cycle_sample_t& m) noexcept { return m.getEncodedSize(); }
int encodedSize(const ftid_lcm::compensated_wrench_t& m) noexcept { return m.getEncodedSize(); }
int encodedSize(const ftid_lcm::loop_stats_t& m) noexcept { return m.getEncodedSize(); }

}  // namespace ftid::transport
