#pragma once
// Building the per-sample SampleContext (ftid/effects/effect.hpp) from a log and the robot
// kinematics. Frames and units: docs/conventions.md.
//
//   R_BS, p_BS_B, w_S, alpha_S, a_S  = RobotKinematics::computeSensorMotion(q, qd, qdd)
//   g_S                              = R_BS^T g_B(U, V)          (for the tilt in the options)
//   wrench_S, IMU columns, temp      = copied from the log
//   t                                = log t minus the first sample's t
//   extra, extra_names               = pointers to this sample's extra columns (row-major copy)
//                                      and to the set's column names (generic effects such as
//                                      poly(<column>,n) read them)
#include <string>
#include <vector>

#include "ftid/effects/effect.hpp"

namespace ftid::logio {
struct LogData;
}
namespace ftid::model {
class RobotKinematics;
}

namespace ftid::identify {

using effects::SampleContext;

struct ContextOptions {
  Mat3 R_FS = Mat3::Identity();   ///< sensor mount X_FS (orientation of S in the flange F)
  Vec3 p_FS_F = Vec3::Zero();     ///< sensor mount (position of the S origin in F) [m]
  double tilt_u_rad = 0.0;        ///< tilt used to fill g_S (the fitter recomputes g_S itself)
  double tilt_v_rad = 0.0;
};

/// The contexts of one log. Owns the row-major copy of the extra columns that
/// SampleContext::extra points into and the names SampleContext::extra_names points to; copying
/// and moving re-point the samples to the new owner.
struct ContextSet {
  std::string source;                    ///< log file (for messages)
  double t_origin = 0.0;                 ///< log t of the first sample (SampleContext::t is relative)
  std::vector<SampleContext> samples;
  std::vector<std::string> extra_names;  ///< names of the extra columns, in order
  std::vector<double> extra_rows;        ///< extra_rows[i * extra_names.size() + k]
  bool has_imu = false;
  bool has_temp = false;

  ContextSet() = default;
  ContextSet(const ContextSet& other);
  ContextSet& operator=(const ContextSet& other);
  ContextSet(ContextSet&& other) noexcept;
  ContextSet& operator=(ContextSet&& other) noexcept;
  ~ContextSet() = default;

  /// Index of an extra column by name, or -1.
  int extraIndex(const std::string& name) const;
  std::size_t size() const { return samples.size(); }
  /// Points every SampleContext::extra at its row of extra_rows and extra_names at extra_names
  /// (after editing either; nullptr when there are no extra columns).
  void repoint();
};

/// Builds contexts for every sample of the log. Throws DataError (naming the log) if the log has
/// no wrench columns or no samples.
ContextSet buildContexts(const logio::LogData& log, const model::RobotKinematics& kinematics,
                         const ContextOptions& options = {});

/// Sets g_S = R_BS^T g_B(U, V) in every context.
void setTilt(std::vector<SampleContext>& contexts, double tilt_u_rad, double tilt_v_rad);

}  // namespace ftid::identify
