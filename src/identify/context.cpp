// Building SampleContexts from a log and the robot kinematics (include/ftid/identify/context.hpp).
#include "ftid/identify/context.hpp"

#include <algorithm>
#include <utility>

#include "ftid/common/error.hpp"
#include "ftid/logio/log.hpp"
#include "ftid/model/frames.hpp"
#include "ftid/model/kinematics.hpp"

namespace ftid::identify {

ContextSet::ContextSet(const ContextSet& other)
    : source(other.source),
      t_origin(other.t_origin),
      samples(other.samples),
      extra_names(other.extra_names),
      extra_rows(other.extra_rows),
      has_imu(other.has_imu),
      has_temp(other.has_temp) {
  repoint();
}

ContextSet::ContextSet(ContextSet&& other) noexcept
    : source(std::move(other.source)),
      t_origin(other.t_origin),
      samples(std::move(other.samples)),
      extra_names(std::move(other.extra_names)),
      extra_rows(std::move(other.extra_rows)),
      has_imu(other.has_imu),
      has_temp(other.has_temp) {
  repoint();  // extra_names now lives here (the rows' buffer moved with extra_rows)
  other.repoint();
}

ContextSet& ContextSet::operator=(ContextSet&& other) noexcept {
  if (this != &other) {
    source = std::move(other.source);
    t_origin = other.t_origin;
    samples = std::move(other.samples);
    extra_names = std::move(other.extra_names);
    extra_rows = std::move(other.extra_rows);
    has_imu = other.has_imu;
    has_temp = other.has_temp;
    repoint();
    other.repoint();
  }
  return *this;
}

ContextSet& ContextSet::operator=(const ContextSet& other) {
  if (this != &other) {
    ContextSet copy(other);
    *this = std::move(copy);
  }
  return *this;
}

void ContextSet::repoint() {
  const std::size_t k = extra_names.size();
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const bool has_row = k > 0 && extra_rows.size() >= (i + 1) * k;
    samples[i].extra = has_row ? extra_rows.data() + i * k : nullptr;
    samples[i].extra_names = has_row ? &extra_names : nullptr;
  }
}

int ContextSet::extraIndex(const std::string& name) const {
  const auto it = std::find(extra_names.begin(), extra_names.end(), name);
  return it == extra_names.end() ? -1 : static_cast<int>(it - extra_names.begin());
}

ContextSet buildContexts(const logio::LogData& log, const model::RobotKinematics& kinematics,
                         const ContextOptions& options) {
  if (log.samples.empty()) throw DataError(log.source + ": the log has no samples");
  if (!log.has_wrench) throw DataError(log.source + ": the log has no wrench columns (fx..tz)");
  model::RobotKinematics kin = kinematics;
  kin.setSensorMount(options.R_FS, options.p_FS_F);
  const Vec3 g_B = model::gravityInBase(options.tilt_u_rad, options.tilt_v_rad);

  ContextSet set;
  set.source = log.source;
  set.has_imu = log.has_imu;
  set.has_temp = log.has_temp;
  set.extra_names = log.extra_names;
  const std::size_t n = log.samples.size();
  const std::size_t k = log.extra_names.size();
  set.extra_rows.assign(n * k, 0.0);
  for (std::size_t c = 0; c < k && c < log.extra_columns.size(); ++c) {
    for (std::size_t i = 0; i < n && i < log.extra_columns[c].size(); ++i) {
      set.extra_rows[i * k + c] = log.extra_columns[c][i];
    }
  }
  set.samples.resize(n);
  const double t0 = log.samples.front().t;
  set.t_origin = t0;
  for (std::size_t i = 0; i < n; ++i) {
    const logio::LogSample& s = log.samples[i];
    SampleContext& c = set.samples[i];
    const model::SensorMotion motion = kin.computeSensorMotion(s.q, s.qd, s.qdd);
    c.t = s.t - t0;
    c.q = s.q;
    c.qd = s.qd;
    c.R_BS = motion.R_BS;
    c.p_BS_B = motion.p_BS_B;
    c.w_S = motion.w_S;
    c.alpha_S = motion.alpha_S;
    c.a_S = motion.a_S;
    c.g_S = motion.R_BS.transpose() * g_B;
    c.wrench_S = s.wrench_S;
    c.has_imu = log.has_imu;
    c.has_temp = log.has_temp;
    if (log.has_imu) {
      c.imu_acc_S = s.acc_S;
      c.imu_w_S = s.w_S;
      c.imu_alpha_S = s.alpha_S;
    }
    if (log.has_temp) c.temp_degC = s.temp_degC;
  }
  set.repoint();
  return set;
}

void setTilt(std::vector<SampleContext>& contexts, double tilt_u_rad, double tilt_v_rad) {
  const Vec3 g_B = model::gravityInBase(tilt_u_rad, tilt_v_rad);
  for (auto& c : contexts) c.g_S = c.R_BS.transpose() * g_B;
}

}  // namespace ftid::identify
