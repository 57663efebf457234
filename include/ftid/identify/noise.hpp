#pragma once
// The sensor noise floor from the data that is there (docs/identification.md, "The noise floor").
// Detected automatically, in this order:
//
//   static pose set, repeated readings  (a `pose` column, or the robot at rest: |qd| ~ 0, and runs
//                                        of consecutive samples at the same q): the spread of the
//                                        readings within each pose ("static_poses")
//   static pose set, one reading a pose  no noise estimate is possible ("not_observable"): callers
//                                        use the cross-validated residual as the scale and say so
//   dense time series                    the high-frequency content of each channel: robust (MAD)
//                                        spread of 4th-order differences ("white", today's
//                                        estimator); low-pass filtered noise (AR(1), lag-1
//                                        correlation phi): phi and the level from the spectrum of
//                                        a model residual above the motion's band, where the
//                                        spectrum is the noise's (refineNoiseFloor) ("coloured")
//   --noise fx=..,..,tz=..               the sensor's data sheet ("data_sheet")
//
// Smooth motion (a few Hz at >= 100 Hz sampling) is suppressed in the differences by
// (2 pi f s dt)^4, so the estimate is taken from the readings themselves, before any model is fitted.
#include <string>
#include <utility>
#include <vector>

#include "ftid/common/types.hpp"
#include "ftid/effects/effect.hpp"

namespace ftid::identify {

using effects::SampleContext;

enum class NoiseMethod { kWhite, kColoured, kStaticPoses, kNotObservable, kDataSheet };

/// "white", "coloured", "static_poses", "not_observable", "data_sheet" (the JSON noise_method).
std::string toString(NoiseMethod method);

/// An axis whose held-out residual RMS is above this multiple of its noise floor is marked in
/// every report ("<- model fails here", "<- above", the warnings that the model misses something)
/// and opens the laboratory's search for the reading's dynamics. A display mark, not a
/// significance test: the lab's verdicts rest on its one rule (docs/analyze.md, "The verdict").
inline constexpr double kAboveFloorMark = 1.2;

struct NoiseFloor {
  NoiseMethod method = NoiseMethod::kWhite;
  Vec6 std = Vec6::Zero();        ///< marginal noise std per axis [N, Nm] (0: not observable)
  Vec6 ar1 = Vec6::Zero();        ///< lag-1 correlation of the noise per axis (0 = white)
  /// Standard error of ar1 where it was fitted to a spectrum (refineNoiseFloor; 0 otherwise).
  Vec6 ar1_std = Vec6::Zero();
  int pose_groups = 0;            ///< static data: number of poses found
  Vec6 difference_std = Vec6::Zero();  ///< dense data: the stride-1 4th-difference estimate
  std::string detail;             ///< how it was estimated, in words (one line)

  bool observable() const { return method != NoiseMethod::kNotObservable; }
  /// White-equivalent innovation std: std * sqrt(1 - ar1^2) (the whitened residual's scale).
  Vec6 innovationStd() const;
};

/// Noise of one channel from the 4th-order differences at stride s:
/// 1.4826 MAD(x_i - 4 x_{i+s} + 6 x_{i+2s} - 4 x_{i+3s} + x_{i+4s}) / sqrt(70). Needs 4 s + 4
/// samples (DataError otherwise).
double differenceNoiseStd(const std::vector<double>& x, int stride = 1);

/// AR(1) noise of one channel (marginal std, lag-1 correlation in [0, 0.995]) from the
/// differences at strides 1..3 of the given segments (each a run of consecutive samples; segments
/// shorter than 13 samples are skipped). Throws DataError if fewer than 16 differences remain.
struct Ar1Noise {
  double std = 0.0;
  double phi = 0.0;
};
Ar1Noise estimateAr1Noise(const std::vector<std::vector<double>>& segments);

/// Ratio of the variance of the stride-s 4th difference of AR(1) noise to the marginal variance.
double differenceVarianceFactor(double phi, int stride);

/// Runs [begin, end) of consecutive samples at the same pose: by the extra column `pose` when
/// present, else (static data only: median |qd| below 1e-3 rad/s) by q (within 1e-4 rad); for a
/// pose log (no joint angles) by the sensor pose the same way (its rotation angle plus displacement
/// per sample: median speed below 1e-3, within 1e-4 per sample).
/// Empty when the data are a moving time series. *is_static tells which.
std::vector<std::pair<int, int>> poseGroups(const std::vector<SampleContext>& ctx, bool* is_static);

/// Moving samples (some |qd| at or above poseGroups' 1e-3 rad/s) that make a log a motion: the 20
/// per held-out block that foldBoundaries shares out, for identify's 5 blocks.
inline constexpr long kMinMovingSamples = 100;

/// The robot holds still: a static pose set (poseGroups: the median |qd|) with fewer than
/// kMinMovingSamples moving samples, so that neither a long rest after an excitation (a time
/// series, however long the rest) nor a few noisy velocity readings at rest decide it; pose logs
/// (no joint angles) by poseGroups alone. What needs motion is refused or left out only then: the
/// default model's inertia (`ftid identify` fits `paper`), a sensor_delay.
bool holdsStill(const std::vector<SampleContext>& ctx);

/// The k-fold held-out blocks of a log (identify's checkFit and `ftid analyze`): `folds` contiguous
/// blocks, returned as folds + 1 boundaries from 0 to ctx.size(). Each block holds an equal share
/// of the moving samples (some |qd| at or above poseGroups' 1e-3 rad/s) and a rest lies in the
/// block it falls in, so that a recording that moves and then rests does not put its whole motion
/// in one block (whose fold would then be trained on a rest and fail to predict it). Equal numbers
/// of samples when every sample moves (the same blocks), when fewer than 20 x folds samples move, or
/// for a pose log (no joint angles). Identity: every block has at least floor(m / folds) moving
/// samples, m the moving samples of the log.
std::vector<int> foldBoundaries(const std::vector<SampleContext>& ctx, int folds);

/// Detects the method and estimates the floor of the wrench readings. For dense data this is
/// preliminary: the colour is only weakly determined by the readings alone (smooth motion hides
/// the noise's low frequencies); refineNoiseFloor() settles it from a model residual.
NoiseFloor estimateNoiseFloor(const std::vector<SampleContext>& ctx);

/// Dense data (white/coloured; others unchanged): the noise's AR(1) model from a model residual
/// (6 x n, time order, segments by start index; ctx: the same samples, for the motion's band).
/// The residual's spectrum (Welch, Hann, 256-sample segments from 1024 samples on; shorter runs:
/// one Hann-tapered periodogram of the longest segment) is fitted above the motion's band (3x the
/// frequency below which 99.9 % of the joint-velocity power lies), where model error, made of the
/// motion, does not reach: S(w) = s_e^2 / (1 - 2 phi cos w + phi^2), by the Whittle likelihood.
/// phi is common to the six axes (one sensor filter) unless their own fits differ beyond chance
/// (likelihood ratio, chi-square(5) at 0.001); ar1_std is its standard error. phi < 0.2 counts as
/// white (std = the flat spectral level); else std = s_e / sqrt(1 - phi^2).
void refineNoiseFloor(NoiseFloor& floor, const Eigen::Matrix<double, 6, Eigen::Dynamic>& residual,
                      const std::vector<SampleContext>& ctx, const std::vector<int>& segment_starts = {});

/// Glitches: isolated samples whose residual stands out. Per axis, h = r minus its running median
/// over 7 samples (time series; inside each segment given by its start index) or minus the median
/// (pose sets: neighbours are different poses); flagged where |h| > threshold x 1.4826 MAD(h).
/// Smooth model error is removed by the running median, so only spikes are flagged.
struct Outliers {
  std::vector<int> samples;   ///< ascending
  std::vector<int> axes;      ///< the axis that stands out most, per sample
};
Outliers detectOutliers(const Eigen::Matrix<double, 6, Eigen::Dynamic>& residual, bool time_series, double threshold,
                        const std::vector<int>& segment_starts = {});

/// The data-sheet floor ("data_sheet"; white).
NoiseFloor dataSheetNoiseFloor(const Vec6& std);

/// Parses "fx=0.05,fy=0.05,fz=0.08,tx=0.002,ty=0.002,tz=0.003" (all six, each > 0). Throws
/// ConfigError naming `what` and the bad or missing key.
Vec6 parseNoiseSpec(const std::string& spec, const std::string& what = "--noise");

}  // namespace ftid::identify
