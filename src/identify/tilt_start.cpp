// Multi-start of the nonlinear search (include/ftid/identify/tilt_start.hpp).
#include "ftid/identify/tilt_start.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>

#include "ftid/common/error.hpp"
#include "ftid/identify/setup_check.hpp"

namespace ftid::identify {

namespace {

constexpr double kPi = 3.141592653589793;

std::string degrees(double rad) {
  char b[32];
  std::snprintf(b, sizeof b, "%.1f", rad * 180.0 / kPi);
  return b;
}

std::string fixed(double v, int digits) {
  char b[32];
  std::snprintf(b, sizeof b, "%.*f", digits, v);
  return b;
}

/// Sum over the axes of (RMS / reference)^2: the fits' residuals on one scale.
double costOf(const FitResult& f, const Vec6& reference) {
  double c = 0.0;
  for (int a = 0; a < 6; ++a) c += (f.residual_rms(a) * f.residual_rms(a)) / std::max(reference(a) * reference(a), 1e-300);
  return c;
}

std::string describe(const FitResult& f) {
  std::string s = "tilt U " + degrees(f.tilt_u_rad) + " deg, V " + degrees(f.tilt_v_rad) + " deg";
  if (f.has("mass")) s += ", mass " + fixed(f.value("mass"), 3) + " kg";
  return s;
}

}  // namespace

double wrapAngle(double rad) {
  if (!std::isfinite(rad)) return rad;
  double r = std::remainder(rad, 2.0 * kPi);  // [-pi, pi]
  if (r <= -kPi) r += 2.0 * kPi;
  return r;
}

Vec3 canonicalRpy(const Vec3& rpy_rad) {
  double roll = wrapAngle(rpy_rad(0));
  double pitch = wrapAngle(rpy_rad(1));
  double yaw = wrapAngle(rpy_rad(2));
  if (pitch > kPi / 2.0 || pitch < -kPi / 2.0) {
    // Rz(y) Ry(p) Rx(r) = Rz(y + pi) Ry(pi - p) Rx(r + pi).
    pitch = wrapAngle(kPi - pitch);
    roll = wrapAngle(roll + kPi);
    yaw = wrapAngle(yaw + kPi);
  }
  return {roll, pitch, yaw};
}

void wrapAngles(FitResult& fit) {
  fit.tilt_u_rad = wrapAngle(fit.tilt_u_rad);
  fit.tilt_v_rad = wrapAngle(fit.tilt_v_rad);
  if (fit.mounting_estimated) fit.mount_rpy_rad = canonicalRpy(fit.mount_rpy_rad);
}

MultiStartFit fitModelMultiStart(const Model& model, const std::vector<SampleContext>& contexts,
                                 const FitOptions& given) {
  MultiStartFit out;
  FitOptions options = given;
  if (model.estimatesMounting() && !options.mount_rpy_rad) {
    // A large mounting rotation is outside the basin of the level start: start from the best of
    // the 24 axis-aligned rotations (the gravity model's fit decides, setup_check.hpp).
    const Mat3 R_SM = bestAxisAlignedMount(contexts);
    if (!R_SM.isIdentity()) {
      options.mount_rpy_rad = rpyOf(R_SM);
      const Vec3 r = options.mount_rpy_rad->unaryExpr([](double v) { return std::abs(v) < 5e-5 ? 0.0 : v; });
      out.notes.push_back("the mounting fit started from the axis-aligned rotation rpy " + fixed(r.x(), 4) + "," +
                          fixed(r.y(), 4) + "," + fixed(r.z(), 4) + " rad, which the gravity model fits best");
    }
  }
  const bool tilt_given = options.tilt_u_rad && options.tilt_v_rad;
  if (!model.estimatesTilt() || tilt_given) {
    out.fit = fitModel(model, contexts, options);
    out.starts = 1;
    wrapAngles(out.fit);
    return out;
  }
  std::vector<FitResult> fits;
  std::optional<IdentificationError> first_error;
  auto attempt = [&](const FitOptions& o) {
    try {
      fits.push_back(fitModel(model, contexts, o));
      wrapAngles(fits.back());
    } catch (const IdentificationError& e) {
      if (!first_error) first_error = e;
    }
    ++out.starts;
  };
  attempt(options);  // the paper's force stage
  FitOptions level = options;
  level.tilt_u_rad = 0.0;
  level.tilt_v_rad = 0.0;
  attempt(level);
  if (fits.empty()) throw *first_error;
  Vec6 reference = fits.front().residual_rms;
  for (const auto& f : fits) reference = reference.cwiseMin(f.residual_rms);
  std::size_t best = 0;
  for (std::size_t k = 1; k < fits.size(); ++k) {
    if (costOf(fits[k], reference) < costOf(fits[best], reference)) best = k;
  }
  const double best_cost = costOf(fits[best], reference);
  for (std::size_t k = 0; k < fits.size(); ++k) {
    if (k == best) continue;
    const FitResult& f = fits[k];
    const double du = std::abs(wrapAngle(f.tilt_u_rad - fits[best].tilt_u_rad));
    const double dv = std::abs(wrapAngle(f.tilt_v_rad - fits[best].tilt_v_rad));
    const double tol = 1e-3 + 3.0 * std::max({fits[best].tilt_u_std, fits[best].tilt_v_std, f.tilt_u_std, f.tilt_v_std});
    if (du <= tol && dv <= tol) continue;  // the same minimum
    const double ratio = costOf(f, reference) / std::max(best_cost, 1e-300) - 1.0;
    if (ratio < kAmbiguousCostRatio) {
      out.notes.push_back("the tilt search found two minima that fit nearly equally well (" + describe(fits[best]) +
                          "; " + describe(f) + ", residual " + fixed(100.0 * ratio, 1) +
                          " % larger): the data do not decide the tilt; excite the payload longer or with more motion");
    } else if (k == 0) {
      out.notes.push_back("the tilt search from the paper's force stage ended in a worse minimum (" + describe(f) +
                          ", residual " + fixed(100.0 * ratio, 0) + " % larger) than from a level base (" +
                          describe(fits[best]) + "): the better one is kept");
    }
  }
  out.fit = std::move(fits[best]);
  return out;
}

}  // namespace ftid::identify
