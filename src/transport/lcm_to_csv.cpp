#include "ftid/transport/lcm_to_csv.hpp"

#include <cmath>
#include <limits>

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

logio::LogData lcmLogToLogData(const std::string& lcm_log_path, const LcmToLogOptions& options,
                               LcmToLogReport* report_out) {
  LcmToLogReport report;
  logio::LogData log;
  log.source = lcm_log_path;
  log.has_wrench = true;
  log.extra_names = {"cycle", "sensor_age_ms", "fault_bits"};
  log.extra_columns.assign(3, {});

  LcmLogReader reader(lcm_log_path);
  LcmLogEvent event;
  ftid_lcm::cycle_sample_t msg{};
  CycleRecord rec;
  bool all_imu = true;
  bool all_temp = true;
  double last_t = -std::numeric_limits<double>::infinity();
  while (reader.next(&event)) {
    ++report.events;
    if (event.channel != options.channel) continue;
    ++report.on_channel;
    if (!decodeFrom(event.data.data(), event.data.size(), &msg)) {
      ++report.decode_errors;
      continue;
    }
    fromLcm(msg, &rec);
    if (!options.keep_invalid && (!rec.robot.valid || !rec.sensor.valid)) {
      ++report.skipped_invalid;
      continue;
    }
    const bool finite = std::isfinite(rec.robot.robot_time) && allFinite(rec.robot.q) &&
                        allFinite(rec.robot.qd) && allFinite(rec.robot.qdd) &&
                        allFinite(rec.sensor.wrench_S) &&
                        (!rec.sensor.has_imu ||
                         (allFinite(rec.sensor.imu_acc_S) && allFinite(rec.sensor.imu_w_S) &&
                          allFinite(rec.sensor.imu_alpha_S))) &&
                        (!rec.sensor.has_temp || std::isfinite(rec.sensor.temp_degC));
    if (!finite) {
      ++report.skipped_non_finite;
      continue;
    }
    if (!(rec.robot.robot_time > last_t)) {
      ++report.skipped_non_monotonic;
      continue;
    }
    last_t = rec.robot.robot_time;
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
    all_imu = all_imu && rec.sensor.has_imu;
    all_temp = all_temp && rec.sensor.has_temp;
    log.samples.push_back(s);
    log.extra_columns[0].push_back(static_cast<double>(rec.cycle));
    log.extra_columns[1].push_back(static_cast<double>(rec.sensor_age_us) * 1e-3);
    log.extra_columns[2].push_back(static_cast<double>(rec.fault_bits));
    ++report.converted;
  }
  if (report_out != nullptr) *report_out = report;
  if (log.samples.empty()) {
    throw DataError(lcm_log_path + ": no usable cycle_sample_t on channel '" + options.channel +
                    "' (" + std::to_string(report.events) + " events, " +
                    std::to_string(report.on_channel) + " on the channel, " +
                    std::to_string(report.skipped_invalid) + " invalid, " +
                    std::to_string(report.decode_errors) + " not decodable)");
  }
  log.has_imu = all_imu;
  log.has_temp = all_temp;
  return log;
}

}  // namespace ftid::transport
