// Set-up diagnosis before fitting (include/ftid/identify/setup_check.hpp).
#include "ftid/identify/setup_check.hpp"

#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>
#include <utility>

#include "ftid/common/error.hpp"
#include "ftid/identify/noise.hpp"
#include "ftid/identify/physical_check.hpp"
#include "ftid/identify/tilt_start.hpp"

namespace ftid::identify {

namespace {

constexpr double kTwoPi = 6.283185307179586;

std::string num(double v, int digits) {
  char b[48];
  std::snprintf(b, sizeof b, "%.*f", digits, v);
  return b;
}

std::string rpyText(const Vec3& rpy) {
  std::string s;
  for (int k = 0; k < 3; ++k) {
    char b[32];
    const double v = std::abs(rpy(k)) < 5e-5 ? 0.0 : rpy(k);  // no "-0"
    std::snprintf(b, sizeof b, "%.5g", v);
    s += (k > 0 ? "," : "") + std::string(b);
  }
  return s;
}

/// Relative residual energy of `model` (default: the gravity model) on ctx: the residual's mean
/// square over the reading's, forces and torques each (NaN if it cannot be fitted).
double relativeResidual(const std::vector<SampleContext>& ctx, double* mass_kg, const char* model = "paper",
                        double* mass_std_kg = nullptr, bool* upright = nullptr) {
  double ms_f = 0.0, ms_t = 0.0;
  for (const auto& c : ctx) {
    ms_f += c.wrench_S.head<3>().squaredNorm();
    ms_t += c.wrench_S.tail<3>().squaredNorm();
  }
  const double n = static_cast<double>(ctx.size());
  ms_f /= n;
  ms_t /= n;
  try {
    const MultiStartFit m = fitModelMultiStart(effects::Model::fromName(model), ctx);
    const Vec6& r = m.fit.residual_rms;
    if (mass_kg != nullptr) *mass_kg = m.fit.value("mass");
    if (mass_std_kg != nullptr) *mass_std_kg = m.fit.stddev("mass");
    // The fitted base's z axis against the configured one: cos = cos(U) cos(V).
    if (upright != nullptr) *upright = std::cos(m.fit.tilt_u_rad) * std::cos(m.fit.tilt_v_rad) > 0.0;
    return r.head<3>().squaredNorm() / std::max(ms_f, 1e-300) + r.tail<3>().squaredNorm() / std::max(ms_t, 1e-300);
  } catch (const Error&) {
    return std::numeric_limits<double>::quiet_NaN();
  }
}

std::vector<SampleContext> rotatedWrench(const std::vector<SampleContext>& ctx, const Mat3& R_fixed, bool to_sensor,
                                         bool from_sensor) {
  std::vector<SampleContext> out = ctx;
  for (auto& c : out) {
    Mat3 R = R_fixed;
    if (to_sensor) R = c.R_BS.transpose();   // a base-frame reading into S
    if (from_sensor) R = c.R_BS;             // a sensor-frame reading taken as base: undo
    c.wrench_S.head<3>() = R * c.wrench_S.head<3>();
    c.wrench_S.tail<3>() = R * c.wrench_S.tail<3>();
  }
  return out;
}

}  // namespace

std::vector<Mat3> axisAlignedRotations() {
  std::vector<Mat3> out;
  out.push_back(Mat3::Identity());
  // Signed permutation matrices with determinant +1.
  const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (const auto& p : perms) {
    for (int s = 0; s < 8; ++s) {
      Mat3 R = Mat3::Zero();
      for (int i = 0; i < 3; ++i) R(i, p[i]) = ((s >> i) & 1) != 0 ? -1.0 : 1.0;
      if (R.determinant() < 0.0 || R.isIdentity()) continue;
      out.push_back(R);
    }
  }
  return out;
}

Vec3 rpyOf(const Mat3& R) {
  const double pitch = std::asin(std::max(-1.0, std::min(1.0, -R(2, 0))));
  double roll = 0.0, yaw = 0.0;
  if (std::abs(R(2, 0)) < 1.0 - 1e-12) {
    roll = std::atan2(R(2, 1), R(2, 2));
    yaw = std::atan2(R(1, 0), R(0, 0));
  } else {  // gimbal lock: roll and yaw share one axis; put it all in yaw
    yaw = std::atan2(-R(0, 1), R(1, 1));
  }
  return {roll, pitch, yaw};
}

Mat3 rotationFromRpy(const Vec3& rpy_rad) {
  return Mat3(Eigen::AngleAxisd(rpy_rad(2), Vec3::UnitZ()) * Eigen::AngleAxisd(rpy_rad(1), Vec3::UnitY()) *
              Eigen::AngleAxisd(rpy_rad(0), Vec3::UnitX()));
}

Vec3 parseRpy(const std::string& text, const std::string& what) {
  Vec3 v;
  std::stringstream ss(text);
  std::string item;
  int k = 0;
  while (std::getline(ss, item, ',')) {
    if (k >= 3) throw ConfigError(what + ": expected R,P,Y (three angles in rad), got '" + text + "'");
    std::size_t used = 0;
    double x = std::numeric_limits<double>::quiet_NaN();
    try {
      x = std::stod(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != item.size() || item.empty() || !std::isfinite(x) || std::abs(x) > kTwoPi) {
      throw ConfigError(what + ": '" + item + "' is not an angle in rad (a finite number within +-2 pi)");
    }
    v(k++) = x;
  }
  if (k != 3) throw ConfigError(what + ": expected R,P,Y (three angles in rad), got '" + text + "'");
  return v;
}

Mat3 bestAxisAlignedMount(const std::vector<SampleContext>& all) {
  if (all.size() < 20) return Mat3::Identity();
  std::vector<SampleContext> ctx;
  const std::size_t step = std::max<std::size_t>(1, all.size() / kSetupMaxSamples);
  for (std::size_t i = 0; i < all.size(); i += step) ctx.push_back(all[i]);
  Mat3 best = Mat3::Identity();
  double best_r = relativeResidual(ctx, nullptr);
  if (!std::isfinite(best_r)) best_r = std::numeric_limits<double>::infinity();
  const auto rotations = axisAlignedRotations();
  for (std::size_t k = 1; k < rotations.size(); ++k) {
    const double r = relativeResidual(rotatedWrench(ctx, rotations[k], false, false), nullptr);
    if (std::isfinite(r) && r < best_r) {
      best_r = r;
      best = rotations[k];
    }
  }
  return best;
}

namespace {

// The unit of the time column against the recorded joint velocities: s, the least-squares factor
// in qd = s * dq/dt over consecutive samples (qd averaged over the pair), is 1 when t is in
// seconds, 1000 when it is in milliseconds. The decade nearest to s (the likeliest of the units
// s, ms, us, ns, ...) is the verdict: "" when it is 1, else a line naming it. Nothing to judge
// without joints or motion.
std::string timeUnitLine(const std::vector<SampleContext>& all) {
  double vd = 0.0, dd = 0.0;
  for (std::size_t i = 1; i < all.size(); ++i) {
    const SampleContext& a = all[i - 1];
    const SampleContext& b = all[i];
    const double dt = b.t - a.t;
    if (!a.has_joints || !b.has_joints || !(dt > 0.0)) continue;
    const JointVector d = (b.q - a.q) / dt;
    const JointVector v = 0.5 * (a.qd + b.qd);
    vd += v.dot(d);
    dd += d.squaredNorm();
  }
  if (!(dd > 0.0) || !(vd > 0.0)) return "";
  const double s = vd / dd;
  const int decade = static_cast<int>(std::lround(std::log10(s)));
  if (decade == 0) return "";
  const char* unit = decade == 3 ? "milliseconds" : decade == 6 ? "microseconds" : decade == 9 ? "nanoseconds" : nullptr;
  char factor[32];
  std::snprintf(factor, sizeof factor, "%.4g", s);
  return std::string("set-up: the joint velocity columns are ") + factor + "x the joint angles' rate of change over the "
         "time column t: " + (unit != nullptr ? std::string("t looks like ") + unit + "; give t in seconds"
                                             : std::string("t is not in seconds, or qd is not in rad/s")) +
         " (docs/log-format.md)";
}

}  // namespace

namespace {

// A negative mass: the gravity model is the same with the reading's sign reversed and the mass's
// (a reflection, which no mount rotation gives), so only the sign of the mass tells. When the
// reversed reading fits a positive mass: a hint to negate the six columns (a sensor reporting the
// wrench on the tool rather than the tool's on the sensor); "" otherwise.
std::string reversedSignHint(const std::vector<SampleContext>& ctx) {
  std::vector<SampleContext> reversed = ctx;
  for (auto& c : reversed) c.wrench_S = -c.wrench_S;
  double mass_reversed = 0.0, mass_std = 0.0;
  const double r = relativeResidual(reversed, &mass_reversed, "paper", &mass_std);
  // A mass the data determine (identify's rule, kMaxMassRelativeStd): not an empty sensor's noise.
  if (!std::isfinite(r) || !(mass_std <= kMaxMassRelativeStd * mass_reversed)) return "";
  return "; with its sign reversed the wrench fits a mass of " + num(mass_reversed, 3) + " kg (" + num(100.0 * r, 1) +
         " % unexplained): if the sensor reports the wrench on the tool, negate fx, fy, fz, tx, ty, tz";
}

// Torque columns in N mm (an ATI Net F/T set to "N, N-mm"): the gravity model alone cannot tell (a
// 1000x centre of mass fits as well), but the payload's dynamics tie m c in the forces
// (m alpha x c) to the torques. `paper+rigid_body` fitted with the torques as given and divided by
// 1000, judged by the rule of the alternatives above (kSetupMinResidual, kSetupBetterRatio); ""
// unless the divided torques explain the data. Needs motion: nothing is said when the robot holds
// still.
std::string torqueUnitLine(const std::vector<SampleContext>& ctx) {
  if (holdsStill(ctx)) return "";
  std::vector<SampleContext> mm = ctx;
  for (auto& c : mm) c.wrench_S.tail<3>() *= 1e-3;
  const double given = relativeResidual(ctx, nullptr, "paper+rigid_body");
  const double divided = relativeResidual(mm, nullptr, "paper+rigid_body");
  if (!(given > kSetupMinResidual && divided < kSetupBetterRatio * given)) return "";
  return "set-up: the torque columns divided by 1000 (N mm read as Nm) explain the payload's dynamics (" +
         num(100.0 * divided, 2) + " % of the signal unexplained instead of " + num(100.0 * given, 1) +
         " %): convert tx, ty, tz to Nm (docs/log-format.md)";
}

/// A column-level set-up error: its words, its fix, and the reading as it would be without it.
struct ChannelError {
  std::string what;
  std::string fix;
  int negate = -1;              ///< the channel (0..5: fx..tz) whose sign is reversed, or -1
  int swap_a = -1, swap_b = -1;  ///< the two axes (0..2) whose force and torque columns are swapped, or -1
  std::vector<SampleContext> apply(const std::vector<SampleContext>& ctx) const {
    std::vector<SampleContext> out = ctx;
    for (auto& c : out) {
      if (negate >= 0) c.wrench_S(negate) = -c.wrench_S(negate);
      if (swap_a >= 0) {
        std::swap(c.wrench_S(swap_a), c.wrench_S(swap_b));
        std::swap(c.wrench_S(3 + swap_a), c.wrench_S(3 + swap_b));
      }
    }
    return out;
  }
};

/// The six single reversed signs and the three swapped axis pairs.
std::vector<ChannelError> channelErrors() {
  static const char* kNames[6] = {"fx", "fy", "fz", "tx", "ty", "tz"};
  std::vector<ChannelError> out;
  for (int k = 0; k < 6; ++k) {
    ChannelError e;
    e.negate = k;
    e.what = std::string("the ") + kNames[k] + " column has its sign reversed";
    e.fix = std::string("negate the ") + kNames[k] + " column (or the sensor's sign for that channel)";
    out.push_back(e);
  }
  const int pairs[3][2] = {{0, 1}, {1, 2}, {0, 2}};
  for (const auto& p : pairs) {
    ChannelError e;
    e.swap_a = p[0];
    e.swap_b = p[1];
    e.what = std::string("the ") + kNames[p[0]] + " and " + kNames[p[1]] + " columns (and " + kNames[3 + p[0]] + ", " +
             kNames[3 + p[1]] + ") are swapped";
    e.fix = std::string("swap the ") + kNames[p[0]] + " and " + kNames[p[1]] + " columns and the " +
            kNames[3 + p[0]] + " and " + kNames[3 + p[1]] + " columns";
    out.push_back(e);
  }
  return out;
}

}  // namespace

SetupDiagnosis diagnoseSetup(const std::vector<SampleContext>& all, const samples::ContextOptions& given,
                             bool try_mounts) {
  SetupDiagnosis d;
  if (all.size() < 20) return d;
  // Degrees in the joint angle columns: a UR joint stays within +-2 pi rad.
  double max_q = 0.0;
  for (const auto& c : all) {
    if (c.has_joints) max_q = std::max(max_q, c.q.cwiseAbs().maxCoeff());
  }
  if (max_q > kTwoPi + 0.1) {
    d.lines.push_back("set-up: joint angles reach " + num(max_q, 1) +
                      ", beyond any joint's +-6.28 rad: the angle columns look like degrees; convert q1..q6 (and "
                      "qd, qdd) to rad (docs/log-format.md)");
  }
  const std::string time_unit = timeUnitLine(all);
  if (!time_unit.empty()) d.lines.push_back(time_unit);
  std::vector<SampleContext> ctx;
  const std::size_t step = std::max<std::size_t>(1, all.size() / kSetupMaxSamples);
  for (std::size_t i = 0; i < all.size(); i += step) ctx.push_back(all[i]);

  double mass_given = 0.0, mass_given_std = 0.0;
  d.given_residual = relativeResidual(ctx, &mass_given, "paper", &mass_given_std);
  if (!std::isfinite(d.given_residual)) return d;
  d.best_residual = std::numeric_limits<double>::infinity();
  // A reading with every sign reversed fits as well as the reading itself, with the mass negative or
  // the base turned upside down (the tilt absorbs it), so an alternative and its reversed twin tie:
  // of the alternatives that explain the data (the rule below), one that fits a positive mass with
  // the base upright as configured is preferred.
  SetupDiagnosis upright_best;
  upright_best.best_residual = std::numeric_limits<double>::infinity();
  auto consider = [&](const std::vector<SampleContext>& alt, const std::string& what, const std::string& fix) {
    bool upright = true;
    double mass = 0.0;
    const double r = relativeResidual(alt, &mass, "paper", nullptr, &upright);
    for (SetupDiagnosis* slot : {&d, upright && mass > 0.0 ? &upright_best : nullptr}) {
      if (slot != nullptr && std::isfinite(r) && r < slot->best_residual) {
        slot->best_residual = r;
        slot->best = what;
        slot->fix = fix;
      }
    }
  };
  // The other wrench frame.
  {
    const auto alt = rotatedWrench(ctx, Mat3::Identity(), !given.wrench_in_base, given.wrench_in_base);
    consider(alt,
             given.wrench_in_base ? "the wrench columns are in the sensor frame" : "the wrench columns are in the base frame",
             given.wrench_in_base ? "--wrench-frame sensor" : "--wrench-frame base");
  }
  // The sensor mounted rotated: its reading is in S' = S R (R_SS' = R), so in S it is R w'.
  const auto rotations = axisAlignedRotations();
  for (std::size_t k = 1; try_mounts && k < rotations.size(); ++k) {
    const Mat3& R = rotations[k];
    const auto alt = rotatedWrench(ctx, R, false, false);
    const Vec3 rpy = canonicalRpy(rpyOf(given.R_FS * R));
    consider(alt, "the sensor is mounted rotated (R_FS rpy " + rpyText(rpy) + " rad)",
             "--mount-rpy " + rpyText(rpy));
  }
  // A column-level error in the log or the sensor's configuration: one channel with its sign
  // reversed, or two axes' columns swapped (forces and torques alike). Neither is a rotation (both
  // reflect), so no mount explains them, though a rotation with the tilt turned over may nearly.
  for (const ChannelError& e : channelErrors()) {
    consider(e.apply(ctx), e.what, e.fix);
  }
  const auto explains = [&](double r) { return d.given_residual > kSetupMinResidual && r < kSetupBetterRatio * d.given_residual; };
  if (explains(upright_best.best_residual)) {
    d.best_residual = upright_best.best_residual;
    d.best = upright_best.best;
    d.fix = upright_best.fix;
  }
  d.explains = explains(d.best_residual);
  const std::string torque_unit = torqueUnitLine(ctx);
  if (!torque_unit.empty()) d.lines.push_back(torque_unit);
  if (d.explains) {
    d.lines.push_back("set-up: " + d.best + " explains the data (the gravity model leaves " +
                      num(100.0 * d.best_residual, 2) + " % of the signal unexplained instead of " +
                      num(100.0 * d.given_residual, 1) + " %, fitted mass " + num(mass_given, 3) +
                      " kg as given): " + (d.fix.compare(0, 2, "--") == 0 ? "add " : "") + d.fix);
  } else if (mass_given <= 0.0 &&
             (d.given_residual > kSetupMinResidual || mass_given_std <= kMaxMassRelativeStd * -mass_given)) {
    // The gravity not following the kinematics, or a negative mass the data determine (identify's
    // rule, kMaxMassRelativeStd), however well it fits.
    d.lines.push_back("set-up: the gravity the wrench sees does not follow the kinematics (the gravity model fits a "
                      "mass of " + num(mass_given, 3) + " kg, " + num(100.0 * d.given_residual, 1) +
                      " % of the signal unexplained); check the robot description, the mount and the wrench frame" +
                      reversedSignHint(ctx));
  }
  return d;
}

}  // namespace ftid::identify
