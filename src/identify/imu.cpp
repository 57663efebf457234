// Payload-independent IMU estimators (include/ftid/identify/imu.hpp).
#include "ftid/identify/imu.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "ftid/common/error.hpp"
#include "ftid/model/frames.hpp"

namespace ftid::identify {

using effects::SampleContext;

namespace {

constexpr double kRadToDeg = 180.0 / 3.141592653589793;
constexpr int kMinSamples = 20;

Mat3 skew(const Vec3& v) {
  Mat3 s;
  s << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return s;
}

Mat3 expRotation(const Vec3& d) {
  const double angle = d.norm();
  if (angle < 1e-300) return Mat3::Identity();
  return Eigen::AngleAxisd(angle, d / angle).toRotationMatrix();
}

void requireImu(const std::vector<SampleContext>& contexts, const char* who) {
  if (contexts.empty() || !contexts.front().has_imu) {
    throw DataError(std::string(who) + ": the log has no IMU columns (ax..alz, docs/log-format.md)");
  }
}

/// Gravity in B for the tilt and its derivatives (docs/conventions.md, paper Eq. 13).
void gravityAndDerivatives(double u, double v, Vec3* g_B, Vec3* dg_du, Vec3* dg_dv) {
  const double g = kStandardGravity;
  *g_B = model::gravityInBase(u, v);
  *dg_du = g * Vec3(-std::sin(u) * std::sin(v), -std::cos(u), std::sin(u) * std::cos(v));
  *dg_dv = g * Vec3(std::cos(u) * std::cos(v), 0.0, std::cos(u) * std::sin(v));
}

/// The Wahba solution on centred rates at a fixed delay: Q = R_SM^T, the bias, the cost.
struct WahbaFit {
  Mat3 Q = Mat3::Identity();
  Vec3 bias = Vec3::Zero();
  double cost = 0.0;
  int n = 0;
  double rcond = 0.0;  ///< smallest / largest singular value of the cross-covariance
};

WahbaFit wahbaAt(const std::vector<SampleContext>& c, const KinematicsInterpolator& kin, double delay) {
  WahbaFit f;
  Vec3 mean_w = Vec3::Zero();
  Vec3 mean_y = Vec3::Zero();
  std::vector<Vec3> w;
  std::vector<Vec3> y;
  w.reserve(c.size());
  y.reserve(c.size());
  KinematicsAt k;
  for (const auto& ctx : c) {
    if (!kin.at(ctx.t - delay, &k, false)) continue;
    w.push_back(k.w_S);
    y.push_back(ctx.imu_w_S);
    mean_w += k.w_S;
    mean_y += ctx.imu_w_S;
  }
  f.n = static_cast<int>(w.size());
  if (f.n < kMinSamples) return f;
  mean_w /= f.n;
  mean_y /= f.n;
  Mat3 H = Mat3::Zero();
  double sum_sq = 0.0;
  for (int i = 0; i < f.n; ++i) {
    const Vec3 wc = w[static_cast<std::size_t>(i)] - mean_w;
    const Vec3 yc = y[static_cast<std::size_t>(i)] - mean_y;
    H += wc * yc.transpose();
    sum_sq += wc.squaredNorm() + yc.squaredNorm();
  }
  // maximise tr(Q H): H = U S V^T, Q = V diag(1, 1, det(V U^T)) U^T.
  Eigen::JacobiSVD<Mat3> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3 D = Mat3::Identity();
  D(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0.0 ? -1.0 : 1.0;
  f.Q = svd.matrixV() * D * svd.matrixU().transpose();
  f.bias = mean_y - f.Q * mean_w;
  const Vec3 s = svd.singularValues();
  f.rcond = s(0) > 0.0 ? s(2) / s(0) : 0.0;
  f.cost = (sum_sq - 2.0 * (f.Q * H).trace()) / f.n;  // mean square residual (all axes)
  return f;
}

/// The delay minimising the profiled Wahba cost on the grid center + i h, |i| <= m, refined by a
/// parabola through the best three; `fallback` when no grid point has enough samples.
double gridDelay(const std::vector<SampleContext>& c, const KinematicsInterpolator& kin, double center, double h,
                 int m, double fallback) {
  std::vector<double> cost(static_cast<std::size_t>(2 * m + 1), std::numeric_limits<double>::infinity());
  int best = -1;
  for (int i = -m; i <= m; ++i) {
    const WahbaFit f = wahbaAt(c, kin, center + i * h);
    if (f.n < kMinSamples) continue;
    cost[static_cast<std::size_t>(i + m)] = f.cost;
    if (best < 0 || f.cost < cost[static_cast<std::size_t>(best)]) best = i + m;
  }
  if (best < 0) return fallback;
  double tau = center + (best - m) * h;
  if (best > 0 && best < 2 * m) {
    const double a = cost[static_cast<std::size_t>(best - 1)];
    const double b = cost[static_cast<std::size_t>(best)];
    const double d = cost[static_cast<std::size_t>(best + 1)];
    const double denom = a - 2.0 * b + d;
    if (std::isfinite(denom) && denom > 0.0) tau += 0.5 * h * (a - d) / denom;
  }
  return tau;
}

/// Grid points on each side of the coarse delay grid (at 125 Hz, kCoarseDelayPoints half steps of
/// 4 ms cover the default +-0.2 s).
constexpr int kCoarseDelayPoints = 50;

/// Coarse delay: the profiled Wahba cost on a grid of half sample steps over +-max_delay, a parabola
/// through the best three. A fast log (half steps finer than max_delay / 50: above 125 Hz at the
/// default 0.2 s) is searched in two levels, as the cost follows the motion's few Hz and not the
/// sample rate: a grid of max_delay / 50 first, then half steps within two of its spacings of the
/// best, the result kept within +-max_delay. The passes are 101 + 2 ceil(2 (max_delay / 50) /
/// (step / 2)) + 1 instead of 4 max_delay / step + 1 (a log at 5 kHz: 262 instead of 4,001).
double coarseGyroDelay(const std::vector<SampleContext>& c, const KinematicsInterpolator& kin, double max_delay) {
  const double h = 0.5 * kin.step();
  const int m = std::max(1, static_cast<int>(std::floor(max_delay / h)));
  if (m <= kCoarseDelayPoints + 1) return gridDelay(c, kin, 0.0, h, m, 0.0);  // one level (rounding of step)
  const double h_coarse = max_delay / kCoarseDelayPoints;
  const double tau = gridDelay(c, kin, 0.0, h_coarse, kCoarseDelayPoints, 0.0);
  const double fine = gridDelay(c, kin, tau, h, static_cast<int>(std::ceil(2.0 * h_coarse / h)), tau);
  return std::clamp(fine, -max_delay, max_delay);
}

Vec3 rpyOf(const Mat3& R) {
  const Vec3 ypr = R.eulerAngles(2, 1, 0);  // R = Rz(yaw) Ry(pitch) Rx(roll)
  Vec3 rpy(ypr(2), ypr(1), ypr(0));
  // eulerAngles returns yaw in [0, pi]; prefer the representation with |pitch| <= pi/2.
  if (std::abs(rpy(1)) > 0.5 * 3.141592653589793) {
    const double pi = 3.141592653589793;
    rpy = Vec3(rpy(0) + pi, pi - rpy(1), rpy(2) + pi);
  }
  for (int i = 0; i < 3; ++i) rpy(i) = std::remainder(rpy(i), 2.0 * 3.141592653589793);
  return rpy;
}

}  // namespace

KinematicsInterpolator::KinematicsInterpolator(const std::vector<SampleContext>& contexts) : c_(contexts) {
  t_.reserve(contexts.size());
  for (std::size_t i = 0; i < contexts.size(); ++i) {
    const double t = contexts[i].t;
    if (!std::isfinite(t) || (i > 0 && !(t > t_.back()))) {
      throw DataError("IMU estimate: sample " + std::to_string(i + 1) + ": time " + std::to_string(t) +
                      " is not finite or not after the previous sample");
    }
    t_.push_back(t);
  }
  if (t_.size() >= 2) {
    std::vector<double> dt(t_.size() - 1);
    for (std::size_t i = 0; i + 1 < t_.size(); ++i) dt[i] = t_[i + 1] - t_[i];
    std::nth_element(dt.begin(), dt.begin() + static_cast<std::ptrdiff_t>(dt.size() / 2), dt.end());
    step_ = dt[dt.size() / 2];
  }
}

std::size_t KinematicsInterpolator::firstAfter(double s) const {
  // The index a uniform log would have, then a few steps either way; a binary search when the
  // times are too uneven for that. Either way the first t_[j] > s (std::upper_bound's answer).
  const std::size_t n = t_.size();
  if (step_ > 0.0) {
    const double guess = std::floor((s - t_.front()) / step_) + 1.0;
    std::size_t j = guess <= 0.0 ? 0 : (guess >= static_cast<double>(n) ? n : static_cast<std::size_t>(guess));
    for (int walk = 0; walk < 8; ++walk) {
      if (j > 0 && t_[j - 1] > s) {
        --j;
      } else if (j < n && t_[j] <= s) {
        ++j;
      } else {
        return j;
      }
    }
  }
  return static_cast<std::size_t>(std::upper_bound(t_.begin(), t_.end(), s) - t_.begin());
}

bool KinematicsInterpolator::at(double s, KinematicsAt* out, bool rotation) const {
  if (t_.size() < 2 || !(s >= t_.front()) || !(s <= t_.back())) return false;
  std::size_t j1 = firstAfter(s);
  if (j1 >= t_.size()) j1 = t_.size() - 1;
  const std::size_t j0 = j1 - 1;
  const double h = t_[j1] - t_[j0];
  if (h > 1.5 * step_) return false;  // a gap (e.g. a held-out block)
  const SampleContext& a = c_[j0];
  const SampleContext& b = c_[j1];
  const double x = (s - t_[j0]) / h;
  if (x == 0.0) {
    if (rotation) out->R_BS = a.R_BS;
    out->w_S = a.w_S;
    out->alpha_S = a.alpha_S;
    out->a_S = a.a_S;
    return true;
  }
  if (rotation) {
    const Eigen::Quaterniond qa(a.R_BS);
    const Eigen::Quaterniond qb(b.R_BS);
    out->R_BS = qa.slerp(x, qb).toRotationMatrix();
  }
  const double x2 = x * x;
  const double x3 = x2 * x;
  out->w_S = (2 * x3 - 3 * x2 + 1) * a.w_S + (x3 - 2 * x2 + x) * h * a.alpha_S + (-2 * x3 + 3 * x2) * b.w_S +
             (x3 - x2) * h * b.alpha_S;
  out->alpha_S = (1.0 - x) * a.alpha_S + x * b.alpha_S;
  out->a_S = (1.0 - x) * a.a_S + x * b.a_S;
  return true;
}

GyroMountEstimate estimateGyroMount(const std::vector<SampleContext>& contexts, const ImuOptions& options) {
  requireImu(contexts, "gyro mount estimate");
  const KinematicsInterpolator kin(contexts);
  double tau = options.estimate_delay ? coarseGyroDelay(contexts, kin, options.max_delay_s) : 0.0;
  WahbaFit w0 = wahbaAt(contexts, kin, tau);
  if (w0.n < kMinSamples) {
    throw DataError("gyro mount estimate: only " + std::to_string(w0.n) + " samples inside the data (need " +
                    std::to_string(kMinSamples) + ")");
  }
  if (w0.rcond < 1e-6) {
    throw DataError("gyro mount estimate: the angular rates do not determine the IMU's rotation (the motion turns "
                    "about fewer than two axes)");
  }
  Mat3 Q = w0.Q;
  Vec3 b = w0.bias;
  const int np = options.estimate_delay ? 7 : 6;
  GyroMountEstimate est;
  Eigen::MatrixXd JtJ(np, np);
  double ssr = 0.0;
  int n = 0;
  bool converged = false;
  for (int iter = 0; iter <= options.max_iterations; ++iter) {
    JtJ.setZero();
    Eigen::VectorXd Jtr = Eigen::VectorXd::Zero(np);
    ssr = 0.0;
    n = 0;
    KinematicsAt k;
    Eigen::Matrix<double, 3, 7> J;
    for (const auto& ctx : contexts) {
      if (!kin.at(ctx.t - tau, &k, false)) continue;
      const Vec3 r = ctx.imu_w_S - Q * k.w_S - b;
      J.block<3, 3>(0, 0) = -Q * skew(k.w_S);  // d(Q (I + skew d) w)/dd
      J.block<3, 3>(0, 3) = Mat3::Identity();
      J.col(6) = -Q * k.alpha_S;               // d w(t - tau)/d tau = -alpha
      const auto Jn = J.leftCols(np);
      JtJ.noalias() += Jn.transpose() * Jn;
      Jtr.noalias() += Jn.transpose() * r;
      ssr += r.squaredNorm();
      ++n;
    }
    if (converged || iter == options.max_iterations) break;  // statistics at the final point
    const Eigen::VectorXd dx = JtJ.ldlt().solve(Jtr);
    if (!dx.allFinite()) break;
    Q = Q * expRotation(dx.head<3>());
    b += dx.segment<3>(3);
    if (np == 7) tau += std::clamp(dx(6), -kin.step(), kin.step());
    converged = dx.head<3>().norm() < 1e-12 && (np == 6 || std::abs(dx(6)) < 1e-12);
  }
  const int dof = 3 * n - np;
  const double sigma2 = dof > 0 ? ssr / dof : 0.0;
  const Eigen::MatrixXd cov = sigma2 * JtJ.ldlt().solve(Eigen::MatrixXd::Identity(np, np));
  est.covariance.topLeftCorner(np, np) = cov;
  est.R_SM = Q.transpose();
  est.rpy_rad = rpyOf(est.R_SM);
  est.bias_radps = b;
  est.delay_estimated = options.estimate_delay;
  est.delay_s = tau;
  est.sigma_radps = std::sqrt(sigma2);
  est.n_used = n;
  // d was defined in M (Q = Q_hat (I + skew d)); about S's axes it is R_SM d: rotate the block.
  Eigen::Matrix<double, 7, 7> T = Eigen::Matrix<double, 7, 7>::Identity();
  T.topLeftCorner<3, 3>() = est.R_SM;
  est.covariance = T * est.covariance * T.transpose();
  for (int i = 0; i < 3; ++i) {
    est.rotation_std_rad(i) = std::sqrt(std::max(est.covariance(i, i), 0.0));
    est.bias_std_radps(i) = std::sqrt(std::max(est.covariance(3 + i, 3 + i), 0.0));
  }
  est.delay_std_s = std::sqrt(std::max(est.covariance(6, 6), 0.0));
  return est;
}

AccTiltEstimate estimateAccTilt(const std::vector<SampleContext>& contexts, const Mat3& R_SM, double delay_s,
                                const ImuOptions& options) {
  requireImu(contexts, "accelerometer tilt estimate");
  const KinematicsInterpolator kin(contexts);
  const Mat3 Q = R_SM.transpose();
  // Linear start: z - Q a = -Q R^T g_B + b  for [g_B; b].
  Eigen::Matrix<double, 6, 6> AtA = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> Aty = Eigen::Matrix<double, 6, 1>::Zero();
  // The kinematics at the IMU's delayed times, interpolated once for the start and every iteration.
  std::vector<std::pair<const SampleContext*, KinematicsAt>> at_delay;
  at_delay.reserve(contexts.size());
  for (const auto& ctx : contexts) {
    KinematicsAt k;
    if (kin.at(ctx.t - delay_s, &k)) at_delay.emplace_back(&ctx, k);
  }
  int n = 0;
  for (const auto& [c, k] : at_delay) {
    const SampleContext& ctx = *c;
    Eigen::Matrix<double, 3, 6> A;
    A.leftCols<3>() = -Q * k.R_BS.transpose();
    A.rightCols<3>() = Mat3::Identity();
    const Vec3 y = ctx.imu_acc_S - Q * k.a_S;
    AtA.noalias() += A.transpose() * A;
    Aty.noalias() += A.transpose() * y;
    ++n;
  }
  if (n < kMinSamples) {
    throw DataError("accelerometer tilt estimate: only " + std::to_string(n) + " samples inside the data (need " +
                    std::to_string(kMinSamples) + ")");
  }
  Vec3 g_B;
  {
    // With the bias: solve all six when well conditioned, else gravity alone.
    const Eigen::Matrix<double, 6, 1> sol = AtA.ldlt().solve(Aty);
    const Vec3 g_only = AtA.topLeftCorner<3, 3>().ldlt().solve(Aty.head<3>());
    g_B = (options.estimate_acc_bias && sol.allFinite() && sol.head<3>().norm() > 0.5 * kStandardGravity)
              ? Vec3(sol.head<3>())
              : g_only;
  }
  double u = std::asin(std::clamp(-g_B.y() / g_B.norm(), -1.0, 1.0));
  double v = std::atan2(g_B.x(), -g_B.z());
  Vec3 b = Vec3::Zero();

  // Is the bias determined? The reciprocal condition number of the column-scaled Jacobian.
  auto accumulate = [&](double uu, double vv, const Vec3& bb, Eigen::Matrix<double, 5, 5>* JtJ,
                        Eigen::Matrix<double, 5, 1>* Jtr, double* ssr, int* count) {
    Vec3 gB, dgu, dgv;
    gravityAndDerivatives(uu, vv, &gB, &dgu, &dgv);
    JtJ->setZero();
    Jtr->setZero();
    *ssr = 0.0;
    *count = 0;
    Eigen::Matrix<double, 3, 5> J;
    for (const auto& [c, kk] : at_delay) {
      const SampleContext& ctx = *c;
      const Mat3 QRt = Q * kk.R_BS.transpose();
      const Vec3 r = ctx.imu_acc_S - (Q * kk.a_S - QRt * gB + bb);
      J.col(0) = -QRt * dgu;
      J.col(1) = -QRt * dgv;
      J.rightCols<3>() = Mat3::Identity();
      JtJ->noalias() += J.transpose() * J;
      Jtr->noalias() += J.transpose() * r;
      *ssr += r.squaredNorm();
      ++*count;
    }
  };
  Eigen::Matrix<double, 5, 5> JtJ;
  Eigen::Matrix<double, 5, 1> Jtr;
  double ssr = 0.0;
  accumulate(u, v, b, &JtJ, &Jtr, &ssr, &n);
  bool with_bias = options.estimate_acc_bias;
  if (with_bias) {
    const Eigen::Matrix<double, 5, 1> d = JtJ.diagonal().cwiseMax(1e-300).cwiseSqrt().cwiseInverse();
    const Eigen::Matrix<double, 5, 5> S = d.asDiagonal() * JtJ * d.asDiagonal();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 5, 5>> es(S);
    const double lmax = es.eigenvalues().maxCoeff();
    const double rcond = lmax > 0.0 ? std::sqrt(std::max(es.eigenvalues().minCoeff(), 0.0) / lmax) : 0.0;
    with_bias = rcond >= options.bias_rcond;
  }
  const int np = with_bias ? 5 : 2;
  for (int iter = 0; iter < options.max_iterations; ++iter) {
    const Eigen::VectorXd dx = JtJ.topLeftCorner(np, np).ldlt().solve(Jtr.head(np));
    if (!dx.allFinite()) break;
    u += dx(0);
    v += dx(1);
    if (with_bias) b += dx.tail<3>();
    accumulate(u, v, b, &JtJ, &Jtr, &ssr, &n);
    if (dx.head<2>().norm() < 1e-13) break;
  }
  AccTiltEstimate est;
  const int dof = 3 * n - np;
  const double sigma2 = dof > 0 ? ssr / dof : 0.0;
  est.covariance.topLeftCorner(np, np) =
      sigma2 * JtJ.topLeftCorner(np, np).ldlt().solve(Eigen::MatrixXd::Identity(np, np));
  est.tilt_u_rad = std::remainder(u, 2.0 * 3.141592653589793);
  est.tilt_v_rad = std::remainder(v, 2.0 * 3.141592653589793);
  est.tilt_u_std = std::sqrt(std::max(est.covariance(0, 0), 0.0));
  est.tilt_v_std = std::sqrt(std::max(est.covariance(1, 1), 0.0));
  est.bias_estimated = with_bias;
  est.bias_mps2 = b;
  for (int i = 0; i < 3; ++i) est.bias_std_mps2(i) = std::sqrt(std::max(est.covariance(2 + i, 2 + i), 0.0));
  est.sigma_mps2 = std::sqrt(sigma2);
  est.n_used = n;
  return est;
}

std::vector<SampleContext> freshImuRows(const std::vector<SampleContext>& contexts, int* held, int* typical) {
  *held = 0;
  *typical = 1;
  std::vector<char> stale(contexts.size(), 0);
  std::vector<int> spans;
  std::size_t start = 0;  // the row the current reading arrived with
  for (std::size_t i = 1; i <= contexts.size(); ++i) {
    if (i < contexts.size()) {
      const SampleContext& a = contexts[i - 1];
      const SampleContext& b = contexts[i];
      const bool same = a.imu_acc_S == b.imu_acc_S && a.imu_w_S == b.imu_w_S && a.imu_alpha_S == b.imu_alpha_S;
      const bool moved = a.q != b.q || a.qd != b.qd || a.R_BS != b.R_BS;
      if (same && moved) {
        stale[i] = 1;
        ++*held;
        continue;
      }
      if (same) continue;  // at rest a repeated reading is a reading
    }
    if (i - start >= 2) spans.push_back(static_cast<int>(i - start));
    start = i;
  }
  if (*held == 0) return {};
  std::nth_element(spans.begin(), spans.begin() + static_cast<std::ptrdiff_t>(spans.size() / 2), spans.end());
  *typical = spans.empty() ? 1 : spans[spans.size() / 2];
  std::vector<SampleContext> out;
  out.reserve(contexts.size() - static_cast<std::size_t>(*held));
  for (std::size_t i = 0; i < contexts.size(); ++i) {
    if (stale[i] == 0) out.push_back(contexts[i]);
  }
  return out;
}

ImuEstimate estimateImu(const std::vector<SampleContext>& all, const ImuOptions& options) {
  ImuEstimate e;
  // Only the rows each IMU reading arrived with (a held reading is no new measurement).
  const std::vector<SampleContext> fresh = freshImuRows(all, &e.held_rows, &e.typical_hold_rows);
  const std::vector<SampleContext>& contexts = e.held_rows > 0 ? fresh : all;
  e.gyro = estimateGyroMount(contexts, options);
  e.acc = estimateAccTilt(contexts, e.gyro.R_SM, e.gyro.delay_s, options);
  // The accelerometer's answer depends on the gyro's frame and delay: propagate their uncertainty
  // (independent noise) through the sensitivities G = d[U, V, b_a] / d[d, tau] (forward differences,
  // same bias decision): Cov += G Cov_gyro G^T.
  ImuOptions same = options;
  same.estimate_acc_bias = e.acc.bias_estimated;
  same.bias_rcond = 0.0;
  auto state = [](const AccTiltEstimate& a) {
    Eigen::Matrix<double, 5, 1> x;
    x << a.tilt_u_rad, a.tilt_v_rad, a.bias_mps2;
    return x;
  };
  const Eigen::Matrix<double, 5, 1> x0 = state(e.acc);
  Eigen::Matrix<double, 5, 4> G = Eigen::Matrix<double, 5, 4>::Zero();
  constexpr double kStepRad = 1e-5;
  for (int i = 0; i < 3; ++i) {
    const Mat3 R = expRotation(-kStepRad * Vec3::Unit(i)) * e.gyro.R_SM;  // R_SM = (I - skew(d)) R_SM_hat
    G.col(i) = (state(estimateAccTilt(contexts, R, e.gyro.delay_s, same)) - x0) / kStepRad;
  }
  Eigen::Matrix4d C = Eigen::Matrix4d::Zero();
  C.topLeftCorner<3, 3>() = e.gyro.covariance.topLeftCorner<3, 3>();
  if (e.gyro.delay_estimated) {
    constexpr double kStepS = 1e-6;
    G.col(3) = (state(estimateAccTilt(contexts, e.gyro.R_SM, e.gyro.delay_s + kStepS, same)) - x0) / kStepS;
    C.topRightCorner<3, 1>() = e.gyro.covariance.block<3, 1>(0, 6);
    C.bottomLeftCorner<1, 3>() = e.gyro.covariance.block<1, 3>(6, 0);
    C(3, 3) = e.gyro.covariance(6, 6);
  }
  e.acc.covariance += G * C * G.transpose();
  e.acc.tilt_u_std = std::sqrt(std::max(e.acc.covariance(0, 0), 0.0));
  e.acc.tilt_v_std = std::sqrt(std::max(e.acc.covariance(1, 1), 0.0));
  if (e.acc.bias_estimated) {
    for (int i = 0; i < 3; ++i) e.acc.bias_std_mps2(i) = std::sqrt(std::max(e.acc.covariance(2 + i, 2 + i), 0.0));
  }
  return e;
}

Eigen::Matrix2d predictImuTiltCovariance(const std::vector<SampleContext>& contexts, double acc_std, double gyro_std,
                                         bool bias_estimated) {
  const Eigen::Matrix2d infinite = Eigen::Matrix2d::Constant(std::numeric_limits<double>::infinity());
  if (contexts.empty() || !(acc_std > 0.0) || !(gyro_std > 0.0)) return infinite;
  // The tilt of the contexts' gravity: g_B = R_BS g_S.
  const Vec3 g_B = contexts.front().R_BS * contexts.front().g_S;
  const double u = std::asin(std::clamp(-g_B.y() / g_B.norm(), -1.0, 1.0));
  const double v = std::atan2(g_B.x(), -g_B.z());
  Vec3 g, dgu, dgv;
  gravityAndDerivatives(u, v, &g, &dgu, &dgv);
  Eigen::Matrix<double, 5, 5> A = Eigen::Matrix<double, 5, 5>::Zero();
  Eigen::Matrix<double, 5, 3> B = Eigen::Matrix<double, 5, 3>::Zero();
  Mat3 Sww = Mat3::Zero();
  Mat3 Sw = Mat3::Zero();  // sum of skew(w)
  for (const auto& c : contexts) {
    const Mat3 Rt = c.R_BS.transpose();
    Eigen::Matrix<double, 3, 5> J;
    J.col(0) = -Rt * dgu;
    J.col(1) = -Rt * dgv;
    J.rightCols<3>() = Mat3::Identity();
    // d(Q x)/dd at Q = I with R_SM = (I - skew(d)): Q = I + skew(d), so d(Q x)/dd = -skew(x).
    const Mat3 Jd = -skew(c.a_S - Rt * g);
    A.noalias() += J.transpose() * J;
    B.noalias() += J.transpose() * Jd;
    const Mat3 Kw = skew(c.w_S);
    Sww.noalias() += Kw.transpose() * Kw;
    Sw += Kw;
  }
  A /= acc_std * acc_std;
  B /= acc_std * acc_std;
  // The gyro's information over d with b_g marginalised: sum skew^T skew - (sum skew)^T (sum skew) / n.
  const double n = static_cast<double>(contexts.size());
  const Mat3 Id = (Sww - Sw.transpose() * Sw / n) / (gyro_std * gyro_std);
  const int np = bias_estimated ? 5 : 2;
  const Eigen::MatrixXd Ainv = A.topLeftCorner(np, np).ldlt().solve(Eigen::MatrixXd::Identity(np, np));
  const Eigen::LDLT<Mat3> ld(Id);
  if (!Ainv.allFinite() || ld.info() != Eigen::Success || !(ld.vectorD().array() > 0.0).all()) return infinite;
  const Mat3 cov_d = ld.solve(Mat3::Identity());
  const Eigen::MatrixXd G = -Ainv * B.topRows(np);
  const Eigen::MatrixXd cov = Ainv + G * cov_d * G.transpose();
  if (!cov.allFinite()) return infinite;
  return cov.topLeftCorner<2, 2>();
}

std::string formatImuEstimate(const ImuEstimate& e) {
  std::ostringstream os;
  char line[200];
  std::snprintf(line, sizeof(line), "IMU (payload-free): tilt U = %.4f +- %.4f deg, V = %.4f +- %.4f deg (%d samples)\n",
                e.acc.tilt_u_rad * kRadToDeg, e.acc.tilt_u_std * kRadToDeg, e.acc.tilt_v_rad * kRadToDeg,
                e.acc.tilt_v_std * kRadToDeg, e.acc.n_used);
  os << line;
  if (e.held_rows > 0) {
    std::snprintf(line, sizeof(line),
                  "  %d rows hold the previous row's IMU reading while the robot moved (each reading spans %d rows: "
                  "an IMU at 1/%d of the log's rate); only the row each reading arrived with is used\n",
                  e.held_rows, e.typical_hold_rows, e.typical_hold_rows);
    os << line;
  }
  if (e.acc.bias_estimated) {
    std::snprintf(line, sizeof(line), "  accelerometer bias %.4f %.4f %.4f m/s^2 (std %.2g %.2g %.2g), noise %.3g m/s^2\n",
                  e.acc.bias_mps2.x(), e.acc.bias_mps2.y(), e.acc.bias_mps2.z(), e.acc.bias_std_mps2.x(),
                  e.acc.bias_std_mps2.y(), e.acc.bias_std_mps2.z(), e.acc.sigma_mps2);
  } else {
    std::snprintf(line, sizeof(line),
                  "  accelerometer bias not determined by these orientations (held at 0), noise %.3g m/s^2\n",
                  e.acc.sigma_mps2);
  }
  os << line;
  std::snprintf(line, sizeof(line), "  gyro bias %.5f %.5f %.5f rad/s (std %.2g %.2g %.2g), noise %.3g rad/s\n",
                e.gyro.bias_radps.x(), e.gyro.bias_radps.y(), e.gyro.bias_radps.z(), e.gyro.bias_std_radps.x(),
                e.gyro.bias_std_radps.y(), e.gyro.bias_std_radps.z(), e.gyro.sigma_radps);
  os << line;
  std::snprintf(line, sizeof(line), "  IMU frame in S: roll %.3f pitch %.3f yaw %.3f deg (std %.2g %.2g %.2g deg)\n",
                e.gyro.rpy_rad.x() * kRadToDeg, e.gyro.rpy_rad.y() * kRadToDeg, e.gyro.rpy_rad.z() * kRadToDeg,
                e.gyro.rotation_std_rad.x() * kRadToDeg, e.gyro.rotation_std_rad.y() * kRadToDeg,
                e.gyro.rotation_std_rad.z() * kRadToDeg);
  os << line;
  if (e.gyro.delay_estimated) {
    std::snprintf(line, sizeof(line), "  IMU stream delay %.2f +- %.2f ms\n", e.gyro.delay_s * 1e3,
                  e.gyro.delay_std_s * 1e3);
    os << line;
  }
  return os.str();
}

}  // namespace ftid::identify
