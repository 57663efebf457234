#include "ftid/daemon/output_stage.hpp"

#include <cmath>

#include "ftid/common/error.hpp"

namespace ftid::daemon {

const char* toString(OutputFrame frame) noexcept {
  switch (frame) {
    case OutputFrame::kSensor: return "sensor";
    case OutputFrame::kTool: return "tool";
    case OutputFrame::kBase: return "base";
  }
  return "?";
}

OutputFrame parseOutputFrame(const std::string& text) {
  if (text == "sensor") return OutputFrame::kSensor;
  if (text == "tool") return OutputFrame::kTool;
  if (text == "base") return OutputFrame::kBase;
  throw ConfigError("output frame must be 'sensor', 'tool' or 'base', not '" + text + "'");
}

OutputStage::OutputStage(const OutputStageConfig& config) : config_(config) {
  if (!(config.sample_rate_hz > 0.0) || !std::isfinite(config.sample_rate_hz)) {
    throw ConfigError("output stage: the sample rate must be positive");
  }
  if (!(config.lowpass_hz >= 0.0) || !(config.lowpass_hz < 0.45 * config.sample_rate_hz)) {
    throw ConfigError("output.lowpass_hz must be 0 (off) or below 0.45 x the robot rate (" +
                      std::to_string(0.45 * config.sample_rate_hz) + " Hz)");
  }
  filter_ = config.lowpass_hz > 0.0;
  if (filter_) {
    // Analog prototype H(s) = wc^2 / (s^2 + sqrt(2) wc s + wc^2), s = K (z - 1) / (z + 1) with
    // K = wc / tan(wc T / 2) (pre-warped so that the cut-off maps exactly).
    const double T = 1.0 / config.sample_rate_hz;
    const double wc = 2.0 * M_PI * config.lowpass_hz;
    const double k = wc / std::tan(wc * T / 2.0);
    const double k2 = k * k, wc2 = wc * wc, r2 = std::sqrt(2.0) * wc * k;
    const double a0 = k2 + r2 + wc2;
    b0_ = wc2 / a0;
    b1_ = 2.0 * wc2 / a0;
    b2_ = wc2 / a0;
    a1_ = 2.0 * (wc2 - k2) / a0;
    a2_ = (k2 - r2 + wc2) / a0;
  }
}

Wrench OutputStage::toFrame(const Wrench& w, const Mat3& R_BS) const noexcept {
  Wrench out;
  switch (config_.frame) {
    case OutputFrame::kSensor:
      out = w;
      break;
    case OutputFrame::kTool: {
      const Vec3 f = w.head<3>();
      const Vec3 t = w.tail<3>() - config_.p_ST_S.cross(f);
      out.head<3>() = config_.R_ST.transpose() * f;
      out.tail<3>() = config_.R_ST.transpose() * t;
      break;
    }
    case OutputFrame::kBase:
      out.head<3>() = R_BS * w.head<3>();
      out.tail<3>() = R_BS * w.tail<3>();
      break;
  }
  return out;
}

Wrench OutputStage::process(const Wrench& contact_S, const Mat3& R_BS, bool valid) noexcept {
  if (!valid) {
    primed_ = false;
    return Wrench::Zero();
  }
  const Wrench x = toFrame(contact_S, R_BS);
  if (!filter_) return x;
  if (!primed_) {
    // Steady state for a constant input x: y = x, s1 = x - b0 x, s2 = b2 x - a2 x.
    s1_ = (1.0 - b0_) * x;
    s2_ = (b2_ - a2_) * x;
    primed_ = true;
  }
  const Wrench y = b0_ * x + s1_;
  s1_ = b1_ * x - a1_ * y + s2_;
  s2_ = b2_ * x - a2_ * y;
  return y;
}

}  // namespace ftid::daemon
