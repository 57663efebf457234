#pragma once
// ftidd's output stage (docs/daemon.md "Output frame and filter"): the contact wrench of every
// cycle, expressed in the configured frame and optionally low-pass filtered, before it is
// published (compensated_wrench_t.output, output_frame).
//
//   sensor: w_out = contact_S (force in S, moment about the S origin)
//   tool:   the tool frame T at X_ST (config output.tool_xyz / tool_rpy, in S):
//             f_T = R_ST^T f_S,   t_T = R_ST^T (t_S - p_ST_S x f_S)   (moment about the T origin)
//   base:   f_B = R_BS f_S,       t_B = R_BS t_S                       (moment about the S origin,
//                                                                      axes of the robot base B)
//   low-pass (lowpass_hz > 0): per axis a 2nd-order Butterworth, bilinear transform with the
//   cut-off pre-warped (|H| = 1/sqrt(2) exactly at lowpass_hz), unity DC gain, run at the robot
//   rate. It filters the wrench in the output frame. An invalid cycle outputs zero and resets the
//   filter; the next valid cycle starts it at that cycle's value (no start-up transient).
//
// process() is noexcept and allocation-free (test/rt_safety/rt_output_stage_test.cpp).
#include <array>
#include <cstdint>
#include <string>

#include "ftid/common/types.hpp"

namespace ftid::daemon {

enum class OutputFrame : std::int8_t { kSensor = 0, kTool = 1, kBase = 2 };

/// "sensor", "tool", "base" (the config values and names in messages).
const char* toString(OutputFrame frame) noexcept;
/// Throws ConfigError naming the value if it is none of the above.
OutputFrame parseOutputFrame(const std::string& text);

struct OutputStageConfig {
  OutputFrame frame = OutputFrame::kSensor;
  Mat3 R_ST = Mat3::Identity();  ///< tool frame orientation in S (frame tool)
  Vec3 p_ST_S = Vec3::Zero();    ///< tool frame origin in S [m] (frame tool)
  double lowpass_hz = 0.0;       ///< 0 = no filter
  double sample_rate_hz = 125.0; ///< the loop rate (robot RTDE frequency)
};

class OutputStage {
 public:
  /// Set-up: throws ConfigError if lowpass_hz is not 0 or in (0, 0.45 sample_rate_hz).
  explicit OutputStage(const OutputStageConfig& config = {});

  /// One cycle: the contact wrench (in S) in the output frame, filtered. R_BS is the sensor
  /// orientation of this cycle (used by frame base). Returns zero and resets if !valid.
  Wrench process(const Wrench& contact_S, const Mat3& R_BS, bool valid) noexcept;
  void reset() noexcept { primed_ = false; }

  OutputFrame frame() const noexcept { return config_.frame; }
  const OutputStageConfig& config() const noexcept { return config_; }

 private:
  Wrench toFrame(const Wrench& w_S, const Mat3& R_BS) const noexcept;

  OutputStageConfig config_;
  bool filter_ = false;
  double b0_ = 1, b1_ = 0, b2_ = 0, a1_ = 0, a2_ = 0;  // y = b0 x + s1; s1 = b1 x - a1 y + s2; s2 = b2 x - a2 y
  Wrench s1_ = Wrench::Zero();
  Wrench s2_ = Wrench::Zero();
  bool primed_ = false;
};

}  // namespace ftid::daemon
