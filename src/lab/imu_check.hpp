#pragma once
// The laboratory's look at the sensor's IMU (issue 23; docs/analyze.md "The IMU"). Private to ftid_lab.
#include <string>
#include <vector>

#include "ftid/lab/analyze.hpp"

namespace ftid::lab::detail {

/// The IMU against the kinematics (identify::estimateImu on the fitting contexts: the gyro's frame,
/// bias and delay; the accelerometer's tilt and bias), payload-free. Fills result->imu's estimate;
/// a log without the IMU columns, or a motion that cannot determine the gyro's frame, is said in
/// imu.not_used_reason.
void estimateImu(const std::vector<SampleContext>& fit, AnalysisResult* result);

/// The IMU's estimate against `last`, the last model: its `mounting` and `sensor_delay` (or,
/// without them, the configured frame and no delay) and its tilt when it estimates one
/// (identify::compareImuMountAndDelay, compareImuTilt: the 0.999 chi-square quantile of each).
/// A delay the dynamics check judged against the IMU (result->dynamics.delay) is that judgement's
/// verdict instead: one rule, no second test. Each disagreement is also a warning; `missing`, the
/// effect the analysis recommends adding to `last` ("" when none), is named in it as the first cause.
void checkImu(const ModelReport& last, const std::string& missing, AnalysisResult* result);

}  // namespace ftid::lab::detail
