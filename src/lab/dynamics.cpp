// Sensor and mount dynamics in the laboratory (ftid/lab/dynamics.hpp, dynamics_check.hpp): the
// discrete filters, the grid search on the last model's filtered design and its judgement.
#include "dynamics_check.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <functional>
#include <utility>

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

std::string delayAgainstLagLine(const DynamicsCheck& d) {
  const DynamicsCheck::DelayAgainstLag& g = d.delay;
  if (!g.tested) return "";
  auto filter = [](const std::string& effect, double f, double zeta, double lag) {
    char b[200];
    if (effect == "mount_dynamics") {
      std::snprintf(b, sizeof b, "f_n = %.3g Hz, damping %.2g, lag 2 zeta / w_n = %.3g ms", f, zeta, 1e3 * lag);
    } else {
      std::snprintf(b, sizeof b, "cut-off %.3g Hz, lag 1 / w_c = %.3g ms", f, 1e3 * lag);
    }
    return std::string(b);
  };
  const std::string joint = "fitted together with the filter above (" + filter(d.effect, d.f_hz, d.zeta, g.lag_s) +
                            "), the delay is " + detail::fmt(1e3 * g.delay_s, 2) + " ms";
  const std::string head = "the model's sensor_delay of " + detail::fmt(1e3 * g.model_delay_s, 3) +
                           " ms against the reading's lag: ";
  if (!g.imu_compared) {
    return head + joint + "; without an IMU a delay and a filter's lag trade off at the motion's frequencies (the "
                          "IMU's stream delay would tell them apart)";
  }
  char p[32];
  std::snprintf(p, sizeof p, g.family_p < 1e-300 ? "< 1e-300" : "= %.2g", g.family_p);
  const std::string held = "held at the IMU's stream delay (" + detail::fmt(1e3 * g.imu_delay_s, 2) +
                           " ms) with the filter searched again (" +
                           filter(g.held_effect, g.held_f_hz, g.held_zeta, g.held_lag_s) + "), the rule " +
                           (g.delay_is_lag ? "does not take" : "takes") + " a different delay (" +
                           (g.delay_is_lag && !g.reason.empty() ? g.reason : "family-wise p " + std::string(p)) + ")";
  if (g.delay_is_lag) {
    return head + held + ": the model's delay is consistent with the IMU's stream delay plus the reading's lag (as "
                         "a delay it still approximates the lag in compensation)";
  }
  return head + held + "; " + joint + ": the wrench lags the IMU beyond the filter's lag (a set-up error or a bad IMU)";
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

/// The model's raw design through a filter, whitened and solved with the folds.
Solution solveFiltered(const Engine& eng, const Design& raw, const std::vector<std::pair<int, int>>& runs,
                       const Filter& filter) {
  const Design fraw = filteredDesign(eng, raw, runs, filter);
  Design X = fraw;
  eng.core().whiten(X, 0, static_cast<int>(X.cols()));
  return eng.solve(X, true, &fraw);
}

/// The reading's filter: mount_dynamics (2nd order, f_n and damping) or sensor_filter (1st order).
Filter makeFilter(bool is_mount, double f_hz, double zeta, double dt) {
  if (is_mount) return [f_hz, zeta, dt](std::vector<double>& x) { secondOrderFilter(x, f_hz, zeta, dt); };
  return [f_hz, dt](std::vector<double>& x) { firstOrderFilter(x, f_hz, dt); };
}

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

/// The filter's group delay at low frequency: 2 zeta / w_n (2nd order, zeta > 0) or 1 / w_c
/// (1st order, zeta = 0).
double filterLag(double f_hz, double zeta) {
  const double w = 2.0 * kPi * f_hz;
  return zeta > 0.0 ? 2.0 * zeta / w : 1.0 / w;
}

/// `last` (which fits sensor_delay) relinearised at the delay `delay_s` (within the treatment's
/// range), its delay column rebuilt there.
Linearization linearizationAt(const Engine& eng, const Fitted& last, double delay_s) {
  Linearization lin = last.lin;
  if (!lin.delay_column) return lin;
  const double max_delay = eng.core().treatment().max_delay_s;
  lin.delay = std::clamp(delay_s, -max_delay, max_delay);
  eng.core().updateActive(lin);
  eng.delayColumn(last.model, lin, last.sol.theta);
  return lin;
}

/// `last` relinearised at its delay minus `lag_s`: read through a filter of that lag, the filter
/// takes that share of the delay and the delay column corrects what is left.
Linearization laggedLinearization(const Engine& eng, const Fitted& last, double lag_s) {
  return linearizationAt(eng, last, last.lin.delay - lag_s);
}

/// The search over filters of checkDynamics: a grid of 12 frequencies (1.5x apart over 0.5 .. 50 Hz
/// at 125 Hz) and, for the 2nd order, 4 dampings, then golden-section refinement. `mount(f, zeta)`
/// and `lowpass(f)` give a trial filter's in-sample SSE.
class FilterSearch {
 public:
  using MountSse = std::function<double(double, double)>;
  using LowpassSse = std::function<double(double)>;
  FilterSearch(MountSse mount, LowpassSse lowpass, double f_lo, double f_hi)
      : mount_(std::move(mount)), lowpass_(std::move(lowpass)), f_lo_(f_lo), f_hi_(f_hi) {}

  int gridPoints() const { return kFreqs * static_cast<int>(kZetas.size() + 1); }

  /// The best 2nd- and 1st-order filters: the grid's best of each, refined; a seed's filter (of its
  /// kind) is refined too, and the best of all stands.
  std::pair<Trial, Trial> run(const DynamicsCheck* seed) const {
    Trial best_m{0, 0, 1e300}, best_f{0, 0, 1e300};
    int best_mk = 0, best_mz = 0, best_fk = 0;
    for (int k = 0; k < kFreqs; ++k) {
      for (std::size_t z = 0; z < kZetas.size(); ++z) {
        const double s = mount_(freq(k), kZetas[z]);
        if (s < best_m.sse) best_m = {freq(k), kZetas[z], s}, best_mk = k, best_mz = static_cast<int>(z);
      }
      const double s = lowpass_(freq(k));
      if (s < best_f.sse) best_f = {freq(k), 0.0, s}, best_fk = k;
    }
    best_m = refineMount(best_m, best_mk, best_mz);
    best_f = refineLowpass(best_fk);
    if (seed != nullptr && seed->tested && seed->effect == "mount_dynamics") {
      const int mz = static_cast<int>(std::min_element(kZetas.begin(), kZetas.end(), [&](double x, double y) {
                                        return std::abs(std::log(x / seed->zeta)) < std::abs(std::log(y / seed->zeta));
                                      }) - kZetas.begin());
      for (const Trial& t : {Trial{seed->f_hz, seed->zeta, mount_(seed->f_hz, seed->zeta)},
                             refineMount({seed->f_hz, seed->zeta, 0.0}, nearest(seed->f_hz), mz)}) {
        if (t.sse < best_m.sse) best_m = t;
      }
    } else if (seed != nullptr && seed->tested) {
      for (const Trial& t : {Trial{seed->f_hz, 0.0, lowpass_(seed->f_hz)}, refineLowpass(nearest(seed->f_hz))}) {
        if (t.sse < best_f.sse) best_f = t;
      }
    }
    return {best_m, best_f};
  }

 private:
  static constexpr int kFreqs = 12;
  static constexpr std::array<double, 4> kZetas = {0.05, 0.15, 0.4, 1.0};

  double freq(double k) const { return f_lo_ * std::pow(f_hi_ / f_lo_, k / (kFreqs - 1)); }
  int nearest(double f) const {
    const double k = std::round((kFreqs - 1) * std::log(f / f_lo_) / std::log(f_hi_ / f_lo_));
    return static_cast<int>(std::clamp(k, 0.0, kFreqs - 1.0));
  }
  static double zetaAt(int z) { return kZetas[static_cast<std::size_t>(std::clamp(z, 0, static_cast<int>(kZetas.size()) - 1))]; }

  /// By turns in log f_n at a fixed lag 2 zeta / w_n (zeta = pi f_n lag) and in log lag at a fixed
  /// f_n: first between the neighbouring grid points, then in brackets narrowing around the current
  /// point. The data fix the reading's lag best, so f_n and zeta lie on a ridge of constant lag,
  /// along which turns in f_n and zeta would crawl.
  Trial refineMount(Trial m, int mk, int mz) const {
    auto at = [&](double f, double lag) { return mount_(f, std::clamp(kPi * f * lag, 1e-3, 2.0)); };
    double lag = m.zeta / (kPi * m.f);
    double lf_lo = std::log(freq(std::max(0, mk - 1))), lf_hi = std::log(freq(std::min(kFreqs - 1, mk + 1)));
    double ll_lo = std::log(zetaAt(mz - 1) / (kPi * m.f)), ll_hi = std::log(zetaAt(mz + 1) / (kPi * m.f));
    for (int pass = 0; pass < 3; ++pass) {
      m.f = std::exp(golden([&](double l) { return at(std::exp(l), lag); }, lf_lo, lf_hi));
      lag = std::exp(golden([&](double l) { return at(m.f, std::exp(l)); }, ll_lo, ll_hi));
      const double span = 0.2 / (pass + 1);
      lf_lo = std::max(std::log(f_lo_), std::log(m.f) - span);
      lf_hi = std::min(std::log(f_hi_), std::log(m.f) + span);
      ll_lo = std::log(lag) - 2.0 * span;
      ll_hi = std::min(std::log(2.0 / (kPi * m.f)), std::log(lag) + 2.0 * span);
    }
    m.zeta = std::clamp(kPi * m.f * lag, 1e-3, 2.0);
    m.sse = mount_(m.f, m.zeta);
    return m;
  }
  Trial refineLowpass(int fk) const {
    const double lf = golden([&](double l) { return lowpass_(std::exp(l)); }, std::log(freq(std::max(0, fk - 1))),
                             std::log(freq(std::min(kFreqs - 1, fk + 1))));
    return Trial{std::exp(lf), 0.0, lowpass_(std::exp(lf))};
  }

  MountSse mount_;
  LowpassSse lowpass_;
  double f_lo_, f_hi_;
};

}  // namespace

DynamicsCheck checkDynamics(const RankContext& rc, const Fitted& last, double motion_band_hz, bool spectral_peak,
                            const DynamicsCheck* seed) {
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
  // A fitted sensor_delay may be a filter's lag (judgeDelayAgainstLag): searched then too.
  if (!rc.options.always_search_dynamics && !last.lin.delay_column && !somethingLeft(eng.data(), last.sol, spectral_peak)) {
    out.note = "the last model's held-out residual is within " + fmt(identify::kAboveFloorMark, 3) +
                 "x the noise floor with no spectral peak, and it fits no delay";
    return out;
  }
  const Design raw = eng.rawDesign(last.model, last.lin);
  const auto runs = filterRuns(eng.data(), last.lin.active);
  // Each trial through a filter of lag L: a model with sensor_delay relinearised at delay - L.
  auto sseThrough = [&](double lag_s, const Filter& filter) {
    if (!last.lin.delay_column) return trialSse(eng, raw, runs, filter);
    const Linearization lin = laggedLinearization(eng, last, lag_s);
    return trialSse(eng, eng.rawDesign(last.model, lin), filterRuns(eng.data(), lin.active), filter);
  };
  const double f_lo = std::max(0.5, 0.5 * motion_band_hz), f_hi = 0.4 / dt;
  if (!(f_hi > 2.0 * f_lo)) {
    out.note = "the sample rate leaves no band above the motion";
    return out;
  }
  const FilterSearch search(
      [&](double f, double z) {
        return sseThrough(filterLag(f, z), [&](std::vector<double>& x) { secondOrderFilter(x, f, z, dt); });
      },
      [&](double f) { return sseThrough(filterLag(f, 0.0), [&](std::vector<double>& x) { firstOrderFilter(x, f, dt); }); },
      f_lo, f_hi);
  out.grid_points = search.gridPoints();
  const auto [best_m, best_f] = search.run(seed);
  const bool is_mount = best_m.sse < best_f.sse;
  const Trial& b = is_mount ? best_m : best_f;
  const Filter filter = makeFilter(is_mount, b.f, b.zeta, dt);
  const Linearization lin_b = laggedLinearization(eng, last, filterLag(b.f, b.zeta));
  const Solution sol = last.lin.delay_column
                           ? solveFiltered(eng, eng.rawDesign(last.model, lin_b), filterRuns(eng.data(), lin_b.active), filter)
                           : solveFiltered(eng, raw, runs, filter);
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

namespace {

/// `last` (which fits sensor_delay) read through `filter`, its delay refined by Gauss-Newton steps
/// of the filtered solve (the other nonlinear parameters stay linearised at `last`'s: their
/// columns take their share of each step). Returns the linearisation and the filtered fit with the
/// lowest in-sample error seen: a step that raises it is not kept, so the result fits at least as
/// well as `last`'s own linearisation through the filter.
std::pair<Linearization, Solution> delayThroughFilter(const Engine& eng, const Fitted& last, const Filter& filter) {
  Linearization lin = last.lin;
  const int k = lin.delayColumn(last.model.numParams());
  const double max_delay = eng.core().treatment().max_delay_s;
  Solution f = solveFiltered(eng, eng.rawDesign(last.model, lin), filterRuns(eng.data(), lin.active), filter);
  std::pair<Linearization, Solution> best{lin, f};
  for (int it = 0; it < 8; ++it) {
    const double step = std::clamp(f.theta(k), -max_delay - lin.delay, max_delay - lin.delay);
    if (!std::isfinite(step) || std::abs(step) < 1e-6) break;
    lin.delay += step;
    eng.core().updateActive(lin);
    eng.delayColumn(last.model, lin, f.theta);
    f = solveFiltered(eng, eng.rawDesign(last.model, lin), filterRuns(eng.data(), lin.active), filter);
    if (!(f.sse_fit < best.second.sse_fit)) break;
    best = {lin, f};
  }
  return best;
}

}  // namespace

namespace {

/// The samples active in both (an empty set: all).
std::vector<char> activeInBoth(const std::vector<char>& a, const std::vector<char>& b) {
  if (a.empty()) return b;
  if (b.empty()) return a;
  std::vector<char> both(a.size(), 0);
  for (std::size_t i = 0; i < a.size() && i < b.size(); ++i) both[i] = (a[i] != 0 && b[i] != 0) ? 1 : 0;
  return both;
}

/// `last` with its delay held at `delay_s` (no delay column) on the samples active there and in
/// `also` (so that two delays are compared on the same samples), solved with the folds.
Fitted delayHeld(const Engine& eng, const Fitted& last, double delay_s, const std::vector<char>& also) {
  Fitted held{last.model, last.lin, {}};
  held.lin.delay = delay_s;
  held.lin.delay_column = false;
  eng.core().updateActive(held.lin);
  held.lin.active = activeInBoth(held.lin.active, also);
  const Design raw = eng.rawDesign(held.model, held.lin);
  Design X = raw;
  eng.core().whiten(X, 0, static_cast<int>(X.cols()));
  held.sol = eng.solve(X, true, &raw);
  return held;
}

Filter filterOf(const DynamicsCheck& d, double dt) { return makeFilter(d.effect == "mount_dynamics", d.f_hz, d.zeta, dt); }

struct FreeDelay {
  Solution sol;
  double delay_s = 0.0;
};

/// The delay set free, solved on the samples `active`, at the lowest in-sample error of: `lin_d`
/// through `filter_d` (the joint search's filter, the delay refined from the model's minus the
/// lag), and through `filter_held` (the search's with the delay held at the IMU's) at the IMU's
/// delay and refined from there. The second nests the held model (the same filter and samples, one
/// column more), so the free delay never fits worse than the held one: its gain is a profile
/// likelihood ratio with 1 dof, not a comparison with a fit that stopped on another ridge.
FreeDelay freeDelay(const Engine& eng, const Fitted& last, const Linearization& lin_d, const Filter& filter_d,
                    double imu_delay_s, const Filter& filter_held, const std::vector<char>& active) {
  const int k = lin_d.delayColumn(last.model.numParams());
  auto solveOn = [&](Linearization lin, const Filter& filter) {
    lin.active = active;
    Solution sol = solveFiltered(eng, eng.rawDesign(last.model, lin), filterRuns(eng.data(), lin.active), filter);
    const double delay_s = lin.delay + sol.theta(k);
    return FreeDelay{std::move(sol), delay_s};
  };
  const Fitted at_imu{last.model, linearizationAt(eng, last, imu_delay_s), last.sol};
  FreeDelay best = solveOn(lin_d, filter_d);
  for (const Linearization& lin : {at_imu.lin, delayThroughFilter(eng, at_imu, filter_held).first}) {
    FreeDelay f = solveOn(lin, filter_held);
    if (f.sol.sse_fit < best.sol.sse_fit) best = std::move(f);
  }
  return best;
}

}  // namespace

void judgeDelayAgainstLag(const RankContext& rc, const Fitted& last, const identify::ImuReport& imu,
                          double motion_band_hz, DynamicsCheck* d) {
  d->delay = {};
  if (!d->significant || !last.lin.delay_column) return;
  const Engine& eng = rc.eng;
  const double dt = sampleStep(eng.data());
  DynamicsCheck::DelayAgainstLag& g = d->delay;
  g.tested = true;
  g.lag_s = filterLag(d->f_hz, d->effect == "mount_dynamics" ? d->zeta : 0.0);
  g.model_delay_s = last.lin.delay;
  // The delay free: through d's filter (the joint search's), refined from the model's delay minus the lag.
  const Fitted start{last.model, laggedLinearization(eng, last, g.lag_s), last.sol};
  auto [lin, rich] = delayThroughFilter(eng, start, filterOf(*d, dt));
  const std::vector<std::string> names = fittedNames(last.model, lin);
  const FitView rich_view = fitView(last.model, lin, rich, &names, eng.data().ctx);
  g.delay_s = rich_view.theta(lin.delayColumn(last.model.numParams()));
  if (!imu.used || !imu.estimate.gyro.delay_estimated) return;
  // The delay held at the IMU's, the filter searched again: the profile of the filter's parameters
  // on both sides, so the gain is the delay's alone (one parameter: chi-square with 1 dof).
  g.imu_delay_s = imu.estimate.gyro.delay_s;
  const Fitted held = delayHeld(eng, last, g.imu_delay_s, lin.active);
  const DynamicsCheck found = checkDynamics(rc, held, motion_band_hz, true, d);
  if (!found.tested) return;
  const FreeDelay free = freeDelay(eng, last, lin, filterOf(*d, dt), g.imu_delay_s, filterOf(found, dt), held.lin.active);
  rich = free.sol;
  g.delay_s = free.delay_s;
  const Solution simple =
      solveFiltered(eng, eng.rawDesign(held.model, held.lin), filterRuns(eng.data(), held.lin.active), filterOf(found, dt));
  g.imu_compared = true;
  g.held_effect = found.effect;
  g.held_f_hz = found.f_hz;
  g.held_zeta = found.zeta;
  g.held_lag_s = filterLag(found.f_hz, found.effect == "mount_dynamics" ? found.zeta : 0.0);
  const double sigma2 = rich.sse_fit / std::max(1, rich.rows_fit - rich.rank);
  const double gain = std::max(0.0, simple.sse_fit - rich.sse_fit);
  RuleInputs in;
  in.family_size = rc.family_size;
  in.family_alpha = rc.options.family_alpha;
  in.heldout_reduction = 1.0 - rich.sse_heldout / simple.sse_heldout;
  in.min_heldout_reduction = std::max(rc.options.min_relative_reduction, 0.0);
  in.added_params = 1;
  in.p_value = chiSquareSurvivalUncertainScale(gain / std::max(sigma2, 1e-300), 1, rc.scale_sd);
  const Decision decision = decide(in);
  g.family_p = decision.family_p;
  g.delay_is_lag = decision.verdict != Verdict::kRecommended;
  g.reason = decision.reason;
}

}  // namespace ftid::lab::detail
