#pragma once
// Multi-start of the nonlinear search (docs/identification.md, "Several starts"): the tilt search
// of fitModel starts from the paper's force stage, which on a short or weakly excited run can lie
// in the basin of a wrong minimum (the 1 s run: mass 2.2 kg, tilt V 196 deg, held-out
// residual 6x the noise). fitModelMultiStart also starts from a level base (0, 0) and keeps the
// fit with the smallest residual, weighted per axis by the smallest RMS any start reached. Angles
// are returned in their principal range (-pi, pi] (tilt U, V; mounting roll, yaw) with the pitch in
// [-pi/2, pi/2] (the same rotation).
#include <string>
#include <vector>

#include "ftid/identify/fit.hpp"

namespace ftid::identify {

/// Starts that ended in different minima with nearly the same residual (relative difference below
/// this) leave the tilt undecided: said in a note.
inline constexpr double kAmbiguousCostRatio = 0.05;

struct MultiStartFit {
  FitResult fit;                   ///< the best start's fit
  int starts = 0;                  ///< starts tried
  std::vector<std::string> notes;  ///< one line each: a better minimum found, an undecided tilt
};

/// fitModel (all contexts) from the default start and from a level base; options.tilt_* given: one
/// fit from there. Throws what fitModel throws if no start can be fitted.
MultiStartFit fitModelMultiStart(const Model& model, const std::vector<SampleContext>& contexts,
                                 const FitOptions& options = {});

/// An angle in (-pi, pi].
double wrapAngle(double rad);
/// Roll, pitch, yaw (R = Rz(yaw) Ry(pitch) Rx(roll)) of the same rotation with roll, yaw in
/// (-pi, pi] and pitch in [-pi/2, pi/2].
Vec3 canonicalRpy(const Vec3& rpy_rad);
/// The fit's angles in their principal range (tilt_u/v wrapped, mount_rpy canonical).
void wrapAngles(FitResult& fit);

}  // namespace ftid::identify
