// Nonlinear parameters and model evaluation (include/ftid/effects/nonlinear.hpp).
#include "ftid/effects/nonlinear.hpp"

#include <Eigen/LU>
#include <cmath>
#include <string>

#include "ftid/common/error.hpp"

namespace ftid::effects {

Mat3 mountingRotation(const Vec3& rpy_rad) noexcept {
  const double cr = std::cos(rpy_rad.x()), sr = std::sin(rpy_rad.x());
  const double cp = std::cos(rpy_rad.y()), sp = std::sin(rpy_rad.y());
  const double cy = std::cos(rpy_rad.z()), sy = std::sin(rpy_rad.z());
  Mat3 Rx, Ry, Rz;
  Rx << 1.0, 0.0, 0.0, 0.0, cr, -sr, 0.0, sr, cr;
  Ry << cp, 0.0, sp, 0.0, 1.0, 0.0, -sp, 0.0, cp;
  Rz << cy, -sy, 0.0, sy, cy, 0.0, 0.0, 0.0, 1.0;
  return Rz * Ry * Rx;
}

void applyMounting(const Mat3& R_SM, SampleContext* ctx) noexcept {
  const Mat3 R_BM = ctx->R_BS * R_SM;
  ctx->R_BS = R_BM;
  const Vec3 w = R_SM.transpose() * ctx->w_S;
  const Vec3 al = R_SM.transpose() * ctx->alpha_S;
  const Vec3 a = R_SM.transpose() * ctx->a_S;
  const Vec3 g = R_SM.transpose() * ctx->g_S;
  ctx->w_S = w;
  ctx->alpha_S = al;
  ctx->a_S = a;
  ctx->g_S = g;
}

void interpolateKinematics(const SampleContext& a, const SampleContext& b, double s,
                           SampleContext* out) noexcept {
  const double r = 1.0 - s;
  out->q = r * a.q + s * b.q;
  out->qd = r * a.qd + s * b.qd;
  out->R_BS = r * a.R_BS + s * b.R_BS;
  out->p_BS_B = r * a.p_BS_B + s * b.p_BS_B;
  out->w_S = r * a.w_S + s * b.w_S;
  out->alpha_S = r * a.alpha_S + s * b.alpha_S;
  out->a_S = r * a.a_S + s * b.a_S;
  out->g_S = r * a.g_S + s * b.g_S;
  out->has_imu = a.has_imu && b.has_imu;
  out->imu_acc_S = r * a.imu_acc_S + s * b.imu_acc_S;
  out->imu_w_S = r * a.imu_w_S + s * b.imu_w_S;
  out->imu_alpha_S = r * a.imu_alpha_S + s * b.imu_alpha_S;
}

Mat6 modelWrenchMap(const std::vector<const Effect*>& effects, SampleContext ctx, const Eigen::VectorXd& theta,
                    Eigen::Ref<Eigen::Matrix<double, 6, Eigen::Dynamic>> Y) noexcept {
  Mat6 E;
  for (int k = 0; k < 6; ++k) {
    ctx.wrench_model_S = Wrench::Unit(k);
    Y.setZero();
    for (const Effect* e : effects) e->addRegressor(ctx, Y);
    E.col(k).noalias() = Y * theta;
  }
  return E;
}

std::vector<const Effect*> modelWrenchEffects(const Model& model) {
  std::vector<const Effect*> out;
  for (const auto& e : model.effectList()) {
    if ((e->signals() & kSignalModelWrench) != 0) out.push_back(e.get());
  }
  return out;
}

ModelEvaluator::ModelEvaluator(const Model& model, const Eigen::VectorXd& theta)
    : model_(model),
      theta_(theta),
      reads_model_wrench_((model.signals() & kSignalModelWrench) != 0),
      wrench_effects_(modelWrenchEffects(model_)),
      Y_(6, model.numParams()) {
  if (theta.size() != model.numParams()) {
    throw ConfigError("model evaluation: " + std::to_string(theta.size()) + " parameters given, model '" +
                      model.name() + "' has " + std::to_string(model.numParams()));
  }
  Y_.setZero();
}

Wrench ModelEvaluator::evaluate(const SampleContext& ctx) noexcept {
  work_ = ctx;  // fixed-size copy; ctx.extra and ctx.extra_names are pointers
  work_.wrench_model_S.setZero();
  model_.computeRegressor(work_, Y_);
  Wrench w;
  w.noalias() = Y_ * theta_;
  if (reads_model_wrench_) {
    // Effects reading the modelled wrench are linear in it and contribute nothing above.
    work_.wrench_model_S = w;
    model_.computeRegressor(work_, Y_);
    w.noalias() = Y_ * theta_;
  }
  return w;
}

Wrench ModelEvaluator::contact(const SampleContext& ctx, Wrench* modelled) noexcept {
  work_ = ctx;
  work_.wrench_model_S.setZero();
  model_.computeRegressor(work_, Y_);
  Wrench w_base;
  w_base.noalias() = Y_ * theta_;  // the derived effects contribute nothing with wrench_model_S = 0
  if (!reads_model_wrench_) {
    if (modelled != nullptr) *modelled = w_base;
    return ctx.wrench_S - w_base;
  }
  const Mat6 IE = Mat6::Identity() + modelWrenchMap(wrench_effects_, work_, theta_, Y_);
  if (modelled != nullptr) *modelled = IE * w_base;
  return Wrench(IE.partialPivLu().solve(ctx.wrench_S)) - w_base;
}

}  // namespace ftid::effects
