// Parameter sets from general fits (include/ftid/identify/fit_parameters.hpp).
#include "ftid/identify/fit_parameters.hpp"

#include "ftid/effects/nonlinear.hpp"
#include "ftid/identify/fit.hpp"

namespace ftid::identify {

ParameterSet toParameterSet(const FitResult& fit) {
  ParameterSet set;
  set.model = fit.model_name;
  for (std::size_t j = 0; j < fit.params.size(); ++j) {
    const auto e = static_cast<Eigen::Index>(j);
    set.params.push_back({fit.params[j].name, fit.theta(e), fit.theta_std(e), fit.params[j].unit});
  }
  for (const auto& d : fit.derived) set.derived.push_back({d.name, d.value, d.std, d.unit});
  set.tilt_estimated = fit.tilt_estimated;
  set.tilt_u_rad = fit.tilt_u_rad;
  set.tilt_v_rad = fit.tilt_v_rad;
  set.tilt_u_std = fit.tilt_u_std;
  set.tilt_v_std = fit.tilt_v_std;
  if (fit.mounting_estimated) {
    for (int k = 0; k < 3; ++k) {
      set.params.push_back({effects::kMountParamNames[k], fit.mount_rpy_rad(k), fit.mount_rpy_std(k), "rad"});
    }
  }
  if (fit.delay_estimated) set.params.push_back({effects::kDelayParamName, fit.delay_s, fit.delay_std, "s"});
  set.residual_rms = fit.residual_rms;
  set.condition_number = fit.condition_number;
  set.extras.push_back({"tilt_iterations", static_cast<double>(fit.tilt_iterations), 0.0, ""});
  set.extras.push_back({"residual_variance_weighted", fit.sigma2, 0.0, ""});
  set.provenance.method = "fit";
  set.provenance.n_samples = fit.n_samples;
  return set;
}

}  // namespace ftid::identify
