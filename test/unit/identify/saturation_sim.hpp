#pragma once
// Test helpers for saturation (include/ftid/identify/saturation.hpp): a simulated log's readings
// as contexts (the detector reads only t and wrench_S), a sensor's clip and its quantisation
// applied to the logged wrench after the simulation (the sensor's physics, not ftid's model).
#include <algorithm>
#include <cmath>
#include <vector>

#include "ftid/logio/log.hpp"
#include "ftid/samples/context.hpp"

namespace ftid::satsim {

/// The readings of a log (t and wrench_S only).
inline std::vector<effects::SampleContext> readings(const logio::LogData& log) {
  std::vector<effects::SampleContext> ctx(log.samples.size());
  for (std::size_t i = 0; i < ctx.size(); ++i) {
    ctx[i].t = log.samples[i].t;
    ctx[i].wrench_S = log.samples[i].wrench_S;
  }
  return ctx;
}

struct Clip {
  double limit = 0.0;  ///< the clip level
  int count = 0;       ///< samples whose true reading was at or above it (now at it)
};

/// Clips `axis` of every reading at a round level (a multiple of `step`: 0.1 N, or a quantised
/// sensor's count) below which about 1 - fraction of the samples lie: the readings at or above it
/// read the level itself.
inline Clip clipAxis(logio::LogData& log, int axis, double fraction, double step = 0.1) {
  std::vector<double> v;
  for (const auto& s : log.samples) v.push_back(s.wrench_S(axis));
  std::sort(v.begin(), v.end());
  const auto k = static_cast<std::size_t>(std::floor((1.0 - fraction) * static_cast<double>(v.size())));
  Clip clip;
  clip.limit = std::round(v[std::min(k, v.size() - 1)] / step) * step;
  for (auto& s : log.samples) {
    if (s.wrench_S(axis) >= clip.limit) {
      s.wrench_S(axis) = clip.limit;
      ++clip.count;
    }
  }
  return clip;
}

/// Rounds every wrench axis to the sensor's resolution (e.g. 1/32 N and 1/1000 Nm).
inline void quantise(logio::LogData& log, double force_step, double torque_step) {
  for (auto& s : log.samples) {
    for (int a = 0; a < 6; ++a) {
      const double q = a < 3 ? force_step : torque_step;
      s.wrench_S(a) = std::round(s.wrench_S(a) / q) * q;
    }
  }
}

}  // namespace ftid::satsim
