// The change-point scan of the model laboratory (change_point_scan.hpp, include/ftid/lab/change_point.hpp,
// docs/analyze.md "Change points").
#include "change_point_scan.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <tuple>

#include "change_point_core.hpp"
#include "ftid/effects/rigid_body.hpp"
#include "ftid/identify/noise.hpp"
#include "ftid/identify/robust_data.hpp"
#include "ftid/identify/normal_equations.hpp"

namespace ftid::lab::detail::cpscan {

namespace {

/// The best split of a scan: grid position, kind and its score.
struct Best {
  int k = -1;
  int kind = 0;
  double z = -1e300;   // -log p of the split's chi-square (ranking key, logSurvival)
  double p = 1.0;      // its p-value (colour scale uncertainty included)
};

void stepColumns(const effects::Model& model, ScanData& s) {
  const auto params = model.params();
  const auto& idx = model.paramIndex();
  std::vector<std::string> payload = {"mass", "mass_com_x", "mass_com_y", "mass_com_z"};
  if (model.contains("rigid_body")) {
    for (const char* n : effects::kInertiaParamNames) payload.emplace_back(n);
  }
  const std::vector<std::string> offsets = {"f0_x", "f0_y", "f0_z", "t0_x", "t0_y", "t0_z"};
  const auto add = [&](const std::vector<std::string>& names, const char* kind) {
    Kind k{kind, {}};
    for (const auto& n : names) {
      const int c = idx.column(n);
      if (c < 0) continue;
      k.u.push_back(static_cast<int>(s.cols.size()));
      s.cols.push_back(c);
      s.names.push_back(n);
      s.units.push_back(params[static_cast<std::size_t>(c)].unit);
    }
    if (!k.u.empty()) s.kinds.push_back(k);
  };
  add(payload, "payload");
  add(offsets, "offsets");
}

/// The observed scan: forms of every split and kind (for the null) and the best split.
Best observedScan(const ScanData& s, const std::vector<int>& ks, std::vector<std::vector<SplitForm>>* forms) {
  Best best;
  sweep(s, ks, true, s.r, [&](std::size_t g, const Eigen::MatrixXd& c, const Eigen::VectorXd& v) {
    std::vector<SplitForm> at;
    for (std::size_t kk = 0; kk < s.kinds.size(); ++kk) {
      at.push_back(splitForm(s, s.kinds[kk], c));
      if (at.back().rank == 0) continue;
      const Eigen::VectorXd vk = sub(v, s.kinds[kk]);
      const double chi2 = vk.dot(at.back().inv * vk) / s.sigma2;
      const double z = -logSurvival(chi2, at.back().rank);
      if (z > best.z) best = {ks[g], static_cast<int>(kk), z,
                              chiSquareSurvivalUncertainScale(chi2, at.back().rank, s.scale_sd)};
    }
    if (forms != nullptr) forms->push_back(std::move(at));
  });
  return best;
}

/// One simulated scan under no change: the smallest p-value over splits and kinds.
double nullMinP(const ScanData& s, const std::vector<int>& ks, const std::vector<std::vector<SplitForm>>& forms,
                std::mt19937_64& rng) {
  std::normal_distribution<double> gauss(0.0, 1.0);
  const auto xf = s.X.topRows(6 * static_cast<Eigen::Index>(s.n)).leftCols(s.p);
  Eigen::VectorXd e(xf.rows());
  for (Eigen::Index i = 0; i < e.size(); ++i) e(i) = s.r(i) != 0.0 || xf.row(i).squaredNorm() > 0.0 ? gauss(rng) : 0.0;
  const Eigen::VectorXd beta = s.a_inv * (xf.transpose() * e);
  const Eigen::VectorXd r = e - xf * beta;
  // The largest statistic per degrees of freedom (the p-value falls with it): one survival
  // function per rank instead of one per split.
  std::vector<double> max_chi2(s.cols.size() + 1, -1.0);
  sweep(s, ks, false, r, [&](std::size_t g, const Eigen::MatrixXd& /*c*/, const Eigen::VectorXd& v) {
    for (std::size_t kk = 0; kk < s.kinds.size(); ++kk) {
      const SplitForm& f = forms[g][kk];
      if (f.rank == 0) continue;
      const Eigen::VectorXd vk = sub(v, s.kinds[kk]);
      auto& m = max_chi2[static_cast<std::size_t>(f.rank)];
      m = std::max(m, vk.dot(f.inv * vk));
    }
  });
  double min_p = 1.0;
  for (std::size_t rank = 1; rank < max_chi2.size(); ++rank) {
    if (max_chi2[rank] >= 0.0) min_p = std::min(min_p, chiSquareSurvival(max_chi2[rank], static_cast<double>(rank)));
  }
  return min_p;
}

/// The scan's effective number of independent splits m: the null's smallest p-value u follows
/// 1 - (1 - u)^m; m is its maximum-likelihood estimate from simulated scans, raised by two of its
/// relative standard errors (1 / sqrt(R)) so that a short simulation errs on the safe side.
double effectiveSplits(const ScanData& s, const std::vector<int>& ks, const std::vector<std::vector<SplitForm>>& forms) {
  const double cost = 6.0 * s.n * static_cast<double>(s.p + s.cols.size());
  const int replicates = std::clamp(static_cast<int>(1e8 / std::max(1.0, cost)), 40, 60);
  std::mt19937_64 rng(0x6368616e6765ULL + static_cast<std::uint64_t>(s.n));
  double sum = 0.0;
  for (int k = 0; k < replicates; ++k) sum += -std::log1p(-std::min(nullMinP(s, ks, forms, rng), 1.0 - 1e-16));
  const double m = replicates / std::max(sum, 1e-300);
  return std::max(1.0, m * (1.0 + 2.0 / std::sqrt(static_cast<double>(replicates))));
}

/// Refines a coarse best split to the sample (same kind) within one grid step either side.
Best refine(const ScanData& s, const Best& coarse, int step) {
  if (step <= 1) return coarse;
  std::vector<int> ks;
  for (int k = std::max(1, coarse.k - step + 1); k <= std::min(s.n - 1, coarse.k + step - 1); ++k) ks.push_back(k);
  Best best = coarse;
  const Kind& kind = s.kinds[static_cast<std::size_t>(coarse.kind)];
  sweep(s, ks, true, s.r, [&](std::size_t g, const Eigen::MatrixXd& c, const Eigen::VectorXd& v) {
    const SplitForm f = splitForm(s, kind, c);
    if (f.rank == 0) return;
    const Eigen::VectorXd vk = sub(v, kind);
    const double z = -logSurvival(vk.dot(f.inv * vk) / s.sigma2, f.rank);
    if (z > best.z) best = {ks[g], coarse.kind, z, coarse.p};
  });
  return best;
}

/// Moves the tilt by the solution's correction and recomputes its Jacobian columns per segment:
/// before at[0] with the parameters before the change, from at[j] on with the steps up to j added.
bool stepTilt(const ScanData& s, const effects::Model& model, const Kind& kind, const std::vector<int>& at,
              const Solution& sol, Linearization& lin) {
  const int pm = model.numParams();
  const auto q = static_cast<Eigen::Index>(kind.u.size());
  const auto steps = static_cast<Eigen::Index>(at.size());
  const double du = sol.theta(pm), dv = sol.theta(pm + 1);
  lin.u += du;
  lin.v += dv;
  Eigen::VectorXd theta = sol.theta.head(s.p);
  const Linearization moved = lin;
  s.eng->tiltColumns(model, lin, theta);
  for (Eigen::Index m = 0; m < steps; ++m) {
    for (Eigen::Index j = 0; j < q; ++j) {
      theta(s.cols[static_cast<std::size_t>(kind.u[static_cast<std::size_t>(j)])]) += sol.theta(s.p + m * q + j);
    }
    Linearization lb = moved;
    s.eng->tiltColumns(model, lb, theta);
    const Eigen::Index from = at[static_cast<std::size_t>(m)];
    const Eigen::Index to = m + 1 < steps ? at[static_cast<std::size_t>(m + 1)] : lin.j_u.cols();
    lin.j_u.middleCols(from, to - from) = lb.j_u.middleCols(from, to - from);
    lin.j_v.middleCols(from, to - from) = lb.j_v.middleCols(from, to - from);
  }
  return std::abs(du) + std::abs(dv) > 1e-9;
}

/// The change point's time uncertainty from the step's per-sample signal delta^2 near the split
/// (the expected rise of the whitened sum of squares per sample the split is misplaced, in units of
/// the noise): the split's error in samples has standard deviation sqrt(26) / delta^2 (the argmax
/// of a two-sided Brownian motion with drift, Bai 1997), plus the sampling's own dt / sqrt(12).
double timeStd(const ScanData& s, const Kind& kind, const Eigen::VectorXd& step, int k, double dt) {
  const int half = 25;
  double signal = 0.0;
  int count = 0;
  for (int i = std::max(0, k - half); i < std::min(s.n, k + half); ++i, ++count) {
    for (int a = 0; a < 6; ++a) {
      const int row = s.eng->core().rowOf(i, a);
      double d = 0.0;
      for (std::size_t j = 0; j < kind.u.size(); ++j) d += s.X(row, s.cols[static_cast<std::size_t>(kind.u[j])]) * step(static_cast<Eigen::Index>(j));
      signal += d * d;
    }
  }
  const double delta2 = signal / std::max(1, count) / s.sigma2;
  const double samples_sd = delta2 > 0.0 ? std::sqrt(kArgmaxVariance) / delta2 : 1e9;
  return dt * std::sqrt(samples_sd * samples_sd + 1.0 / 12.0);
}

/// `with_null` = false only locates the split (no simulated null). The step is not fitted yet
/// (relinearised() fits it).
std::optional<Scan> scanOnce(const RankContext& rc, const Fitted& base, bool with_null) {
  Scan sc;
  sc.data = scanData(rc, base);
  const ScanData& s = sc.data;
  const std::vector<int> ks = gridOf(s.n, kMaxGrid);
  if (ks.size() < 2 || s.kinds.empty()) return std::nullopt;
  std::vector<std::vector<SplitForm>> forms;
  const Best coarse = observedScan(s, ks, &forms);
  if (coarse.k < 0) return std::nullopt;
  // The scan's p lies between its best split's p (m = 1) and the Bonferroni bound over every split
  // and kind (m = splits x kinds). When even the best split's p fails the rule, the bound is
  // reported and the null is not simulated: it could not change the verdict.
  const double splits = static_cast<double>(ks.size() * s.kinds.size());
  const bool matters = (rc.family_size + 1) * coarse.p < rc.options.family_alpha;
  const double m_eff = !with_null ? 1.0 : matters ? effectiveSplits(s, ks, forms) : splits;
  sc.p_scan = -std::expm1(m_eff * std::log1p(-std::min(coarse.p, 1.0 - 1e-16)));
  const Best best = refine(s, coarse, ks[1] - ks[0]);
  sc.kind = s.kinds[static_cast<std::size_t>(best.kind)];
  sc.k = best.k;
  return sc;
}

/// The fitting samples' readings alone: the noise floor before any model (robust to a step: the
/// 4th-order differences see it in 5 samples at most, which their median ignores).
std::vector<SampleContext> fittingSamples(const Engine& eng) {
  const auto& ctx = eng.data().ctx;
  return {ctx.begin(), ctx.begin() + eng.data().n_fit};
}

/// A dataset with the noise model nf (weights 1 / innovation std, the AR(1) filter).
Dataset withNoise(const Engine& eng, const identify::NoiseFloor& nf) {
  Dataset d = eng.data();
  d.ar1 = nf.ar1;
  const Vec6 inn = nf.innovationStd();
  for (int a = 0; a < 6; ++a) d.weights(a) = 1.0 / std::max(inn(a), 1e-9);
  return d;
}

bool dense(const identify::NoiseFloor& nf) {
  return nf.method == identify::NoiseMethod::kWhite || nf.method == identify::NoiseMethod::kColoured;
}

/// The noise model re-estimated from the residual of the model with the steps (the start's
/// residual holds the steps themselves, which reads as strongly coloured noise).
identify::NoiseFloor noiseWithStep(const Scan& sc, const Fitted& base) {
  const auto [lin, sol] = fitWithSteps(sc.data, base, sc.kind, sc.splits(), 0);
  const Engine& eng = *sc.data.eng;
  const std::vector<SampleContext> fit = fittingSamples(eng);
  identify::NoiseFloor nf = identify::estimateNoiseFloor(fit);
  if (!dense(nf)) return nf;
  const Design raw = stepDesign(sc.data, base.model, lin, sc.kind, sc.splits(), false);
  const auto cols = raw.cols() - 1;
  const auto n = static_cast<int>(fit.size());
  Mat6X res(6, n);
  for (int i = 0; i < n; ++i) {
    for (int a = 0; a < 6; ++a) {
      const int row = eng.core().rowOf(i, a);
      res(a, i) = (raw(row, cols) - raw.row(row).head(cols).dot(sol.theta)) / eng.data().weights(a);
    }
  }
  // Left-out samples (saturated, glitches) have zero rows: the floor is judged on the kept series.
  const identify::KeptSeries kept = identify::keptSeries(res, fit, eng.data().excluded);
  identify::refineNoiseFloor(nf, kept.residual, kept.ctx, kept.segment_starts);
  return nf;
}

/// Whether the analysis' noise (marginal std per axis) is more than twice the readings' own floor
/// on some axis: its residual then holds more than noise.
bool aboveReadings(const Engine& eng, const identify::NoiseFloor& readings) {
  const Dataset& d = eng.data();
  for (int a = 0; a < 6; ++a) {
    const double marginal = 1.0 / (d.weights(a) * std::sqrt(std::max(1e-6, 1.0 - d.ar1(a) * d.ar1(a))));
    if (marginal > 2.0 * readings.std(a)) return true;
  }
  return false;
}

/// A scan on its own engine (another noise model): the engine, the start refitted on it, the context.
struct Pass {
  std::unique_ptr<Engine> eng;
  std::optional<Fitted> base;
  std::optional<RankContext> rc;
  std::optional<Scan> scan;
};

/// The start's linear parameters are refitted under the new weights at the start's linearisation
/// (the step's fit re-linearises the tilt); `with_null` = false only locates the split.
Pass scanWithNoise(const RankContext& rc, const Fitted& base, const identify::NoiseFloor& nf, bool with_null) {
  Pass p;
  p.eng = std::make_unique<Engine>(withNoise(rc.eng, nf));
  p.base = Fitted{base.model, base.lin, p.eng->solve(p.eng->design(base.model, base.lin), true)};
  p.rc.emplace(RankContext{*p.eng, rc.menu, rc.options, rc.log_cmd, colourScaleSd(nf.ar1, nf.ar1_std), rc.family_size});
  p.scan = scanOnce(*p.rc, *p.base, with_null);
  return p;
}

/// The rule on the scan's best split (and a second change after it, when significant: a change
/// that ends), then the comparison with the best smooth candidate whose held-out gain is
/// significant (recommended or refused: reportChangePoints).
std::vector<ChangePoint> judge(const RankContext& rc, const Fitted& base, const Scan& scanned,
                               double best_smooth_reduction, ScanNote* note) {
  RuleInputs in = changeRule(rc, scanned.p_scan, static_cast<int>(scanned.kind.u.size()));
  if (note != nullptr) note->p_scan = scanned.p_scan;
  const auto& ctx = rc.eng.data().ctx;
  const double t_split = 0.5 * (ctx[static_cast<std::size_t>(scanned.k - 1)].t + ctx[static_cast<std::size_t>(scanned.k)].t);
  const std::string where = "the best split (" + scanned.kind.name + " step at t = " + fmt(t_split, 6) + " s)";
  Decision d = decide(in);
  if (d.verdict == Verdict::kRecommended) {
    // The exact fit with the step, and with a second change after it when that one is significant
    // and lowers the held-out error of the one-step model by the margin (the rule, as for any
    // effect added to a model): judged on its held-out error against the start.
    Second second;
    Scan sc = relinearised(scanned, base);
    const Scan two = withSecond(rc, scanned, second);
    Decision d2;
    if (two.k2 > 0) {
      const Scan sc2 = relinearised(two, base);
      RuleInputs in2 = changeRule(rc, second.p, sc2.sol.rank - sc.sol.rank, 2);
      in2.heldout_reduction = 1.0 - sc2.sol.sse_heldout / std::max(1e-300, sc.sol.sse_heldout);
      d2 = decide(in2);
      if (d2.verdict == Verdict::kRecommended) sc = sc2;
    }
    in.heldout_reduction = 1.0 - sc.sol.sse_heldout / std::max(1e-300, base.sol.sse_heldout);
    in.added_params = sc.sol.rank - base.sol.rank;
    d = decide(in);
    if (d.verdict == Verdict::kRecommended && in.heldout_reduction > best_smooth_reduction) {
      std::vector<ChangePoint> cps;
      const std::vector<int> at = sc.splits();
      for (std::size_t m = 0; m < at.size(); ++m) {
        ChangePoint cp = describe(sc.data, sc.kind, sc.sol, at[m], static_cast<int>(m));
        const bool first = at[m] == scanned.k;  // the scan's own split; the other is the second change
        cp.p_value = first ? sc.p_scan : second.p;
        cp.family_p = first ? d.family_p : d2.family_p;
        cp.heldout_reduction = in.heldout_reduction;
        cps.push_back(cp);
      }
      return cps;
    }
  }
  if (note != nullptr) {
    note->why = d.verdict != Verdict::kRecommended
                    ? where + " is " + verdictWord(d.verdict) + ": " + d.reason
                    : where + " would lower the held-out error by " + fmt(100.0 * in.heldout_reduction, 3) +
                          " %, less than the best effect with a significant held-out gain (" + fmt(100.0 * best_smooth_reduction, 3) + " %)";
  }
  return {};
}

std::vector<ChangePoint> findSteps(const RankContext& rc, const Fitted& base, double best_smooth_reduction,
                                   ScanNote* note) {
  const std::optional<Scan> first = scanOnce(rc, base, true);
  if (!first) return {};
  if (rc.options.noise_std) return judge(rc, base, *first, best_smooth_reduction, note);
  // The analysis' noise model came from the start's residual, which holds a step if there is one
  // (it reads as strongly coloured noise and hides the step). When the first scan is nominally
  // significant, or that noise is far above the readings' own floor, locate the split under the
  // readings' floor, re-estimate the noise from the residual with that step, and scan again under
  // it: that scan is the one judged.
  const identify::NoiseFloor readings = identify::estimateNoiseFloor(fittingSamples(rc.eng));
  if (!dense(readings) || (first->p_scan >= rc.options.family_alpha && !aboveReadings(rc.eng, readings))) {
    return judge(rc, base, *first, best_smooth_reduction, note);
  }
  Pass locate = scanWithNoise(rc, base, readings, false);
  // Nothing under the readings' floor either (its best split's p fails the rule): the first scan stands.
  if (!locate.scan || (rc.family_size + 1) * locate.scan->p_scan >= rc.options.family_alpha) {
    return judge(rc, base, *first, best_smooth_reduction, note);
  }
  Second second;  // a change that ends is a step and its end: both out of the noise's residual
  *locate.scan = withSecond(*locate.rc, *locate.scan, second);
  const identify::NoiseFloor with_step = noiseWithStep(*locate.scan, *locate.base);
  const Pass final_pass = scanWithNoise(rc, base, dense(with_step) ? with_step : readings, true);
  if (!final_pass.scan) return {};
  return judge(*final_pass.rc, *final_pass.base, *final_pass.scan, best_smooth_reduction, note);
}

}  // namespace

ScanData scanData(const RankContext& rc, const Fitted& base) {
  ScanData s;
  s.eng = &rc.eng;
  s.X = rc.eng.design(base.model, base.lin);
  s.p = static_cast<int>(s.X.cols()) - 1;
  s.n = rc.eng.data().n_fit;
  s.scale_sd = rc.scale_sd;
  stepColumns(base.model, s);
  s.rows.resize(6 * static_cast<std::size_t>(s.n));
  s.xs.resize(6 * static_cast<Eigen::Index>(s.n), static_cast<Eigen::Index>(s.cols.size()));
  for (int i = 0; i < s.n; ++i) {
    for (int a = 0; a < 6; ++a) {
      const int row = rc.eng.core().rowOf(i, a);
      s.rows[static_cast<std::size_t>(6 * i + a)] = row;
      for (std::size_t j = 0; j < s.cols.size(); ++j) s.xs(row, static_cast<Eigen::Index>(j)) = s.X(row, s.cols[j]);
    }
  }
  const auto xf = s.X.topRows(6 * static_cast<Eigen::Index>(s.n));
  const Eigen::MatrixXd gram = xf.leftCols(s.p).transpose() * xf.leftCols(s.p);
  const auto sol = identify::solveGram(gram, xf.leftCols(s.p).transpose() * xf.col(s.p), true);
  s.a_inv = sol.inverse;
  s.r = xf.col(s.p) - xf.leftCols(s.p) * sol.x;
  int active = 0;
  for (Eigen::Index i = 0; i < xf.rows(); ++i) active += xf.row(i).squaredNorm() > 0.0 ? 1 : 0;
  s.dof = std::max(1, active - sol.rank);
  s.sigma2 = std::max(1e-300, s.r.squaredNorm() / s.dof);
  return s;
}

/// One kind's blocks of a split's suffix sums: cz = Z^T X (q x p) and zz = Z^T Z (q x q).
void kindBlocks(const ScanData& s, const Kind& kind, const Eigen::MatrixXd& c_suffix, Eigen::MatrixXd& cz,
                Eigen::MatrixXd& zz) {
  const auto q = static_cast<Eigen::Index>(kind.u.size());
  cz.resize(q, s.p);
  zz.resize(q, q);
  for (Eigen::Index j = 0; j < q; ++j) {
    cz.row(j) = c_suffix.row(kind.u[static_cast<std::size_t>(j)]);
    for (Eigen::Index l = 0; l < q; ++l) zz(j, l) = cz(j, s.cols[static_cast<std::size_t>(kind.u[static_cast<std::size_t>(l)])]);
  }
}

SplitForm splitForm(const ScanData& s, const Kind& kind, const Eigen::MatrixXd& c_suffix) {
  const auto q = static_cast<Eigen::Index>(kind.u.size());
  Eigen::MatrixXd cz, zz;
  kindBlocks(s, kind, c_suffix, cz, zz);
  const Eigen::MatrixXd info = zz - cz * s.a_inv * cz.transpose();
  const auto g = identify::solveGram(0.5 * (info + info.transpose()), Eigen::VectorXd::Zero(q), true, kRankTolerance);
  return {g.inverse, g.rank};
}

Eigen::VectorXd sub(const Eigen::VectorXd& v, const Kind& kind) {
  Eigen::VectorXd out(static_cast<Eigen::Index>(kind.u.size()));
  for (std::size_t j = 0; j < kind.u.size(); ++j) out(static_cast<Eigen::Index>(j)) = v(kind.u[j]);
  return out;
}

/// log of the chi-square survival function (for ranking splits and kinds of different degrees of
/// freedom): exact while it is representable, else its large-statistic asymptote
/// log Q(k/2, x/2) ~ -x/2 + (k/2 - 1) log(x/2) - lgamma(k/2).
double logSurvival(double chi2, int dof) {
  const double p = chiSquareSurvival(chi2, dof);
  if (p > 1e-280) return std::log(p);
  const double h = 0.5 * std::max(1, dof);
  return -0.5 * chi2 + (h - 1.0) * std::log(0.5 * chi2) - std::lgamma(h);
}

std::vector<int> gridOf(int n, int step_cap) {
  const int margin = std::max(kMinSegment, n / 50);
  std::vector<int> ks;
  if (n - margin <= margin) return ks;
  const int step = std::max(1, (n - 2 * margin + step_cap - 1) / step_cap);
  for (int k = margin; k <= n - margin; k += step) ks.push_back(k);
  return ks;
}

/// The whitened design of the base model at `lin` with one set of step columns of `kind` per split
/// in `at` (increasing): the set of split j is the raw design's columns masked to the samples from
/// at[j] on, then whitened as every design is.
Design stepDesign(const ScanData& s, const effects::Model& model, const Linearization& lin, const Kind& kind,
                  const std::vector<int>& at, bool whitened) {
  const Engine& eng = *s.eng;
  const Design raw = eng.rawDesign(model, lin);
  const auto q = static_cast<Eigen::Index>(kind.u.size());
  const auto steps = static_cast<Eigen::Index>(at.size());
  Design xe = Design::Zero(raw.rows(), s.p + steps * q + 1);
  xe.leftCols(s.p) = raw.leftCols(s.p);
  xe.col(s.p + steps * q) = raw.col(s.p);
  for (Eigen::Index m = 0; m < steps; ++m) {
    for (int i = at[static_cast<std::size_t>(m)]; i < eng.data().size(); ++i) {
      for (int a = 0; a < 6; ++a) {
        const int row = eng.core().rowOf(i, a);
        for (Eigen::Index j = 0; j < q; ++j) {
          xe(row, s.p + m * q + j) = raw(row, s.cols[static_cast<std::size_t>(kind.u[static_cast<std::size_t>(j)])]);
        }
      }
    }
  }
  if (whitened) eng.core().whiten(xe, 0, static_cast<int>(xe.cols()));
  return xe;
}

/// The base model refitted with the steps of `kind` at the splits `at`, the tilt shared and
/// re-linearised (Gauss-Newton, a few passes: the start's tilt was fitted without the steps): the
/// exact fit behind the reported change points and their held-out error.
std::pair<Linearization, Solution> fitWithSteps(const ScanData& s, const Fitted& base, const Kind& kind,
                                                const std::vector<int>& at, int passes) {
  Linearization lin = base.lin;
  Solution sol = s.eng->solve(stepDesign(s, base.model, lin, kind, at), true);
  for (int pass = 0; pass < passes && lin.tilt_columns && stepTilt(s, base.model, kind, at, sol, lin); ++pass) {
    sol = s.eng->solve(stepDesign(s, base.model, lin, kind, at), true);
  }
  return {lin, sol};
}

/// The change point at split k, the m-th step set of `sol` (stepDesign's column order).
ChangePoint describe(const ScanData& s, const Kind& kind, const Solution& sol, int k, int m) {
  const auto& ctx = s.eng->data().ctx;
  ChangePoint cp;
  cp.kind = kind.name;
  cp.sample = k;
  const double t0 = ctx[static_cast<std::size_t>(k - 1)].t, t1 = ctx[static_cast<std::size_t>(k)].t;
  cp.t = 0.5 * (t0 + t1);
  cp.t_first = ctx.front().t;
  cp.t_last = ctx[static_cast<std::size_t>(s.n - 1)].t;
  const auto q = static_cast<Eigen::Index>(kind.u.size());
  const Eigen::Index first = s.p + m * q;
  const Eigen::VectorXd step = sol.theta.segment(first, q);
  for (Eigen::Index j = 0; j < q; ++j) {
    const auto u = static_cast<std::size_t>(kind.u[static_cast<std::size_t>(j)]);
    cp.delta.push_back({s.names[u], s.units[u], step(j), std::sqrt(std::max(0.0, sol.covariance(first + j, first + j)))});
  }
  const double dt = (cp.t_last - cp.t_first) / std::max(1, s.n - 1);
  cp.t_std = timeStd(s, kind, step, k, dt);
  return cp;
}

/// The step's fit with the tilt re-linearised (the one judged and reported).
Scan relinearised(Scan sc, const Fitted& base) {
  std::tie(sc.lin, sc.sol) = fitWithSteps(sc.data, base, sc.kind, sc.splits(), 5);
  return sc;
}

}  // namespace ftid::lab::detail::cpscan

namespace ftid::lab::detail {

using namespace cpscan;  // NOLINT(google-build-using-namespace): this file's own scan

std::vector<ChangePoint> findChangePoints(const RankContext& rc, const Fitted& base, double best_smooth_reduction,
                                          ScanNote* note) {
  std::vector<ChangePoint> cps = findSteps(rc, base, best_smooth_reduction, note);
  if (!cps.empty()) return cps;
  cps = judgeWindow(rc, base, windowScans(rc, base), best_smooth_reduction);
  if (!cps.empty() && note != nullptr) {
    note->why.clear();
    note->p_scan = cps.front().p_value;  // the window scan's p decided
  }
  return cps;
}

}  // namespace ftid::lab::detail
