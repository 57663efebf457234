#pragma once
// Pieces of the noise floor shared by noise.cpp (the estimate from the readings) and
// noise_spectrum.cpp (refineNoiseFloor, from a model residual's spectrum). Private to ftid_identify.
#include <string>
#include <vector>

namespace ftid::identify::internal {

/// A lag-1 correlation below this counts as white: the stride-1 estimate is used unchanged.
inline constexpr double kColouredPhi = 0.2;

/// The AR(1) coefficient from the robust lag-1 correlation of the first differences inside each
/// segment, in [0, 0.99]; -1 if fewer than 16 pairs (noise.cpp).
double ar1FromDifferences(const std::vector<std::vector<double>>& segments);

/// The white-noise estimator of differenceNoiseStd over several segments (each differenced on its
/// own); `fallback` when they hold fewer than 16 differences.
double differenceStdOf(const std::vector<std::vector<double>>& segments, double fallback);

/// v with 3 significant digits, for the floor's detail text.
std::string fmt(double v);

}  // namespace ftid::identify::internal
