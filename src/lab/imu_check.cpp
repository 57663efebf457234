// The laboratory's look at the sensor's IMU (imu_check.hpp).
#include "imu_check.hpp"

#include <limits>
#include <optional>
#include <string>

#include "ftid/common/error.hpp"
#include "ftid/effects/model.hpp"
#include "ftid/effects/nonlinear.hpp"
#include "ftid/identify/imu_fusion.hpp"
#include "lab_internal.hpp"

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

/// The delay comparison when the dynamics check judged the model's delay against the IMU's: the
/// rule's verdict (dynamics.hpp, DelayAgainstLag), not a chi-square beside it.
identify::ImuComparison lagComparison(const DynamicsCheck::DelayAgainstLag& lag) {
  identify::ImuComparison c;
  c.quantity = "delay";
  c.chi2 = c.limit = std::numeric_limits<double>::quiet_NaN();
  c.disagrees = !lag.delay_is_lag;
  c.message = "delay: IMU stream " + fmt(1e3 * lag.imu_delay_s, 3) + " ms, the model's " +
              fmt(1e3 * lag.model_delay_s, 3) + " ms with the reading's " + lag.held_effect + " (lag " +
              fmt(1e3 * lag.held_lag_s, 3) + " ms at the IMU's delay): a different wrench delay is " +
              (lag.delay_is_lag ? "not " : "") + "taken by the rule (family-wise p = " + fmt(lag.family_p, 2) +
              "; dynamics of the reading)";
  return c;
}

}  // namespace

void estimateImu(const std::vector<SampleContext>& fit, AnalysisResult* result) {
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
}

void checkImu(const ModelReport& last, const std::string& missing, AnalysisResult* result) {
  identify::ImuReport& imu = result->imu;
  if (!imu.used) return;
  const DynamicsCheck::DelayAgainstLag& lag = result->dynamics.delay;
  imu.comparisons = identify::compareImuMountAndDelay(mountOf(last), delayOf(last), imu.estimate.gyro);
  if (lag.imu_compared) {
    for (auto& c : imu.comparisons) {
      if (c.quantity == "delay") c = lagComparison(lag);
    }
  }
  const ParamEstimate* u = findParam(last, "tilt_u");
  const ParamEstimate* v = findParam(last, "tilt_v");
  if (last.tilt_estimated && u != nullptr && v != nullptr) {
    try {  // the laboratory's own model names parse; a name that did not would only skip this note
      imu.tilt_not_compared = identify::apparentTiltReason(effects::Model::fromName(last.model));
    } catch (const ConfigError&) {
      imu.tilt_not_compared.clear();
    }
    if (!result->change_points.empty()) {
      imu.tilt_not_compared = "tilt not compared: " + last.model +
                              " is fitted across the change in time above; compare it on each segment";
    }
    if (imu.tilt_not_compared.empty()) {
      imu.comparisons.push_back(identify::compareImuTilt(u->value, v->value, u->std, v->std, imu.estimate.acc));
    }
  }
  for (const auto& c : imu.comparisons) {
    if (!c.disagrees) continue;
    imu.warnings.push_back("the IMU and " + last.model + " disagree on the " + c.quantity + ": " + c.message);
    const std::string causes =
        missing.empty()
            ? "a set-up error: the sensor's mount or the robot model; an effect the model lacks that its " +
                  c.quantity + " absorbs; a contact; or a bad IMU"
            : "first " + last.model + " lacks " + missing + ", the missing effect this analysis names, which its " +
                  c.quantity + " may absorb: compare the model with it, as --explain does; else a set-up error: the "
                  "sensor's mount or the robot model; a contact; or a bad IMU";
    result->warnings.push_back(imu.warnings.back() + " (" + causes + ")");
  }
}

}  // namespace ftid::lab::detail
