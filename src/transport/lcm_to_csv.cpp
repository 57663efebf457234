#include "ftid/transport/lcm_to_csv.hpp"

#include <cmath>
#include <limits>

#include "ftid/common/clock.hpp"
#include "ftid/common/error.hpp"
#include "ftid/transport/codec.hpp"
#include "ftid/transport/lcm_log.hpp"

namespace ftid::transport {
namespace {

template <class M>
bool allFinite(const M& m) {
  return m.allFinite();
}

}  // namespace

CycleLogBuilder::CycleLogBuilder(std::string source, bool keep_invalid)
    : keep_invalid_(keep_invalid), last_t_(-std::numeric_limits<double>::infinity()) {
  log_.source = std::move(source);
  log_.has_wrench = true;
  // host_time: the robot state's receive time on the host's UTC clock [s], the clock of the
  // model's time (docs/conventions.md, "Time and logs"); the same double ftidd computes.
  log_.extra_names = {"cycle", "sensor_age_ms", "fault_bits", "host_time"};
  log_.extra_columns.assign(4, {});
}

bool CycleLogBuilder::add(const CycleRecord& rec) {
  if (!keep_invalid_ && (!rec.robot.valid || !rec.sensor.valid)) {
    ++report_.skipped_invalid;
    return false;
  }
  const bool finite = std::isfinite(rec.robot.robot_time) && allFinite(rec.robot.q) && allFinite(rec.robot.qd) &&
                      allFinite(rec.robot.qdd) && allFinite(rec.sensor.wrench_S) &&
                      (!rec.sensor.has_imu || (allFinite(rec.sensor.imu_acc_S) && allFinite(rec.sensor.imu_w_S) &&
                                               allFinite(rec.sensor.imu_alpha_S))) &&
                      (!rec.sensor.has_temp || std::isfinite(rec.sensor.temp_degC));
  if (!finite) {
    ++report_.skipped_non_finite;
    return false;
  }
  if (!(rec.robot.robot_time > last_t_)) {
    ++report_.skipped_non_monotonic;
    return false;
  }
  last_t_ = rec.robot.robot_time;
  logio::LogSample s;
  s.t = rec.robot.robot_time;
  s.q = rec.robot.q;
  s.qd = rec.robot.qd;
  s.qdd = rec.robot.qdd;
  s.wrench_S = rec.sensor.wrench_S;
  s.acc_S = rec.sensor.imu_acc_S;
  s.w_S = rec.sensor.imu_w_S;
  s.alpha_S = rec.sensor.imu_alpha_S;
  s.temp_degC = rec.sensor.temp_degC;
  all_imu_ = all_imu_ && rec.sensor.has_imu;
  all_temp_ = all_temp_ && rec.sensor.has_temp;
  log_.samples.push_back(s);
  log_.extra_columns[0].push_back(static_cast<double>(rec.cycle));
  log_.extra_columns[1].push_back(static_cast<double>(rec.sensor_age_us) * 1e-3);
  log_.extra_columns[2].push_back(static_cast<double>(rec.fault_bits));
  log_.extra_columns[3].push_back(hostTimeSeconds(rec.robot.recv_utime));
  ++report_.converted;
  return true;
}

logio::LogData CycleLogBuilder::finish() const {
  logio::LogData out = log_;
  out.has_imu = all_imu_ && !out.samples.empty();
  out.has_temp = all_temp_ && !out.samples.empty();
  return out;
}

logio::LogData lcmLogToLogData(const std::string& lcm_log_path, const LcmToLogOptions& options,
                               LcmToLogReport* report_out) {
  CycleLogBuilder builder(lcm_log_path, options.keep_invalid);
  LcmToLogReport& report = builder.report();
  LcmLogReader reader(lcm_log_path);
  LcmLogEvent event;
  ftid_lcm::cycle_sample_t msg{};
  CycleRecord rec;
  while (reader.next(&event)) {
    ++report.events;
    if (event.channel != options.channel) continue;
    ++report.on_channel;
    if (!decodeFrom(event.data.data(), event.data.size(), &msg)) {
      ++report.decode_errors;
      continue;
    }
    fromLcm(msg, &rec);
    builder.add(rec);
  }
  if (report_out != nullptr) *report_out = report;
  if (report.converted == 0) {
    throw DataError(lcm_log_path + ": no usable cycle_sample_t on channel '" + options.channel +
                    "' (" + std::to_string(report.events) + " events, " +
                    std::to_string(report.on_channel) + " on the channel, " +
                    std::to_string(report.skipped_invalid) + " invalid, " +
                    std::to_string(report.decode_errors) + " not decodable)");
  }
  return builder.finish();
}

}  // namespace ftid::transport
