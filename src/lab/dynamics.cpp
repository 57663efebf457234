// Sensor and mount dynamics in the laboratory (ftid/lab/dynamics.hpp, dynamics_check.hpp): the
// discrete filters, the grid search on the last model's filtered design and its judgement.
#include "dynamics_check.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>

#include "ftid/identify/noise.hpp"

namespace ftid::lab {

namespace {
constexpr double kPi = 3.14159265358979323846;
}  // namespace

void secondOrderFilter(std::vector<double>& x, double f_hz, double zeta, double dt_s) {
  if (x.empty()) return;
  const double w = 2.0 * kPi * f_hz;
  const double k = w / std::tan(0.5 * w * dt_s);  // prewarped: the resonance stays at f_hz
  const double a0 = k * k + 2.0 * zeta * w * k + w * w, a1 = 2.0 * (w * w - k * k),
               a2 = k * k - 2.0 * zeta * w * k + w * w;
  double u1 = x[0], u2 = x[0], y1 = x[0], y2 = x[0];  // at rest at x[0]
  for (double& v : x) {
    const double u = v;
    const double y = (w * w * (u + 2.0 * u1 + u2) - a1 * y1 - a2 * y2) / a0;
    u2 = u1;
    u1 = u;
    y2 = y1;
    y1 = y;
    v = y;
  }
}

void firstOrderFilter(std::vector<double>& x, double f_hz, double dt_s) {
  if (x.empty()) return;
  const double w = 2.0 * kPi * f_hz;
  const double k = w / std::tan(0.5 * w * dt_s);
  double u1 = x[0], y1 = x[0];
  for (double& v : x) {
    const double u = v;
    const double y = (w * (u + u1) - (w - k) * y1) / (k + w);
    u1 = u;
    y1 = y;
    v = y;
  }
}

std::string dynamicsLine(const DynamicsCheck& d, const Vec6& noise_floor) {
  if (!d.tested) return d.note.empty() ? "" : "dynamics of the reading: not tested (" + d.note + ")";
  double worst = 0.0;
  for (int a = 0; a < 6; ++a) worst = std::max(worst, d.residual_rms(a) / std::max(noise_floor(a), 1e-12));
  char b[400];
  if (d.effect == "mount_dynamics") {
    std::snprintf(b, sizeof b, "mount_dynamics (2nd order) f_n = %.3g Hz, damping %.2g", d.f_hz, d.zeta);
  } else {
    std::snprintf(b, sizeof b, "sensor_filter (1st order) cut-off %.3g Hz", d.f_hz);
  }
  std::string out = std::string("dynamics of the reading: ") + (d.significant ? "found, " : "best, ") + b;
  char p[32];
  std::snprintf(p, sizeof p, d.family_p < 1e-300 ? "< 1e-300" : "= %.2g", d.family_p);
  std::snprintf(b, sizeof b,
                ": held-out error %+.1f %%, residual up to %.2fx the noise floor, family-wise p %s (%d filters "
                "tried)%s",
                -100.0 * d.relative_reduction, worst, p, d.grid_points,
                d.significant ? "" : ": not significant, nothing of the kind");
  return out + b;
}

}  // namespace ftid::lab

namespace ftid::lab::detail {

namespace {

using Design = Engine::Design;
using Filter = std::function<void(std::vector<double>&)>;

/// Runs [begin, end) of consecutive active samples within each log (a delay leaves the samples
/// whose shifted kinematics fall outside their log inactive, with zero rows: a filter started on
/// them would ring from the step to the first real row).
std::vector<std::pair<int, int>> filterRuns(const Dataset& d, const std::vector<char>& active) {
  std::vector<int> starts = d.segment_start.empty() ? std::vector<int>{0} : d.segment_start;
  starts.push_back(d.size());
  std::vector<std::pair<int, int>> runs;
  for (std::size_t s = 0; s + 1 < starts.size(); ++s) {
    int begin = -1;
    for (int i = starts[s]; i <= starts[s + 1]; ++i) {
      const bool on = i < starts[s + 1] && (active.empty() || active[static_cast<std::size_t>(i)] != 0);
      if (on && begin < 0) begin = i;
      if (!on && begin >= 0) {
        runs.emplace_back(begin, i);
        begin = -1;
      }
    }
  }
  return runs;
}

/// The raw design with every column but the measurement filtered along time within each run.
Design filteredDesign(const Engine& eng, Design X, const std::vector<std::pair<int, int>>& runs, const Filter& filter) {
  const Eigen::Index cols = X.cols() - 1;
  std::vector<double> x;
  for (const auto& [b, e] : runs) {
    for (int a = 0; a < 6; ++a) {
      for (Eigen::Index c = 0; c < cols; ++c) {
        x.clear();
        for (int i = b; i < e; ++i) x.push_back(X(eng.core().rowOf(i, a), c));
        filter(x);
        for (int i = b; i < e; ++i) X(eng.core().rowOf(i, a), c) = x[static_cast<std::size_t>(i - b)];
      }
    }
  }
  return X;
}

struct Trial {
  double f = 0.0, zeta = 0.0, sse = 0.0;
};

/// In-sample weighted SSE of the last model through the filter.
double trialSse(const Engine& eng, const Design& raw, const std::vector<std::pair<int, int>>& runs,
                const Filter& filter) {
  Design X = filteredDesign(eng, raw, runs, filter);
  eng.core().whiten(X, 0, static_cast<int>(X.cols()));
  return eng.solve(X, false).sse_fit;
}

/// Golden-section search of g on [lo, hi] (g unimodal there), 12 evaluations.
double golden(const std::function<double(double)>& g, double lo, double hi) {
  const double r = 0.5 * (std::sqrt(5.0) - 1.0);
  double c = hi - r * (hi - lo), d = lo + r * (hi - lo), gc = g(c), gd = g(d);
  for (int k = 0; k < 10; ++k) {
    if (gc < gd) {
      hi = d;
      d = c;
      gd = gc;
      c = hi - r * (hi - lo);
      gc = g(c);
    } else {
      lo = c;
      c = d;
      gc = gd;
      d = lo + r * (hi - lo);
      gd = g(d);
    }
  }
  return 0.5 * (lo + hi);
}

/// Whether the last model leaves something: a spectral peak, or a held-out residual above
/// identify::kAboveFloorMark times the noise floor on some axis (the floor: the weights'
/// innovation std over sqrt(1 - phi^2)).
bool somethingLeft(const Dataset& d, const Solution& sol, bool spectral_peak) {
  if (spectral_peak) return true;
  for (int a = 0; a < 6; ++a) {
    const double floor = 1.0 / (d.weights(a) * std::sqrt(std::max(1e-6, 1.0 - d.ar1(a) * d.ar1(a))));
    const double rms = std::sqrt(sol.sse_heldout_axis(a) / std::max(1, sol.n_heldout));
    if (rms > identify::kAboveFloorMark * floor) return true;
  }
  return false;
}

double sampleStep(const Dataset& d) {
  std::vector<double> steps;
  for (int i = 1; i < d.n_fit; ++i) {
    const double s = d.ctx[static_cast<std::size_t>(i)].t - d.ctx[static_cast<std::size_t>(i - 1)].t;
    if (s > 0.0) steps.push_back(s);
  }
  if (steps.empty()) return 0.0;
  std::nth_element(steps.begin(), steps.begin() + static_cast<std::ptrdiff_t>(steps.size() / 2), steps.end());
  return steps[steps.size() / 2];
}

}  // namespace

DynamicsCheck checkDynamics(const RankContext& rc, const Fitted& last, double motion_band_hz, bool spectral_peak) {
  DynamicsCheck out;
  const Engine& eng = rc.eng;
  const double dt = sampleStep(eng.data());
  if (eng.data().static_data) {
    out.note = "a static pose set: the reading's dynamics show only while it changes";
    return out;
  }
  if (!(dt > 0.0)) {
    out.note = "no time series";
    return out;
  }
  if (!rc.options.always_search_dynamics && !somethingLeft(eng.data(), last.sol, spectral_peak)) {
    out.note = "the last model's held-out residual is within " + fmt(identify::kAboveFloorMark, 3) +
                 "x the noise floor with no spectral peak";
    return out;
  }
  const Design raw = eng.rawDesign(last.model, last.lin);
  const auto runs = filterRuns(eng.data(), last.lin.active);
  const double f_lo = std::max(0.5, 0.5 * motion_band_hz), f_hi = 0.4 / dt;
  if (!(f_hi > 2.0 * f_lo)) {
    out.note = "the sample rate leaves no band above the motion";
    return out;
  }
  constexpr int kFreqs = 12;  // 1.5x apart over 0.5 .. 50 Hz at 125 Hz; the refinement does the rest
  const std::vector<double> zetas = {0.05, 0.15, 0.4, 1.0};
  auto freq = [&](double k) { return f_lo * std::pow(f_hi / f_lo, k / (kFreqs - 1)); };
  auto mount = [&](double f, double z) {
    return trialSse(eng, raw, runs, [&](std::vector<double>& x) { secondOrderFilter(x, f, z, dt); });
  };
  auto lowpass = [&](double f) { return trialSse(eng, raw, runs, [&](std::vector<double>& x) { firstOrderFilter(x, f, dt); }); };
  Trial best_m{0, 0, 1e300}, best_f{0, 0, 1e300};
  int best_mk = 0, best_mz = 0, best_fk = 0;
  for (int k = 0; k < kFreqs; ++k) {
    for (std::size_t z = 0; z < zetas.size(); ++z) {
      const double s = mount(freq(k), zetas[z]);
      if (s < best_m.sse) best_m = {freq(k), zetas[z], s}, best_mk = k, best_mz = static_cast<int>(z);
    }
    const double s = lowpass(freq(k));
    if (s < best_f.sse) best_f = {freq(k), 0.0, s}, best_fk = k;
  }
  out.grid_points = kFreqs * static_cast<int>(zetas.size() + 1);
  // Refine by turns in log f_n and in zeta: first between the neighbouring grid points, then in
  // brackets narrowing around the current point (f_n and zeta are coupled near the optimum).
  double lf_lo = std::log(freq(std::max(0, best_mk - 1))), lf_hi = std::log(freq(std::min(kFreqs - 1, best_mk + 1)));
  double z_lo = zetas[static_cast<std::size_t>(std::max(0, best_mz - 1))];
  double z_hi = zetas[static_cast<std::size_t>(std::min<int>(static_cast<int>(zetas.size()) - 1, best_mz + 1))];
  for (int pass = 0; pass < 3; ++pass) {
    best_m.f = std::exp(golden([&](double l) { return mount(std::exp(l), best_m.zeta); }, lf_lo, lf_hi));
    best_m.zeta = golden([&](double z) { return mount(best_m.f, z); }, z_lo, z_hi);
    const double span = 0.2 / (pass + 1);
    lf_lo = std::max(std::log(f_lo), std::log(best_m.f) - span);
    lf_hi = std::min(std::log(f_hi), std::log(best_m.f) + span);
    z_lo = best_m.zeta * std::exp(-2.0 * span);
    z_hi = std::min(2.0, best_m.zeta * std::exp(2.0 * span));
  }
  best_m.sse = mount(best_m.f, best_m.zeta);
  const double lf = golden([&](double l) { return lowpass(std::exp(l)); }, std::log(freq(std::max(0, best_fk - 1))),
                           std::log(freq(std::min(kFreqs - 1, best_fk + 1))));
  best_f = {std::exp(lf), 0.0, lowpass(std::exp(lf))};
  const bool is_mount = best_m.sse < best_f.sse;
  const Trial& b = is_mount ? best_m : best_f;
  const Filter filter = is_mount ? Filter([&](std::vector<double>& x) { secondOrderFilter(x, b.f, b.zeta, dt); })
                                 : Filter([&](std::vector<double>& x) { firstOrderFilter(x, b.f, dt); });
  const Design fraw = filteredDesign(eng, raw, runs, filter);
  Design X = fraw;
  eng.core().whiten(X, 0, static_cast<int>(X.cols()));
  const Solution sol = eng.solve(X, true, &fraw);
  out.tested = true;
  out.effect = is_mount ? "mount_dynamics" : "sensor_filter";
  out.f_hz = b.f;
  out.zeta = b.zeta;
  out.residual_rms = (sol.sse_heldout_axis / std::max(1, sol.n_heldout)).cwiseSqrt();
  out.relative_reduction = std::clamp(1.0 - sol.sse_heldout / last.sol.sse_heldout, -1.0, 1.0);
  const int k = is_mount ? 2 : 1;
  const double sigma2 = sol.sse_fit / std::max(1, sol.rows_fit - sol.rank - k);
  const double gain = std::max(0.0, last.sol.sse_fit - sol.sse_fit);
  out.p_value = chiSquareSurvivalUncertainScale(gain / std::max(sigma2, 1e-300), k, rc.scale_sd);
  out.family_p = std::min(1.0, out.grid_points * out.p_value);
  out.significant = out.family_p < rc.options.family_alpha && out.relative_reduction > rc.options.search_heldout_margin;
  return out;
}

}  // namespace ftid::lab::detail
