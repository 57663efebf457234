// Re-identification of a payload change (include/ftid/monitor/change_fit.hpp).
#include "ftid/monitor/change_fit.hpp"

#include <cmath>
#include <cstdio>

#include <Eigen/Cholesky>

#include "ftid/effects/model.hpp"
#include "ftid/effects/rigid_body.hpp"

namespace ftid::monitor {

namespace {

std::string number(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

bool freeMotion(const MonitorSample& s, const MonitorSettings& settings) {
  const double g = s.g_S.norm();
  const double turn = g > 0.0 ? s.w_S.cross(s.g_S).norm() / g : 0.0;
  return turn >= settings.free_motion_turn_rad_s || s.a_S.norm() >= settings.free_motion_acc_m_s2;
}

}  // namespace

ChangeFit fitChange(const std::vector<MonitorSample>& samples, const ChangeVector& before,
                    const MonitorSettings& settings, const ChangeFitOptions& options) {
  ChangeFit fit;
  fit.samples = static_cast<int>(samples.size());
  if (samples.empty()) {
    fit.reason = "no samples in the buffer (no valid cycle yet, or the window is empty)";
    return fit;
  }
  const effects::Model model = effects::Model::fromName("gravity+linear_inertia+rigid_body");
  static constexpr const char* kNames[kChangeParams] = {"mass",   "mass_com_x", "mass_com_y", "mass_com_z",
                                                        "i_s_xx", "i_s_yy",     "i_s_zz",     "i_s_xy",
                                                        "i_s_xz", "i_s_yz"};
  int columns[kChangeParams];
  for (int j = 0; j < kChangeParams; ++j) columns[j] = model.paramIndex().column(kNames[j]);
  Eigen::Matrix<double, 6, Eigen::Dynamic> y_work(6, model.numParams());
  const Vec6 w = settings.noise_std.cwiseAbs2().cwiseInverse();
  // Normal equations with the prior as regulariser: (P0^-1 + sum Y^T W Y) delta = sum Y^T W r.
  ChangeMatrix info = ChangeMatrix::Zero();
  ChangeVector rhs = ChangeVector::Zero();
  Eigen::Matrix<double, kChangeParams, 1> prior_std;
  prior_std << settings.prior_mass_std_kg, Vec3::Constant(settings.prior_mass_com_std_kg_m),
      Vec6::Constant(settings.prior_inertia_std_kg_m2);
  info.diagonal() = prior_std.cwiseAbs2().cwiseInverse();
  std::vector<Eigen::Matrix<double, 6, kChangeParams>> ys(samples.size());
  for (std::size_t k = 0; k < samples.size(); ++k) {
    const MonitorSample& s = samples[k];
    effects::SampleContext ctx;
    ctx.g_S = s.g_S;
    ctx.a_S = s.a_S;
    ctx.w_S = s.w_S;
    ctx.alpha_S = s.alpha_S;
    model.computeRegressor(ctx, y_work);
    for (int j = 0; j < kChangeParams; ++j) ys[k].col(j) = y_work.col(columns[j]);
    info.noalias() += ys[k].transpose() * w.asDiagonal() * ys[k];
    rhs.noalias() += ys[k].transpose() * w.asDiagonal() * s.residual_S;
    fit.free_samples += freeMotion(s, settings) ? 1 : 0;
    fit.residual_rms_before += s.residual_S.cwiseAbs2();
  }
  const Eigen::LLT<ChangeMatrix> llt(info);
  const ChangeVector delta = llt.solve(rhs);
  const ChangeMatrix cov = llt.solve(ChangeMatrix::Identity());
  for (std::size_t k = 0; k < samples.size(); ++k) {
    fit.residual_rms_after += (samples[k].residual_S - ys[k] * delta).cwiseAbs2();
  }
  const double n = static_cast<double>(samples.size());
  fit.residual_rms_before = (fit.residual_rms_before / n).cwiseSqrt();
  fit.residual_rms_after = (fit.residual_rms_after / n).cwiseSqrt();
  ChangeEstimate& c = fit.change;
  c.delta = delta;
  c.covariance = cov;
  c.delta_mass_kg = delta[0];
  c.delta_mass_std_kg = std::sqrt(cov(0, 0));
  for (int j = 0; j < 3; ++j) {
    c.delta_mass_com_kg_m[j] = delta[1 + j];
    c.delta_mass_com_std_kg_m[j] = std::sqrt(cov(1 + j, 1 + j));
    c.delta_com_m[j] = delta[1 + j] / delta[0];
    const double g0 = -delta[1 + j] / (delta[0] * delta[0]), g1 = 1.0 / delta[0];
    c.delta_com_std_m[j] = std::sqrt(std::max(0.0, g0 * g0 * cov(0, 0) + 2.0 * g0 * g1 * cov(0, 1 + j) +
                                                       g1 * g1 * cov(1 + j, 1 + j)));
  }
  fit.payload_after = before + delta;

  // Validation, in the order an operator fixes things.
  if (fit.free_samples < options.min_free_fraction * n) {
    fit.reason = "no motion: " + number(100.0 * fit.free_samples / n, 0) +
                 " % of the samples are in free motion (at least " + number(100.0 * options.min_free_fraction, 0) +
                 " % needed); move the arm (rotate the wrist) and ask again";
    return fit;
  }
  if (!(c.delta_mass_std_kg <= options.max_mass_std_kg)) {
    fit.reason = "the motion does not determine the mass: std " + number(c.delta_mass_std_kg, 3) + " kg (at most " +
                 number(options.max_mass_std_kg, 3) + " kg)";
    return fit;
  }
  for (int i = 0; i < 6; ++i) {
    if (!(fit.residual_rms_after[i] <= options.max_residual_ratio * settings.noise_std[i])) {
      fit.reason = std::string("axis ") + kWrenchAxisNames[i] + ": the residual after the fit is " +
                   number(fit.residual_rms_after[i], 4) + " RMS, more than " + number(options.max_residual_ratio, 1) +
                   " x the noise floor (a contact or another effect in the window?)";
      return fit;
    }
  }
  if (!(fit.payload_after[0] > 0.0)) {
    fit.reason = "physics: the new mass " + number(fit.payload_after[0], 3) + " kg is not positive (change " +
                 number(delta[0], 3) + " kg)";
    return fit;
  }
  fit.inertia_checked = fit.payload_after.tail<6>().allFinite();
  if (fit.inertia_checked) {
    const effects::InertiaAboutCom icom = effects::inertiaAboutCom(fit.payload_after, cov);
    if (!icom.valid_within_uncertainty) {
      fit.reason = "physics: the new inertia is not physical: " + icom.explanation;
      return fit;
    }
  }
  fit.ok = true;
  return fit;
}

}  // namespace ftid::monitor
