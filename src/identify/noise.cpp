// The noise floor from the data (include/ftid/identify/noise.hpp, docs/identification.md).
#include "ftid/identify/noise.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "ftid/common/error.hpp"
#include "noise_internal.hpp"

namespace ftid::identify {

using internal::ar1FromDifferences;
using internal::fmt;
using internal::kColouredPhi;

namespace {

constexpr double kMadToStd = 1.482602218505602;
constexpr int kMaxStride = 3;
/// The longest run of a held pose's readings taken around one mean (estimateNoiseFloor): 0.26 s at
/// 125 Hz, short against a zero's drift (temperature, creep) and long enough that removing the
/// mean costs 1/32 of the readings.
constexpr int kPoseWindow = 32;

double median(std::vector<double>& v) {
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

/// |4th differences| at stride s of one segment, appended to out.
void appendDifferences(const std::vector<double>& x, int s, std::vector<double>& out) {
  const std::size_t st = static_cast<std::size_t>(s);
  for (std::size_t i = 0; i + 4 * st < x.size(); ++i) {
    out.push_back(std::abs(x[i] - 4.0 * x[i + st] + 6.0 * x[i + 2 * st] - 4.0 * x[i + 3 * st] + x[i + 4 * st]));
  }
}

/// sum_{i,j < m} phi^|i-j|
double correlationSum(double phi, std::size_t m) {
  double s = static_cast<double>(m);
  double p = 1.0;
  for (std::size_t k = 1; k < m; ++k) {
    p *= phi;
    s += 2.0 * static_cast<double>(m - k) * p;
  }
  return s;
}

/// Expected sums of one window of m readings of unit-variance AR(1) noise (lag-1 correlation phi)
/// around the window's own mean: e0 = E sum_i (x_i - mean)^2, e1 = E sum_i (x_i - mean)(x_{i+1} -
/// mean). With C = phi^|i-k|, a_i = mean_k C(i,k), b = mean_i a_i: E (x_i - mean)(x_k - mean) =
/// C(i,k) - a_i - a_k + b.
void windowMoments(double phi, std::size_t m, double* e0, double* e1) {
  std::vector<double> power(m, 1.0);  // phi^d
  for (std::size_t d = 1; d < m; ++d) power[d] = power[d - 1] * phi;
  std::vector<double> a(m, 0.0);
  for (std::size_t i = 0; i < m; ++i) {
    for (std::size_t k = 0; k < m; ++k) a[i] += power[i > k ? i - k : k - i];
    a[i] /= static_cast<double>(m);
  }
  double b = 0.0;
  for (double v : a) b += v / static_cast<double>(m);
  *e0 = 0.0;
  *e1 = 0.0;
  for (std::size_t i = 0; i < m; ++i) {
    *e0 += 1.0 - 2.0 * a[i] + b;
    if (i + 1 < m) *e1 += phi - a[i] - a[i + 1] + b;
  }
}

/// The lag-1 correlation of AR(1) noise from windows of readings around their own means, by the
/// method of moments with the mean removal's bias taken exactly: phi where sum E e1 / sum E e0 over
/// the windows (windowMoments) equals the observed sum of lag-1 products over the sum of squares
/// (the ratio grows with phi; 50 bisections of [0, 0.995]). Efficient where the robust
/// ar1FromDifferences scattered by about 0.1 on 1,250 readings (a 15 Hz filter's 0.47 read as 0.77).
/// -1 when the windows hold fewer than 16 lag-1 pairs.
double ar1FromWindows(const std::vector<std::vector<double>>& segments) {
  double s0 = 0.0, s1 = 0.0;
  std::vector<int> count_by_size;
  int pairs = 0;
  for (const auto& seg : segments) {
    if (seg.size() < 2) continue;
    double mean = 0.0;
    for (double v : seg) mean += v / static_cast<double>(seg.size());
    for (std::size_t i = 0; i < seg.size(); ++i) {
      s0 += (seg[i] - mean) * (seg[i] - mean);
      if (i + 1 < seg.size()) s1 += (seg[i] - mean) * (seg[i + 1] - mean);
    }
    if (count_by_size.size() <= seg.size()) count_by_size.resize(seg.size() + 1, 0);
    ++count_by_size[seg.size()];
    pairs += static_cast<int>(seg.size()) - 1;
  }
  if (pairs < 16 || !(s0 > 0.0)) return -1.0;
  const double observed = s1 / s0;
  auto expected = [&](double phi) {
    double e0 = 0.0, e1 = 0.0;
    for (std::size_t m = 2; m < count_by_size.size(); ++m) {
      if (count_by_size[m] == 0) continue;
      double w0 = 0.0, w1 = 0.0;
      windowMoments(phi, m, &w0, &w1);
      e0 += count_by_size[m] * w0;
      e1 += count_by_size[m] * w1;
    }
    return e1 / e0;
  };
  double lo = 0.0, hi = 0.995;
  if (observed <= expected(lo)) return 0.0;
  if (observed >= expected(hi)) return hi;
  for (int it = 0; it < 50; ++it) {
    const double mid = 0.5 * (lo + hi);
    (expected(mid) < observed ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace

namespace internal {

/// Robust lag-1 correlation of the first differences inside each segment, mapped to the AR(1)
/// coefficient: for AR(1) noise corr(dx_i, dx_{i+1}) = -(1 - phi) / 2 (white: -1/2). Pairs are
/// (d_i + d_{i+1}) and (d_i - d_{i+1}): corr = (s+^2 - s-^2) / (s+^2 + s-^2), s = 1.4826 MAD.
/// Returns -1 if fewer than 16 pairs.
double ar1FromDifferences(const std::vector<std::vector<double>>& segments) {
  std::vector<double> plus, minus;
  for (const auto& seg : segments) {
    for (std::size_t i = 0; i + 2 < seg.size(); ++i) {
      const double d0 = seg[i + 1] - seg[i];
      const double d1 = seg[i + 2] - seg[i + 1];
      plus.push_back(std::abs(d0 + d1));
      minus.push_back(std::abs(d0 - d1));
    }
  }
  if (plus.size() < 16) return -1.0;
  const double sp = median(plus), sm = median(minus);
  if (!(sp * sp + sm * sm > 0.0)) return 0.0;
  const double rho = (sp * sp - sm * sm) / (sp * sp + sm * sm);
  return std::clamp(1.0 + 2.0 * rho, 0.0, 0.99);
}

std::string fmt(double v) {
  std::ostringstream s;
  s.precision(3);
  s << v;
  return s.str();
}

}  // namespace internal

std::string toString(NoiseMethod method) {
  switch (method) {
    case NoiseMethod::kWhite: return "white";
    case NoiseMethod::kColoured: return "coloured";
    case NoiseMethod::kStaticPoses: return "static_poses";
    case NoiseMethod::kNotObservable: return "not_observable";
    case NoiseMethod::kDataSheet: return "data_sheet";
  }
  return "?";
}

Vec6 NoiseFloor::innovationStd() const {
  Vec6 out;
  for (int a = 0; a < 6; ++a) out(a) = std(a) * std::sqrt(std::max(0.0, 1.0 - ar1(a) * ar1(a)));
  return out;
}

double differenceNoiseStd(const std::vector<double>& x, int stride) {
  if (stride < 1) throw std::invalid_argument("differenceNoiseStd: stride must be >= 1");
  const std::size_t need = 4 * static_cast<std::size_t>(stride) + 4;
  if (x.size() < need) {
    throw DataError("noise floor: need at least " + std::to_string(need) + " samples, got " + std::to_string(x.size()));
  }
  std::vector<double> d;
  d.reserve(x.size());
  appendDifferences(x, stride, d);
  return kMadToStd * median(d) / std::sqrt(70.0);
}

namespace internal {

/// The white-noise estimator of differenceNoiseStd over several segments (each differenced on its
/// own); `fallback` when they hold fewer than 16 differences.
double differenceStdOf(const std::vector<std::vector<double>>& segments, double fallback) {
  std::vector<double> d;
  for (const auto& seg : segments) appendDifferences(seg, 1, d);
  return d.size() < 16 ? fallback : kMadToStd * median(d) / std::sqrt(70.0);
}

}  // namespace internal

double differenceVarianceFactor(double phi, int stride) {
  const double p = std::pow(phi, stride);
  return 70.0 - 112.0 * p + 56.0 * p * p - 16.0 * p * p * p + 2.0 * p * p * p * p;
}

Ar1Noise estimateAr1Noise(const std::vector<std::vector<double>>& segments) {
  // Robust spread of the differences at each stride, then the AR(1) phi whose variance factors
  // fit their growth with the stride best (least squares in log variance; sigma^2 profiled out).
  double logv[kMaxStride];
  for (int s = 1; s <= kMaxStride; ++s) {
    std::vector<double> d;
    for (const auto& seg : segments) {
      if (seg.size() >= 4 * kMaxStride + 1) appendDifferences(seg, s, d);
    }
    if (d.size() < 16) throw DataError("noise floor: too few consecutive samples for the difference estimate");
    const double sd = kMadToStd * median(d);
    logv[s - 1] = std::log(std::max(sd * sd, 1e-300));
  }
  double best_cost = 1e300, best_phi = 0.0, best_logs2 = 0.0;
  for (int k = 0; k <= 995; ++k) {
    const double phi = k * 1e-3;
    double lf[kMaxStride];
    double mean = 0.0;
    for (int s = 1; s <= kMaxStride; ++s) {
      lf[s - 1] = std::log(differenceVarianceFactor(phi, s));
      mean += (logv[s - 1] - lf[s - 1]) / kMaxStride;
    }
    double cost = 0.0;
    for (int s = 0; s < kMaxStride; ++s) cost += std::pow(logv[s] - lf[s] - mean, 2);
    if (cost < best_cost) {
      best_cost = cost;
      best_phi = phi;
      best_logs2 = mean;
    }
  }
  return {std::sqrt(std::exp(best_logs2)), best_phi};
}

std::vector<std::pair<int, int>> poseGroups(const std::vector<SampleContext>& ctx, bool* is_static) {
  std::vector<std::pair<int, int>> groups;
  const int n = static_cast<int>(ctx.size());
  bool stat = false;
  int pose_col = -1;
  if (n > 0 && ctx.front().extra_names != nullptr && ctx.front().extra != nullptr) {
    const auto& names = *ctx.front().extra_names;
    for (std::size_t k = 0; k < names.size(); ++k) {
      if (names[k] == "pose") pose_col = static_cast<int>(k);
    }
  }
  if (pose_col >= 0) {
    stat = true;
    int begin = 0;
    for (int i = 1; i <= n; ++i) {
      if (i == n || ctx[static_cast<std::size_t>(i)].extra[pose_col] != ctx[static_cast<std::size_t>(i - 1)].extra[pose_col]) {
        groups.emplace_back(begin, i);
        begin = i;
      }
    }
  } else if (n > 0 && !ctx.front().has_joints) {
    // A pose log (q = qd = 0): held still where the sensor pose does not change (rotation angle
    // plus displacement per sample: below 1e-3 rad/s or m/s at the median, within 1e-4 per sample).
    std::vector<double> speed(static_cast<std::size_t>(n), 0.0), step(static_cast<std::size_t>(n), 0.0);
    for (int i = 1; i < n; ++i) {
      const auto& a = ctx[static_cast<std::size_t>(i - 1)];
      const auto& b = ctx[static_cast<std::size_t>(i)];
      const double cos_angle = std::clamp(((a.R_BS.transpose() * b.R_BS).trace() - 1.0) / 2.0, -1.0, 1.0);
      step[static_cast<std::size_t>(i)] = std::acos(cos_angle) + (b.p_BS_B - a.p_BS_B).norm();
      const double dt = b.t - a.t;
      speed[static_cast<std::size_t>(i)] = dt > 0.0 ? step[static_cast<std::size_t>(i)] / dt : 0.0;
    }
    if (n > 1) speed[0] = speed[1];
    stat = median(speed) < 1e-3;
    if (stat) {
      int begin = 0;
      for (int i = 1; i <= n; ++i) {
        if (i == n || step[static_cast<std::size_t>(i)] > 1e-4) {
          groups.emplace_back(begin, i);
          begin = i;
        }
      }
    }
  } else if (n > 0) {
    std::vector<double> qd(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) qd[static_cast<std::size_t>(i)] = ctx[static_cast<std::size_t>(i)].qd.cwiseAbs().maxCoeff();
    std::vector<double> sorted = qd;  // median() reorders its argument
    stat = median(sorted) < 1e-3;
    if (stat) {
      // A held pose is a run of still readings (|qd| below 1e-3 rad/s, the rule's own measure) whose
      // q moves by at most 1e-4 rad per sample: a moving reading is a group of its own, so the slow
      // ends of a motion (q changing less than 1e-4 per sample) are no pose (their reading moves).
      auto moving = [&](int i) { return !(qd[static_cast<std::size_t>(i)] < 1e-3); };
      int begin = 0;
      for (int i = 1; i <= n; ++i) {
        if (i == n || moving(i) || moving(i - 1) ||
            (ctx[static_cast<std::size_t>(i)].q - ctx[static_cast<std::size_t>(i - 1)].q).cwiseAbs().maxCoeff() > 1e-4) {
          groups.emplace_back(begin, i);
          begin = i;
        }
      }
    }
  }
  if (is_static != nullptr) *is_static = stat;
  return groups;
}

bool holdsStill(const std::vector<SampleContext>& ctx) {
  bool is_static = false;
  (void)poseGroups(ctx, &is_static);
  const auto moving = std::count_if(ctx.begin(), ctx.end(), [](const SampleContext& c) {
    return c.has_joints && c.qd.cwiseAbs().maxCoeff() >= 1e-3;
  });
  return is_static && moving < kMinMovingSamples;
}

std::vector<int> foldBoundaries(const std::vector<SampleContext>& ctx, int folds) {
  const int n = static_cast<int>(ctx.size());
  std::vector<int> moving;  // indices of the moving samples
  for (int i = 0; i < n; ++i) {
    const SampleContext& c = ctx[static_cast<std::size_t>(i)];
    if (c.has_joints && c.qd.cwiseAbs().maxCoeff() >= 1e-3) moving.push_back(i);
  }
  const int m = static_cast<int>(moving.size());
  const bool by_motion = m < n && m >= 20 * folds;
  std::vector<int> b;
  b.reserve(static_cast<std::size_t>(folds) + 1);
  b.push_back(0);
  for (int f = 1; f < folds; ++f) {
    const long long share = static_cast<long long>(by_motion ? m : n) * f / folds;
    b.push_back(by_motion ? moving[static_cast<std::size_t>(share)] : static_cast<int>(share));
  }
  b.push_back(n);
  return b;
}

NoiseFloor dataSheetNoiseFloor(const Vec6& std) {
  NoiseFloor f;
  f.method = NoiseMethod::kDataSheet;
  f.std = std;
  f.detail = "from the sensor's data sheet (--noise), treated as white";
  return f;
}

namespace {

/// The pose groups with at least two readings, each split into ceil(n / kPoseWindow) windows of
/// as equal sizes as possible (a group of up to kPoseWindow readings is one window).
std::vector<std::pair<int, int>> holdWindows(const std::vector<std::pair<int, int>>& groups) {
  std::vector<std::pair<int, int>> out;
  for (const auto& group : groups) {
    const int begin = group.first;
    const int n = group.second - begin;
    if (n < 2) continue;
    const int k = (n + kPoseWindow - 1) / kPoseWindow;
    const auto at = [&](int w) { return begin + static_cast<int>(static_cast<long long>(n) * w / k); };
    for (int w = 0; w < k; ++w) out.emplace_back(at(w), at(w + 1));
  }
  return out;
}

}  // namespace

NoiseFloor estimateNoiseFloor(const std::vector<SampleContext>& ctx) {
  NoiseFloor f;
  const int n = static_cast<int>(ctx.size());
  if (n < 8) throw DataError("noise floor: need at least 8 samples, got " + std::to_string(n));
  bool is_static = false;
  const auto groups = poseGroups(ctx, &is_static);
  auto channel = [&](int a, int begin, int end) {
    std::vector<double> x;
    x.reserve(static_cast<std::size_t>(end - begin));
    for (int i = begin; i < end; ++i) x.push_back(ctx[static_cast<std::size_t>(i)].wrench_S(a));
    return x;
  };
  if (is_static) {
    f.pose_groups = static_cast<int>(groups.size());
    int repeated = 0, long_groups = 0;
    for (const auto& g : groups) {
      if (g.second - g.first >= 2) repeated += g.second - g.first;
      if (g.second - g.first >= 4 * kMaxStride + 1) long_groups += g.second - g.first;
    }
    if (repeated < n / 2 || repeated - static_cast<int>(groups.size()) < 12) {
      f.method = NoiseMethod::kNotObservable;
      f.detail = "static pose set with one reading per pose (" + std::to_string(groups.size()) +
                 " poses): the noise cannot be separated from the model error; the scale is the "
                 "cross-validated residual (give the data sheet's noise with --noise)";
      return f;
    }
    f.method = NoiseMethod::kStaticPoses;
    // Within each pose the reading is the noise around a constant: its lag-1 correlation by the
    // moments of the windows around their means (ar1FromWindows), its variance from the spread
    // around the means (corrected for the mean removal: E sum (x - mean)^2 = sigma^2 (m - sum_{i,j}
    // phi^|i-j| / m)).
    // A long hold is taken as consecutive windows of at most kPoseWindow readings (as equal as
    // possible), each around its own mean: a slow drift of the zero over the hold (temperature,
    // creep; a recording that rests for 20 s after its motion) is no noise.
    const auto windows = holdWindows(groups);
    for (int a = 0; a < 6; ++a) {
      std::vector<std::vector<double>> segs;
      for (const auto& g : windows) segs.push_back(channel(a, g.first, g.second));
      double phi = ar1FromWindows(segs);
      if (phi < kColouredPhi) phi = 0.0;
      double ss = 0.0, expected = 0.0;
      for (const auto& seg : segs) {
        double m = 0.0;
        for (double v : seg) m += v;
        m /= static_cast<double>(seg.size());
        for (double v : seg) ss += (v - m) * (v - m);
        expected += static_cast<double>(seg.size()) - correlationSum(phi, seg.size()) / static_cast<double>(seg.size());
      }
      f.std(a) = std::sqrt(ss / std::max(expected, 1e-12));
      f.ar1(a) = phi;
    }
    (void)long_groups;
    f.detail = "static pose set: spread of the repeated readings within each of " + std::to_string(groups.size()) +
               " poses" + (f.ar1.maxCoeff() > 0.0 ? ", correlated (lag-1 up to " + fmt(f.ar1.maxCoeff()) + ")" : "");
    return f;
  }
  // Dense time series.
  for (int a = 0; a < 6; ++a) {
    const std::vector<double> x = channel(a, 0, n);
    const double white = differenceNoiseStd(x, 1);
    f.std(a) = white;
    f.difference_std(a) = white;
    if (n >= 4 * kMaxStride + 1 + 16) {
      const Ar1Noise e = estimateAr1Noise({x});
      if (e.phi >= kColouredPhi) {
        f.std(a) = e.std;
        f.ar1(a) = e.phi;
      }
    }
  }
  if (f.ar1.maxCoeff() > 0.0) {
    f.method = NoiseMethod::kColoured;
    f.detail = "coloured (low-pass filtered or averaged) noise: spread of 4th differences grows with the stride; "
               "AR(1) lag-1 correlation up to " + fmt(f.ar1.maxCoeff());
  } else {
    f.method = NoiseMethod::kWhite;
    f.detail = "white noise: robust spread of the 4th-order differences of the readings";
  }
  return f;
}

Outliers detectOutliers(const Eigen::Matrix<double, 6, Eigen::Dynamic>& residual, bool time_series, double threshold,
                        const std::vector<int>& segment_starts) {
  Outliers out;
  const int n = static_cast<int>(residual.cols());
  if (n < 8 || !(threshold > 0.0)) return out;
  std::vector<int> starts = segment_starts.empty() ? std::vector<int>{0} : segment_starts;
  starts.push_back(n);
  Eigen::Matrix<double, 6, Eigen::Dynamic> score(6, n);
  std::vector<double> h(static_cast<std::size_t>(n)), win;
  for (int a = 0; a < 6; ++a) {
    if (time_series) {
      for (std::size_t s = 0; s + 1 < starts.size(); ++s) {
        const int b0 = starts[s], b1 = starts[s + 1];
        for (int i = b0; i < b1; ++i) {
          win.clear();
          for (int j = std::max(b0, i - 3); j <= std::min(b1 - 1, i + 3); ++j) win.push_back(residual(a, j));
          h[static_cast<std::size_t>(i)] = residual(a, i) - median(win);
        }
      }
    } else {
      std::vector<double> all(static_cast<std::size_t>(n));
      for (int i = 0; i < n; ++i) all[static_cast<std::size_t>(i)] = residual(a, i);
      const double m = median(all);
      for (int i = 0; i < n; ++i) h[static_cast<std::size_t>(i)] = residual(a, i) - m;
    }
    std::vector<double> dev(h.size());
    for (std::size_t i = 0; i < h.size(); ++i) dev[i] = std::abs(h[i]);
    const double sigma = kMadToStd * median(dev);
    for (int i = 0; i < n; ++i) score(a, i) = sigma > 0.0 ? std::abs(h[static_cast<std::size_t>(i)]) / sigma : 0.0;
    if (time_series) {
      // A spike also stands out from the line through its two neighbours, which smooth model
      // error (curvature over two samples) does not: both tests must flag it.
      std::vector<double> g(static_cast<std::size_t>(n), 0.0);
      for (std::size_t s = 0; s + 1 < starts.size(); ++s) {
        for (int i = starts[s]; i < starts[s + 1]; ++i) {
          const int l = i > starts[s] ? i - 1 : i + 1;
          const int r = i + 1 < starts[s + 1] ? i + 1 : i - 1;
          if (l < starts[s] || r >= starts[s + 1]) continue;
          g[static_cast<std::size_t>(i)] = residual(a, i) - 0.5 * (residual(a, l) + residual(a, r));
        }
      }
      for (std::size_t i = 0; i < g.size(); ++i) dev[i] = std::abs(g[i]);
      const double sg = kMadToStd * median(dev);
      for (int i = 0; i < n; ++i) {
        const double s2 = sg > 0.0 ? std::abs(g[static_cast<std::size_t>(i)]) / sg : 0.0;
        score(a, i) = std::min(score(a, i), s2);
      }
    }
  }
  for (int i = 0; i < n; ++i) {
    int axis = 0;
    const double worst = score.col(i).maxCoeff(&axis);
    if (worst > threshold) {
      out.samples.push_back(i);
      out.axes.push_back(axis);
    }
  }
  return out;
}

Vec6 parseNoiseSpec(const std::string& spec, const std::string& what) {
  Vec6 out = Vec6::Constant(-1.0);
  std::stringstream ss(spec);
  std::string item;
  while (std::getline(ss, item, ',')) {
    const auto eq = item.find('=');
    if (eq == std::string::npos) throw ConfigError(what + ": expected axis=std, got '" + item + "'");
    const std::string key = item.substr(0, eq);
    int axis = -1;
    for (int a = 0; a < 6; ++a) {
      if (key == kWrenchAxisNames[a]) axis = a;
    }
    if (axis < 0) throw ConfigError(what + ": unknown axis '" + key + "' (fx, fy, fz, tx, ty, tz)");
    const std::string val = item.substr(eq + 1);
    std::size_t used = 0;
    double v = 0.0;
    try {
      v = std::stod(val, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != val.size() || !std::isfinite(v) || !(v > 0.0)) {
      throw ConfigError(what + ": " + key + ": not a positive number: '" + val + "'");
    }
    out(axis) = v;
  }
  for (int a = 0; a < 6; ++a) {
    if (out(a) < 0.0) throw ConfigError(what + ": missing " + kWrenchAxisNames[a] + " (give all six: fx=..,fy=..,fz=..,tx=..,ty=..,tz=..)");
  }
  return out;
}

}  // namespace ftid::identify
