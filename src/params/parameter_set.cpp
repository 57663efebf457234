// The parameter vector of a model from a parameter set (parameter files themselves:
// parameter_file.cpp; sets from fits: identify/fit_parameters.cpp).
#include "ftid/params/parameter_set.hpp"

#include "ftid/common/error.hpp"
#include "ftid/effects/model.hpp"
#include "ftid/effects/nonlinear.hpp"

namespace ftid::params {

Eigen::VectorXd thetaFor(const effects::Model& model, const ParameterSet& set, const std::string& source) {
  const auto& names = model.paramIndex().names();
  Eigen::VectorXd theta(static_cast<Eigen::Index>(names.size()));
  for (std::size_t j = 0; j < names.size(); ++j) {
    const NamedValue* p = nullptr;
    for (const auto& q : set.params) {
      if (q.name == names[j]) p = &q;
    }
    if (p == nullptr) {
      throw ConfigError(source + ": key 'parameters." + names[j] + "' is missing (model '" +
                        model.name() + "' needs it)");
    }
    theta(static_cast<Eigen::Index>(j)) = p->value;
  }
  return theta;
}

Vec6 imuBiasesOf(const ParameterSet& set) {
  Vec6 b = Vec6::Zero();
  for (const auto& v : set.imu) {
    for (int k = 0; k < 6; ++k) {
      if (v.name == kImuBiasNames[k]) b(k) = v.value;
    }
  }
  return b;
}

effects::NonlinearParams nonlinearFor(const effects::Model& model, const ParameterSet& set,
                                      const std::string& source) {
  effects::NonlinearParams nl;
  nl.tilt_u_rad = set.tilt_u_rad;
  nl.tilt_v_rad = set.tilt_v_rad;
  auto need = [&](const char* name) {
    for (const auto& q : set.params) {
      if (q.name == name) {
        if (!std::isfinite(q.value)) throw ConfigError(source + ": key 'parameters." + name + "' is not finite");
        return q.value;
      }
    }
    throw ConfigError(source + ": key 'parameters." + name + "' is missing (model '" + model.name() +
                      "' needs it)");
  };
  if (model.estimatesMounting()) {
    for (int k = 0; k < 3; ++k) nl.mount_rpy_rad(k) = need(effects::kMountParamNames[k]);
  }
  if (model.estimatesDelay()) nl.delay_s = need(effects::kDelayParamName);
  return nl;
}

}  // namespace ftid::params
