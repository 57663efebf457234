// The laboratory's look at the sensor's IMU (imu_check.hpp).
#include "imu_check.hpp"

#include <optional>
#include <string>

#include "ftid/common/error.hpp"
#include "ftid/effects/model.hpp"
#include "ftid/effects/nonlinear.hpp"
#include "ftid/identify/imu_fusion.hpp"

namespace ftid::lab::detail {

namespace {

const ParamEstimate* findParam(const ModelReport& m, const std::string& name) {
  for (const auto& p : m.params) {
    if (p.name == name) return &p;
  }
  return nullptr;
}

/// The last model's sensor mount (roll, pitch, yaw with standard errors), if it fits `mounting`.
std::optional<identify::MountEstimate> mountOf(const ModelReport& m) {
  identify::MountEstimate e;
  for (int k = 0; k < 3; ++k) {
    const ParamEstimate* p = findParam(m, effects::kMountParamNames[k]);
    if (p == nullptr) return std::nullopt;
    e.rpy_rad(k) = p->value;
    e.rpy_std(k) = p->std;
  }
  return e;
}

std::optional<identify::DelayEstimate> delayOf(const ModelReport& m) {
  const ParamEstimate* p = findParam(m, effects::kDelayParamName);
  if (p == nullptr) return std::nullopt;
  return identify::DelayEstimate{p->value, p->std};
}

}  // namespace

void checkImu(const std::vector<SampleContext>& fit, const ModelReport& last, AnalysisResult* result) {
  identify::ImuReport& imu = result->imu;
  imu = identify::ImuReport{};
  if (fit.empty() || !fit.front().has_imu) {
    imu.not_used_reason = "the log has no IMU columns (ax..alz)";
    return;
  }
  try {
    imu.estimate = identify::estimateImu(fit);
  } catch (const Error& e) {
    imu.not_used_reason = e.what();
    return;
  }
  imu.used = true;
  imu.comparisons = identify::compareImuMountAndDelay(mountOf(last), delayOf(last), imu.estimate.gyro);
  const ParamEstimate* u = findParam(last, "tilt_u");
  const ParamEstimate* v = findParam(last, "tilt_v");
  if (last.tilt_estimated && u != nullptr && v != nullptr) {
    try {  // the laboratory's own model names parse; a name that did not would only skip this note
      imu.tilt_not_compared = identify::apparentTiltReason(effects::Model::fromName(last.model));
    } catch (const ConfigError&) {
      imu.tilt_not_compared.clear();
    }
    if (imu.tilt_not_compared.empty()) {
      imu.comparisons.push_back(identify::compareImuTilt(u->value, v->value, u->std, v->std, imu.estimate.acc));
    }
  }
  for (const auto& c : imu.comparisons) {
    if (!c.disagrees) continue;
    imu.warnings.push_back("the IMU and " + last.model + " disagree on the " + c.quantity + ": " + c.message);
    result->warnings.push_back(imu.warnings.back() +
                               " (a set-up error: the sensor's mount or the robot model; an effect the model lacks "
                               "that its " + c.quantity + " absorbs; a contact; or a bad IMU)");
  }
}

}  // namespace ftid::lab::detail
