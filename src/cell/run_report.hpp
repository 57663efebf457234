#pragma once
// The text of an identification run (`ftid --identify`, src/cell/cell_identify.cpp): the design's
// expected accuracy before the motion, and the held-out residual per axis after it.
#include <string>

#include "ftid/common/types.hpp"
#include "ftid/trajectory/trajectory_io.hpp"

namespace ftid::cell::internal {

/// Fixed-point number with `decimals` digits.
std::string fmt(int decimals, double v);

/// What the trajectory's design predicts for the accuracy (its predicted standard errors at the
/// design's noise), printed before the robot moves.
std::string expectedAccuracy(const trajectory::TrajectoryFile& f, const std::string& model_name);

/// The held-out residual per axis against the noise floor, axes above identify::kAboveFloorMark
/// marked "<- above noise".
std::string axisTable(const Vec6& heldout, const Vec6& noise, const Vec6& raw);

/// The axes axisTable marks, e.g. "fx 6.04x, fz 11.47x"; "" when none.
std::string axesAboveFloor(const Vec6& heldout, const Vec6& noise);

}  // namespace ftid::cell::internal
