#pragma once
// Saturation and clipping of the wrench readings (docs/analyze.md, "Saturation"): samples at a
// range limit of the sensor, found per axis before any fit and left out of every fit and held-out
// sum by the one robust data treatment (robust_data.hpp), as glitches are.
//
// Two ways a sample is at a limit:
//  - a flat top: the axis' extreme value (its maximum or its minimum) is shared by more samples
//    than a continuous, noisy reading can share it. The rule (flatTopPValue): the readings near
//    an extreme are the tail of a continuous distribution, so the extreme level holds no more
//    fresh readings than the next level just inside it, up to chance: its count c_top among the
//    c_top + c_next readings of the two levels is at most Binomial(c_top + c_next, 1/2). A clip
//    piles every reading beyond the limit onto one level. An axis is called clipped at an extreme
//    when min(1, 12 p) < kSaturationAlpha (12 = 6 axes x 2 extremes, the family-wise correction
//    of the laboratory's rule). Levels are the distinct values up to kLevelTolerance of the axis'
//    span, so a quantised sensor's levels are its counts. A fresh reading is one whose six axes
//    are not all equal to the previous sample's: a repeated reading (sample-and-hold, a held pose
//    read by a noise-free or coarsely quantised sensor) counts once, since a clipped axis is flat
//    while the other axes keep changing.
//  - a configured rated range (`--rated-range fz=120,tz=10`): |reading| >= limit.
#include <string>
#include <vector>

#include "ftid/common/types.hpp"
#include "ftid/samples/context.hpp"

namespace ftid::identify {

using effects::SampleContext;

/// Family-wise level of the flat-top test (the laboratory's default family_alpha).
inline constexpr double kSaturationAlpha = 1e-3;
/// Values of an axis closer than this fraction of its span are one level (float rounding of a
/// sensor's counts; far below any sensor's resolution).
inline constexpr double kLevelTolerance = 1e-9;
/// Times listed per axis and extreme (the count says how many there are).
inline constexpr int kMaxSaturationTimes = 10;

struct SaturationOptions {
  /// The sensor's rated range per axis fx..tz [N, Nm] (symmetric: |reading| >= limit is
  /// saturated); 0 = not given.
  Vec6 rated_range = Vec6::Zero();
  bool flat_tops = true;  ///< look for flat tops (off: only the rated range)
};

/// Parses `--rated-range`: comma-separated `axis=limit` with axis fx, fy, fz, tx, ty, tz and a
/// positive limit in N / Nm, e.g. "fz=120,tx=10". Throws ConfigError naming the bad key or value.
Vec6 parseRatedRange(const std::string& text);

/// One axis at one extreme.
struct SaturatedAxis {
  int axis = 0;            ///< 0..5 = fx..tz
  int side = 1;            ///< +1: at the maximum, -1: at the minimum
  double value = 0.0;      ///< the flat top's level, else the signed rated limit [N, Nm]
  bool flat_top = false;   ///< found as a flat top
  bool rated = false;      ///< at or beyond the rated range
  int count = 0;           ///< samples at the limit
  double fraction = 0.0;   ///< count / all samples
  double family_p = 1.0;   ///< min(1, 12 p) of the flat-top test (1 when not a flat top)
  std::vector<double> times;  ///< [s] of the first kMaxSaturationTimes samples (SampleContext::t)
};

struct Saturation {
  std::vector<SaturatedAxis> axes;  ///< one entry per axis and extreme at a limit
  std::vector<int> samples;         ///< every saturated sample, ascending
  int n = 0;                        ///< samples looked at
};

/// p-value of c_top readings on the extreme level against c_next on the next level inside it:
/// P(X >= c_top), X ~ Binomial(c_top + c_next, 1/2).
double flatTopPValue(int c_top, int c_next);

/// The saturated samples of the readings (wrench_S of every context, in time order).
Saturation findSaturation(const std::vector<SampleContext>& ctx, const SaturationOptions& options = {});

/// One line per axis in words, e.g. "fz saturates at 118.3 N on 37 samples (3.0 %) — left out of
/// the fit; check the sensor's range or the tool load".
std::string saturationLine(const SaturatedAxis& s);

/// JSON array text (ftid/fileio/json_text.hpp policy), one object per entry: axis ("fz"), side
/// ("max" or "min"), value, count, fraction, times (the first kMaxSaturationTimes), source
/// ("flat_top", "rated_range" or "flat_top+rated_range"), family_p.
std::string saturationJson(const std::vector<SaturatedAxis>& axes);

}  // namespace ftid::identify
