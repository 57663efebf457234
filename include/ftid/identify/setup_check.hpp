#pragma once
// Set-up diagnosis before fitting (docs/identification.md, "Set-up diagnosis"). A log read with the
// wrong set-up still gives confident numbers (issue 21: a base-frame wrench read as sensor-frame
// gave mass 0.027 kg; a sensor mounted 90 deg about z gave 0.53 kg for 0.90). Before the fit, the
// gravity model (`paper`, tilt searched) is fitted to a subsample of the data under the set-up as
// given and under each alternative:
//   - the wrench columns in the other frame (`--wrench-frame base` / `sensor`),
//   - the sensor mounted rotated by each of the 23 other axis-aligned rotations (`--mount-rpy`),
//   - a column-level error: one of fx..tz with its sign reversed, or two axes' force and torque
//     columns swapped (reflections, which no mount gives: the fix is to the log or the sensor),
// and compared by the residual energy relative to the signal's (|f|^2 and |t|^2, unchanged by any
// rotation of the wrench). An alternative that leaves less than kSetupBetterRatio of the given
// set-up's residual explains the data: one line says so, with the fix. Joint angles beyond 2 pi
// (degrees in an angle column) are said as well.
#include <string>
#include <vector>

#include "ftid/common/types.hpp"
#include "ftid/samples/context.hpp"

namespace ftid::identify {

using effects::SampleContext;

/// An alternative explains the data when its relative residual is below this fraction of the given one's.
inline constexpr double kSetupBetterRatio = 0.25;
/// ... and the given set-up leaves at least this fraction of the signal's energy unexplained.
inline constexpr double kSetupMinResidual = 0.01;
/// Samples used by the diagnosis (evenly spaced; the fits are of the gravity model only).
inline constexpr int kSetupMaxSamples = 1500;

struct SetupDiagnosis {
  double given_residual = 0.0;   ///< relative residual energy of `paper` under the set-up as given
  double best_residual = 0.0;    ///< the best alternative's
  std::string best;              ///< the best alternative, in words ("" if none was tried)
  std::string fix;               ///< its fix: a command-line option ("--wrench-frame base", "--mount-rpy 0,0,1.5708")
                                 ///< or what to change in the log ("negate the fz column ...")
  bool explains = false;         ///< the best alternative explains the data (the rule above)
  std::vector<std::string> lines;  ///< one line each: "set-up: ..." (empty when nothing is found)
};

/// Diagnoses `ctx` (built with `given`: its mount R_FS and wrench frame). Never throws for data it
/// cannot fit (an alternative that cannot be fitted is skipped); empty lines when there is no
/// motion or gravity signal to judge.
/// `try_mounts` false (a model that fits the `mounting` rotation itself): no rotated mounts.
SetupDiagnosis diagnoseSetup(const std::vector<SampleContext>& ctx, const samples::ContextOptions& given,
                             bool try_mounts = true);

/// The axis-aligned rotation R_SM (of the 24) under which the gravity model fits `ctx` best, the
/// reading taken in the rotated frame M (w_S = R_SM w_M): the start of the `mounting` effect's fit.
/// Identity if none fits (or ctx has fewer than 20 samples).
Mat3 bestAxisAlignedMount(const std::vector<SampleContext>& ctx);

/// The 24 rotations that map the coordinate axes onto coordinate axes (proper, det +1); [0] = identity.
std::vector<Mat3> axisAlignedRotations();

/// Roll, pitch, yaw of R = Rz(yaw) Ry(pitch) Rx(roll) (pitch in [-pi/2, pi/2]).
Vec3 rpyOf(const Mat3& R);
/// R = Rz(yaw) Ry(pitch) Rx(roll).
Mat3 rotationFromRpy(const Vec3& rpy_rad);
/// Parses "R,P,Y" (three finite numbers [rad], |each| <= 2 pi); throws ConfigError naming `what`.
Vec3 parseRpy(const std::string& text, const std::string& what = "--mount-rpy");

}  // namespace ftid::identify
