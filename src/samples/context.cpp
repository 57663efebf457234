// Building SampleContexts from a log and the robot kinematics (include/ftid/samples/context.hpp).
#include "ftid/samples/context.hpp"
#include "ftid/samples/held_readings.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "ftid/common/default_files.hpp"
#include "ftid/common/error.hpp"
#include "ftid/logio/log.hpp"
#include "ftid/model/frames.hpp"
#include "ftid/model/kinematics.hpp"
#include "ftid/samples/sample_builder.hpp"

namespace ftid::samples {

ContextSet::ContextSet(const ContextSet& other)
    : source(other.source),
      t_origin(other.t_origin),
      time_origin_unix_s(other.time_origin_unix_s),
      samples(other.samples),
      extra_names(other.extra_names),
      extra_rows(other.extra_rows),
      has_imu(other.has_imu),
      has_temp(other.has_temp),
      held_rows(other.held_rows),
      held_note(other.held_note),
      thinned_note(other.thinned_note) {
  repoint();
}

ContextSet::ContextSet(ContextSet&& other) noexcept
    : source(std::move(other.source)),
      t_origin(other.t_origin),
      time_origin_unix_s(other.time_origin_unix_s),
      samples(std::move(other.samples)),
      extra_names(std::move(other.extra_names)),
      extra_rows(std::move(other.extra_rows)),
      has_imu(other.has_imu),
      has_temp(other.has_temp),
      held_rows(other.held_rows),
      held_note(std::move(other.held_note)),
      thinned_note(std::move(other.thinned_note)) {
  repoint();  // extra_names now lives here (the rows' buffer moved with extra_rows)
  other.repoint();
}

ContextSet& ContextSet::operator=(ContextSet&& other) noexcept {
  if (this != &other) {
    source = std::move(other.source);
    t_origin = other.t_origin;
    time_origin_unix_s = other.time_origin_unix_s;
    samples = std::move(other.samples);
    extra_names = std::move(other.extra_names);
    extra_rows = std::move(other.extra_rows);
    has_imu = other.has_imu;
    has_temp = other.has_temp;
    held_rows = other.held_rows;
    held_note = std::move(other.held_note);
    thinned_note = std::move(other.thinned_note);
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

void ContextSet::keepRows(const std::vector<char>& keep) {
  const std::size_t k = extra_names.size();
  std::size_t kept = 0;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    if (keep[i] == 0) continue;
    samples[kept] = samples[i];
    std::copy_n(extra_rows.begin() + static_cast<std::ptrdiff_t>(i * k), k,
                extra_rows.begin() + static_cast<std::ptrdiff_t>(kept * k));
    ++kept;
  }
  samples.resize(kept);
  extra_rows.resize(kept * k);
  repoint();
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

bool parseWrenchFrame(const std::string& text) {
  if (text.empty() || text == "sensor") return false;
  if (text == "base") return true;
  throw ConfigError("--wrench-frame must be 'sensor' or 'base', not '" + text + "'");
}

namespace {

/// A column of the pose log (an extra column of the reader), or nullptr.
const std::vector<double>* column(const logio::LogData& log, const char* name) {
  const int k = log.extraIndex(name);
  return k < 0 ? nullptr : &log.extra_columns[static_cast<std::size_t>(k)];
}

/// Three columns a, b, c as vectors, or an empty vector if any is missing; all-or-nothing.
std::vector<Vec3> triple(const logio::LogData& log, const char* a, const char* b, const char* c) {
  const auto* x = column(log, a);
  const auto* y = column(log, b);
  const auto* z = column(log, c);
  const int present = (x != nullptr) + (y != nullptr) + (z != nullptr);
  if (present == 0) return {};
  if (present != 3) {
    throw DataError(log.source + ": incomplete pose columns: " + a + "," + b + "," + c +
                    " must be all present or all absent");
  }
  std::vector<Vec3> v(x->size());
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = Vec3((*x)[i], (*y)[i], (*z)[i]);
  return v;
}

Vec3 rotationVector(const Mat3& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.angle() * aa.axis();
}

/// Local least-squares slope through sample i of y(t) over +-h samples (smoothed derivative).
template <typename F>
Vec3 slopeAt(const std::vector<double>& t, std::size_t i, int h, F delta) {
  const std::size_t lo = i >= static_cast<std::size_t>(h) ? i - static_cast<std::size_t>(h) : 0;
  const std::size_t hi = std::min(t.size() - 1, i + static_cast<std::size_t>(h));
  double sx = 0, sxx = 0, n = 0;
  Vec3 sy = Vec3::Zero(), sxy = Vec3::Zero();
  for (std::size_t j = lo; j <= hi; ++j) {
    const double x = t[j] - t[i];
    const Vec3 y = delta(j);
    sx += x;
    sxx += x * x;
    sy += y;
    sxy += x * y;
    n += 1;
  }
  const double den = n * sxx - sx * sx;
  return den > 0 ? Vec3((n * sxy - sx * sy) / den) : Vec3(Vec3::Zero());
}

/// Fills R_BS, p_BS_B, w_S, alpha_S, a_S of a pose log's contexts.
void posesToContexts(const logio::LogData& log, const ContextOptions& options, std::vector<SampleContext>& ctx) {
  const std::size_t n = log.samples.size();
  std::vector<Mat3> R(n);
  const std::vector<Vec3> rv = triple(log, "rx", "ry", "rz");
  const auto* qw = column(log, "qw");
  if (qw != nullptr) {
    const std::vector<Vec3> qv = triple(log, "qx", "qy", "qz");
    if (qv.empty()) throw DataError(log.source + ": column qw without qx, qy, qz");
    if (!rv.empty()) throw DataError(log.source + ": both a quaternion (qx..qw) and a rotation vector (rx..rz)");
    for (std::size_t i = 0; i < n; ++i) {
      Eigen::Quaterniond q((*qw)[i], qv[i].x(), qv[i].y(), qv[i].z());
      const double norm = q.norm();
      if (!(std::abs(norm - 1.0) < 1e-3)) {
        throw DataError(log.source + ": sample " + std::to_string(i + 1) + " (t = " + std::to_string(log.samples[i].t) +
                        "): quaternion qx,qy,qz,qw has norm " + std::to_string(norm) + ", not 1");
      }
      R[i] = q.normalized().toRotationMatrix();
    }
  } else if (!rv.empty()) {
    for (std::size_t i = 0; i < n; ++i) {
      const double angle = rv[i].norm();
      R[i] = angle > 0 ? Mat3(Eigen::AngleAxisd(angle, rv[i] / angle).toRotationMatrix()) : Mat3(Mat3::Identity());
    }
  } else {
    throw DataError(log.source + ": no joint angles and no sensor pose (qx,qy,qz,qw or rx,ry,rz)");
  }
  const std::vector<Vec3> p = triple(log, "px", "py", "pz");
  const std::vector<Vec3> w = triple(log, "kin_wx", "kin_wy", "kin_wz");
  const std::vector<Vec3> al = triple(log, "kin_alx", "kin_aly", "kin_alz");
  const std::vector<Vec3> a = triple(log, "kin_ax", "kin_ay", "kin_az");
  std::vector<double> t(n);
  for (std::size_t i = 0; i < n; ++i) t[i] = log.samples[i].t;
  const int h = std::max(1, options.derivative_half_window);
  // Smoothed derivatives where no column gives them: w_S from the local rotation vectors
  // log(R_i^T R_j) (expressed in S at i), alpha_S = d/dt w_S (w_S x w_S = 0), a_S = R^T d2p/dt2.
  std::vector<Vec3> w_fd, v_fd;
  if (w.empty() || (al.empty())) {
    w_fd.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      w_fd[i] = slopeAt(t, i, h, [&](std::size_t j) { return rotationVector(R[i].transpose() * R[j]); });
    }
  }
  if (a.empty() && !p.empty()) {
    v_fd.resize(n);
    for (std::size_t i = 0; i < n; ++i) v_fd[i] = slopeAt(t, i, h, [&](std::size_t j) { return p[j]; });
  }
  for (std::size_t i = 0; i < n; ++i) {
    SampleContext& c = ctx[i];
    c.R_BS = R[i];
    c.p_BS_B = p.empty() ? Vec3(Vec3::Zero()) : p[i];
    c.w_S = w.empty() ? w_fd[i] : w[i];
    c.alpha_S = al.empty() ? slopeAt(t, i, h, [&](std::size_t j) { return w.empty() ? w_fd[j] : w[j]; }) : al[i];
    if (!a.empty()) {
      c.a_S = a[i];
    } else if (!p.empty()) {
      c.a_S = R[i].transpose() * slopeAt(t, i, h, [&](std::size_t j) { return v_fd[j]; });
    } else {
      c.a_S = Vec3::Zero();
    }
    c.q.setZero();
    c.qd.setZero();
    c.has_joints = false;
  }
}

}  // namespace

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
  // The model's time (docs/conventions.md, "Time and logs"): with a host_time column, seconds
  // since the time origin (the parameter set's, else the first sample's host_time), exactly as
  // ftidd computes it from the same recorded value; without one, since the log's first sample.
  const std::vector<double>* host_time = column(log, kHostTimeColumn);
  if (host_time != nullptr) {
    for (std::size_t i = 0; i < n; ++i) {
      if (!std::isfinite((*host_time)[i])) {
        throw DataError(log.source + ": sample " + std::to_string(i + 1) + " (t = " +
                        std::to_string(log.samples[i].t) + "): column '" + kHostTimeColumn + "' is not finite");
      }
    }
    set.time_origin_unix_s =
        std::isfinite(options.time_origin_unix_s) ? options.time_origin_unix_s : host_time->front();
  }
  if (!log.has_joints) posesToContexts(log, options, set.samples);
  for (std::size_t i = 0; i < n; ++i) {
    const logio::LogSample& s = log.samples[i];
    SampleContext& c = set.samples[i];
    const double t_model = host_time != nullptr ? (*host_time)[i] - set.time_origin_unix_s : s.t - t0;
    SensorReading reading;
    reading.wrench_S = s.wrench_S;
    reading.has_imu = log.has_imu;
    reading.imu_acc_S = s.acc_S;
    reading.imu_w_S = s.w_S;
    reading.imu_alpha_S = s.alpha_S;
    reading.has_temp = log.has_temp;
    reading.temp_degC = s.temp_degC;
    if (log.has_joints) {
      makeSampleContext(s.t - t0, t_model, s.q, s.qd, kin.computeSensorMotion(s.q, s.qd, s.qdd), reading, g_B, &c);
    } else {
      // Pose logs: the motion posesToContexts derived from the pose columns; no joint state.
      const model::SensorMotion motion{c.R_BS, c.p_BS_B, c.w_S, c.alpha_S, c.a_S};
      makeSampleContext(s.t - t0, t_model, JointVector::Zero(), JointVector::Zero(), motion, reading, g_B, &c);
      c.has_joints = false;
    }
    if (options.wrench_in_base) {
      c.wrench_S.head<3>() = c.R_BS.transpose() * s.wrench_S.head<3>();
      c.wrench_S.tail<3>() = c.R_BS.transpose() * s.wrench_S.tail<3>();
    }
  }
  set.repoint();
  return set;
}

ContextSet loadLogContexts(const std::string& log_path, const std::string& robot_urdf,
                           const ContextOptions& options,
                           const std::function<void(const std::string& line)>& progress) {
  if (progress) progress("reading " + log_path);
  logio::InputLog in = logio::readInput(log_path, options.input);
  if (progress) {
    progress(log_path + ": " + in.format);
    for (const std::string& note : in.notes) progress(note);
  }
  ContextOptions opt = options;
  opt.wrench_in_base = options.wrench_in_base || in.wrench_in_base;
  const std::string urdf = robot_urdf.empty() ? defaultRobotUrdf() : robot_urdf;
  if (progress) progress("robot " + urdf + ", " + std::to_string(in.log.samples.size()) + " samples");
  const model::RobotKinematics kin = model::RobotKinematics::fromUrdfFile(urdf);
  ContextSet set = buildContexts(in.log, kin, opt);
  set.thinned_note = in.thinned_note;
  if (options.drop_held_readings) {
    const HeldReadings held = findHeldReadings(in.log);
    if (held.count > 0) {
      std::vector<char> keep(held.held.size());
      for (std::size_t i = 0; i < keep.size(); ++i) keep[i] = held.held[i] != 0 ? 0 : 1;
      set.keepRows(keep);
      set.held_rows = held.count;
      set.held_note = describeHeldReadings(held, log_path);
      if (progress) progress(set.held_note);
    }
  }
  return set;
}

void setTilt(std::vector<SampleContext>& contexts, double tilt_u_rad, double tilt_v_rad) {
  const Vec3 g_B = model::gravityInBase(tilt_u_rad, tilt_v_rad);
  for (auto& c : contexts) c.g_S = c.R_BS.transpose() * g_B;
}

}  // namespace ftid::samples
