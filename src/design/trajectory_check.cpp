// Dense, optimiser-independent verification of an excitation trajectory.
#include "ftid/design/trajectory_check.hpp"

#include <cmath>
#include <cstdio>
#include <limits>

#include "ftid/common/error.hpp"

namespace ftid::design {

namespace {

struct Tracker {
  ConstraintMargin m;
  explicit Tracker(std::string name, std::string unit, double limit) {
    m.name = std::move(name);
    m.unit = std::move(unit);
    m.limit = limit;
    m.margin = std::numeric_limits<double>::infinity();
  }
  /// value must stay <= limit (sign = +1) or >= limit (sign = -1).
  void update(double value, double t, double sign) {
    const double margin = sign * (m.limit - value);
    if (margin < m.margin || std::isnan(value)) {
      m.margin = std::isnan(value) ? -std::numeric_limits<double>::infinity() : margin;
      m.worst = value;
      m.t = t;
    }
  }
};

}  // namespace

bool CheckReport::ok() const {
  if (!finite || !restToRest()) return false;
  for (const auto& m : margins) {
    if (!(m.margin >= 0.0)) return false;
  }
  return true;
}

std::vector<std::string> CheckReport::violations() const {
  std::vector<std::string> out;
  char buf[256];
  if (!finite) out.emplace_back("trajectory is not finite");
  if (!whole_periods)
    out.emplace_back("duration is not a whole number of base periods (not rest-to-rest)");
  if (rest_error > 1e-9) {
    std::snprintf(buf, sizeof buf,
                  "not rest-to-rest: end-point error %.3g (q - q0, qd, qdd at t = 0 and T)",
                  rest_error);
    out.emplace_back(buf);
  }
  for (const auto& m : margins) {
    if (m.margin >= 0.0) continue;
    std::snprintf(buf, sizeof buf, "%s: %.6g %s at t = %.4f s exceeds the limit %.6g %s by %.3g %s",
                  m.name.c_str(), m.worst, m.unit.c_str(), m.t, m.limit, m.unit.c_str(), -m.margin,
                  m.unit.c_str());
    out.emplace_back(buf);
  }
  return out;
}

std::string CheckReport::table() const {
  std::string s;
  char buf[256];
  std::snprintf(buf, sizeof buf, "%-36s %14s %14s %12s %9s\n", "constraint", "worst", "limit",
                "margin", "t [s]");
  s += buf;
  for (const auto& m : margins) {
    std::snprintf(buf, sizeof buf, "%-36s %14.6g %14.6g %12.4g %9.4f  %s%s\n", m.name.c_str(),
                  m.worst, m.limit, m.margin, m.t, m.unit.c_str(),
                  m.margin < 0.0 ? "  VIOLATED" : "");
    s += buf;
  }
  std::snprintf(buf, sizeof buf, "rest-to-rest end error %.3g (%s), %d samples every %.4g s\n",
                rest_error, restToRest() ? "ok" : "VIOLATED", samples, dt);
  s += buf;
  return s;
}

CheckReport checkTrajectory(const trajectory::FourierTrajectory& traj,
                            const model::RobotKinematics& kinematics,
                            const trajectory::TrajectoryConstraints& c, double dt) {
  if (!(dt > 0.0)) throw ConfigError("check: sampling step must be positive");
  model::RobotKinematics kin = kinematics;
  kin.setSensorMount(Mat3::Identity(), Vec3::Zero());  // we place S ourselves from the flange
  const Eigen::Isometry3d X_FS = Eigen::Translation3d(c.p_FS_F) * Eigen::Isometry3d(c.R_FS);

  CheckReport report;
  report.dt = dt;
  const double T = traj.duration();
  const double periods = T * traj.baseFrequency();
  report.whole_periods =
      std::abs(periods - std::round(periods)) <= 1e-9 && std::round(periods) >= 1.0;

  static const char* kJointNames[] = {"joint 1", "joint 2", "joint 3",
                                      "joint 4", "joint 5", "joint 6"};
  std::vector<Tracker> lower, upper, vel, acc;
  for (int i = 0; i < kNumJoints; ++i) {
    lower.emplace_back(std::string(kJointNames[i]) + " position >= lower", "rad",
                       c.position_lower[i]);
    upper.emplace_back(std::string(kJointNames[i]) + " position <= upper", "rad",
                       c.position_upper[i]);
    vel.emplace_back(std::string(kJointNames[i]) + " |velocity|", "rad/s", c.velocity[i]);
    acc.emplace_back(std::string(kJointNames[i]) + " |acceleration|", "rad/s^2", c.acceleration[i]);
  }
  std::vector<Tracker> floor, spheres;
  for (std::size_t s = 0; s < c.tool.size(); ++s) {
    floor.emplace_back("tool[" + std::to_string(s) + "] bottom above floor", "m", c.floor_z_B);
    for (const auto& k : c.keep_out) {
      spheres.emplace_back(
          "tool[" + std::to_string(s) + "] clearance to " + (k.name.empty() ? "keep-out" : k.name),
          "m", 0.0);
    }
  }

  const long n = static_cast<long>(std::ceil(T / dt - 1e-9));
  for (long k = 0; k <= n; ++k) {
    const double t = (k == n) ? T : static_cast<double>(k) * dt;
    const trajectory::TrajectoryPoint p = traj.evaluate(t);
    if (!p.q.allFinite() || !p.qd.allFinite() || !p.qdd.allFinite()) report.finite = false;
    for (int i = 0; i < kNumJoints; ++i) {
      lower[static_cast<std::size_t>(i)].update(p.q[i], t, -1.0);
      upper[static_cast<std::size_t>(i)].update(p.q[i], t, +1.0);
      vel[static_cast<std::size_t>(i)].update(std::abs(p.qd[i]), t, +1.0);
      acc[static_cast<std::size_t>(i)].update(std::abs(p.qdd[i]), t, +1.0);
    }
    const Eigen::Isometry3d X_BS = kin.computeFlangePose(p.q) * X_FS;
    std::size_t si = 0;
    for (std::size_t s = 0; s < c.tool.size(); ++s) {
      const Vec3 center_B = X_BS * c.tool[s].center_S;
      floor[s].update(center_B.z() - c.tool[s].radius, t, -1.0);
      for (const auto& ko : c.keep_out) {
        // clearance = distance between the sphere surfaces (must stay >= 0)
        spheres[si++].update((center_B - ko.center_B).norm() - ko.radius - c.tool[s].radius, t,
                             -1.0);
      }
    }
    ++report.samples;
  }
  for (int i = 0; i < kNumJoints; ++i) {
    const auto iu = static_cast<std::size_t>(i);
    for (auto* v : {&lower[iu], &upper[iu], &vel[iu], &acc[iu]}) report.margins.push_back(v->m);
  }
  for (auto& f : floor) report.margins.push_back(f.m);
  for (auto& s : spheres) report.margins.push_back(s.m);

  // Rest-to-rest at both ends (evaluated exactly at t = 0 and t = T).
  const JointVector& q0 = traj.startPose();
  double err = 0.0;
  for (double t : {0.0, T}) {
    const trajectory::TrajectoryPoint p = traj.evaluate(t);
    err = std::max({err, (p.q - q0).cwiseAbs().maxCoeff(), p.qd.cwiseAbs().maxCoeff(),
                    p.qdd.cwiseAbs().maxCoeff()});
  }
  report.rest_error = std::isfinite(err) ? err : std::numeric_limits<double>::infinity();
  return report;
}

std::vector<std::string> checkMotionSamples(double period, const std::vector<JointVector>& approach,
                                            const std::vector<double>& t_traj,
                                            const std::vector<JointVector>& q_traj,
                                            const model::RobotKinematics& kinematics,
                                            const trajectory::TrajectoryConstraints& c) {
  if (!(period > 0.0) || t_traj.size() != q_traj.size()) {
    throw ConfigError("motion check: need a positive period and one time per trajectory sample");
  }
  model::RobotKinematics kin = kinematics;
  kin.setSensorMount(Mat3::Identity(), Vec3::Zero());
  const Eigen::Isometry3d X_FS = Eigen::Translation3d(c.p_FS_F) * Eigen::Isometry3d(c.R_FS);
  std::vector<std::string> out;
  std::vector<std::string> seen;  // one line per constraint (its first violation)
  char buf[384];
  auto report = [&](const std::string& constraint, const std::string& where, const std::string& detail) {
    const std::string key = where.substr(0, where.find(' ')) + " " + constraint;  // per phase
    for (const auto& s : seen) {
      if (s == key) return;
    }
    seen.push_back(key);
    out.push_back(where + ": " + constraint + ": " + detail);
  };
  auto where = [&](bool is_approach, std::size_t k) {
    if (is_approach) {
      std::snprintf(buf, sizeof buf, "approach sample %zu (t = %.3f s after start)", k + 1,
                    static_cast<double>(k + 1) * period);
    } else {
      std::snprintf(buf, sizeof buf, "trajectory sample %zu (t = %.3f s)", k, t_traj[k]);
    }
    return std::string(buf);
  };
  auto workspace = [&](const JointVector& q, bool is_approach, std::size_t k) {
    if (!q.allFinite()) {
      report("finite joint targets", where(is_approach, k), "non-finite target");
      return;
    }
    const Eigen::Isometry3d X_BS = kin.computeFlangePose(q) * X_FS;
    for (std::size_t s = 0; s < c.tool.size(); ++s) {
      const Vec3 center_B = X_BS * c.tool[s].center_S;
      const double bottom = center_B.z() - c.tool[s].radius;
      if (bottom < c.floor_z_B) {
        std::snprintf(buf, sizeof buf, "bottom at z = %.4f m, %.4f m below the floor z = %.4f m", bottom,
                      c.floor_z_B - bottom, c.floor_z_B);
        report("tool[" + std::to_string(s) + "] above floor", where(is_approach, k), buf);
      }
      for (const auto& ko : c.keep_out) {
        const double clearance = (center_B - ko.center_B).norm() - ko.radius - c.tool[s].radius;
        if (clearance < 0.0) {
          std::snprintf(buf, sizeof buf, "penetrates it by %.4f m", -clearance);
          report("tool[" + std::to_string(s) + "] clear of keep-out " + (ko.name.empty() ? "sphere" : ko.name),
                 where(is_approach, k), buf);
        }
      }
    }
  };
  for (std::size_t k = 0; k < approach.size(); ++k) workspace(approach[k], true, k);
  for (std::size_t k = 0; k < q_traj.size(); ++k) {
    const JointVector& q = q_traj[k];
    workspace(q, false, k);
    for (int i = 0; i < kNumJoints; ++i) {
      const std::string joint = "joint " + std::to_string(i + 1);
      if (q[i] < c.position_lower[i] || q[i] > c.position_upper[i]) {
        std::snprintf(buf, sizeof buf, "%.4f rad outside the designed range [%.4f, %.4f] rad", q[i],
                      c.position_lower[i], c.position_upper[i]);
        report(joint + " designed range", where(false, k), buf);
      }
      if (k >= 1) {
        const double dt = t_traj[k] - t_traj[k - 1];
        if (dt > 0.0) {
          const double v = std::abs(q[i] - q_traj[k - 1][i]) / dt;
          if (v > c.velocity[i] * (1.0 + 1e-9)) {
            std::snprintf(buf, sizeof buf, "%.4f rad/s exceeds the designed limit %.4f rad/s", v, c.velocity[i]);
            report(joint + " velocity", where(false, k), buf);
          }
        }
      }
      if (k >= 2) {
        const double h1 = t_traj[k - 1] - t_traj[k - 2];
        const double h2 = t_traj[k] - t_traj[k - 1];
        if (h1 > 0.0 && h2 > 0.0) {
          const double a = std::abs(2.0 * ((q[i] - q_traj[k - 1][i]) / h2 - (q_traj[k - 1][i] - q_traj[k - 2][i]) / h1) /
                                    (h1 + h2));
          if (a > c.acceleration[i] * (1.0 + 1e-9)) {
            std::snprintf(buf, sizeof buf, "%.4f rad/s^2 exceeds the designed limit %.4f rad/s^2", a,
                          c.acceleration[i]);
            report(joint + " acceleration", where(false, k), buf);
          }
        }
      }
    }
  }
  return out;
}

}  // namespace ftid::design
