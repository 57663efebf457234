// Ranking the candidate effects under the laboratory's one rule (lab/verdict.hpp,
// docs/analyze.md "The verdict"), and the rule on two full fits (for --explain).
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "lab_internal.hpp"
#include "ftid/common/error.hpp"
#include "ftid/effects/model.hpp"
#include "ftid/effects/nonlinear.hpp"
#include "ftid/effects/signal_source.hpp"

namespace ftid::lab::detail {

using effects::Model;

void say(const AnalyzeOptions& o, const std::string& line) {
  if (o.progress) o.progress(line);
}

std::string fmt(double v, int precision) {
  std::ostringstream s;
  s.precision(precision);
  s << v;
  return s.str();
}

std::vector<std::string> fittedNames(const Model& model, const Linearization& lin) {
  std::vector<std::string> names = model.paramIndex().names();
  if (lin.tilt_columns) {
    names.emplace_back("tilt_u");
    names.emplace_back("tilt_v");
  }
  if (lin.mount_columns) {
    for (const char* m : effects::kMountParamNames) names.emplace_back(m);
  }
  if (lin.delay_column) names.emplace_back(effects::kDelayParamName);
  return names;
}

FitView fitView(const Model& model, const Linearization& lin, const Solution& sol,
                const std::vector<std::string>* simpler_names, const std::vector<SampleContext>& samples) {
  FitView f;
  f.model = &model;
  f.samples = &samples;
  f.names = fittedNames(model, lin);
  const int n = static_cast<int>(f.names.size());
  f.theta = sol.theta.head(std::min<Eigen::Index>(n, sol.theta.size()));
  const int p = model.numParams();
  if (lin.tilt_columns && p + 1 < f.theta.size()) {
    f.theta(p) = wrapAngle(f.theta(p) + lin.u);
    f.theta(p + 1) = wrapAngle(f.theta(p + 1) + lin.v);
  }
  if (lin.mount_columns) {
    const int c = lin.mountColumn(p);
    for (int k = 0; k < 3 && c + k < f.theta.size(); ++k) f.theta(c + k) = wrapAngle(f.theta(c + k) + lin.mount(k));
  }
  if (lin.delay_column && lin.delayColumn(p) < f.theta.size()) f.theta(lin.delayColumn(p)) += lin.delay;
  f.covariance = sol.covariance;
  f.null_space = sol.null_space;
  f.added.assign(f.names.size(), false);
  if (simpler_names != nullptr) {
    for (std::size_t k = 0; k < f.names.size(); ++k) {
      f.added[k] = std::find(simpler_names->begin(), simpler_names->end(), f.names[k]) == simpler_names->end();
    }
  }
  return f;
}

Linearization bestMountStart(const Engine& eng, const Model& cand) {
  constexpr double kQuarter = 1.5707963267948966;
  std::vector<Mat3> seen;
  const Linearization initial = eng.initial(cand);  // level (or the static force stage's) tilt
  Linearization best = initial;
  double best_sse = std::numeric_limits<double>::infinity();
  for (int r = -1; r <= 2; ++r) {
    for (int p = -1; p <= 2; ++p) {
      for (int y = -1; y <= 2; ++y) {
        const Vec3 rpy(r * kQuarter, p * kQuarter, y * kQuarter);
        const Mat3 R = effects::mountingRotation(rpy);
        if (std::any_of(seen.begin(), seen.end(), [&](const Mat3& m) { return (m - R).norm() < 1e-6; })) continue;
        seen.push_back(R);  // the 24 axis-aligned rotations
        Linearization lin = initial;
        lin.mount = rpy;
        lin.tilt_columns = lin.mount_columns = lin.delay_column = false;
        const Solution s = eng.solve(eng.design(cand, lin), false);  // the linear parameters at this start
        if (s.sse_fit < best_sse) {
          best_sse = s.sse_fit;
          best = lin;
        }
      }
    }
  }
  return best;
}

namespace {

/// Fills the candidate's verdict from the rule's inputs.
void applyRule(const RuleInputs& in, CandidateResult& c) {
  const Decision d = decide(in);
  c.verdict = d.verdict;
  c.family_p = d.family_p;
  c.reason = d.reason;
  c.significant = d.verdict == Verdict::kRecommended;
  c.confounded = d.verdict == Verdict::kRefused;
  c.confound = c.confounded ? d.reason : "";
  c.separating_motion = c.confounded ? d.separating_motion : "";
}

std::vector<Refusal> refusalsOf(const FitView& f) {
  std::vector<Refusal> r = identifiabilityRefusals(f);
  for (auto& x : physicsRefusals(f)) r.push_back(std::move(x));
  return r;
}

}  // namespace

/// Checks the signals a model needs against the data; "" if fine, else the reason.
std::string missingSignal(const Model& model, const std::vector<SampleContext>& ctx) {
  return model.cannotFit(ctx);
}

namespace {

/// Why `cand` (a model with a candidate effect) cannot be tried on this data; "" if it can.
std::string cannotTry(const Engine& eng, const Model& cand, bool base_has_delay) {
  std::string miss = missingSignal(cand, eng.data().ctx);
  if (miss.empty() && eng.data().static_data && cand.estimatesDelay() && !base_has_delay) {
    miss = "static pose set: a delay shows only while the wrench changes (the time between poses is not motion)";
  }
  return miss;
}

}  // namespace

int familySize(const Engine& eng, const std::vector<std::string>& menu) {
  const Model floor = Model::fromName("paper");
  int m = 0;
  for (const auto& name : menu) {
    try {
      const auto e = effects::createEffect(name);
      if (floor.contains(e->name())) continue;
      if (cannotTry(eng, floor.withEffect(name), false).empty()) ++m;
    } catch (const ConfigError&) {
      // Not a valid effect: skipped in every ranking, not part of the family.
    }
  }
  return std::max(1, m);
}

/// The scale uncertainty of a candidate's F statistic that the estimated noise colour brings. The
/// candidates (and the model) vary at the motion's frequencies, far below the band where phi is
/// fitted; whitened with an estimate phi^ of the true phi, noise there keeps the factor
/// r = S_true(0) / S_phi^(0) = ((1 - phi^) / (1 - phi))^2 of its variance, which the F test's
/// denominator (the whole band, where the factor averages to 1) does not see:
/// sd(ln r) = 2 sd(phi^) / (1 - phi^). Axes with their own phi: the mean of the variances (an
/// upper bound for a statistic that pools them).
double colourScaleSd(const Vec6& ar1, const Vec6& ar1_std) {
  double v = 0.0;
  for (int a = 0; a < 6; ++a) {
    if (ar1(a) > 0.0 && ar1_std(a) > 0.0) v += std::pow(2.0 * ar1_std(a) / std::max(1e-3, 1.0 - ar1(a)), 2) / 6.0;
  }
  return std::sqrt(v);
}

std::vector<CandidateResult> rankCandidates(const RankContext& rc, const Fitted& base) {
  const Engine& eng = rc.eng;
  const auto& menu = rc.menu;
  const AnalyzeOptions& options = rc.options;
  std::vector<CandidateResult> out;
  std::vector<std::string> todo;
  for (const auto& name : menu) {
    CandidateResult c;
    c.effect = name;
    try {
      auto e = effects::createEffect(name);
      c.description = e->description();
      if (base.model.contains(e->name())) continue;
    } catch (const ConfigError& err) {
      c.skipped = true;
      c.note = err.what();
      c.verdict = Verdict::kSkipped;
      out.push_back(c);
      continue;
    }
    out.push_back(c);
  }
  const int tested = static_cast<int>(std::count_if(out.begin(), out.end(), [](const auto& c) { return !c.skipped; }));
  say(options, "ranking " + std::to_string(tested) + " candidate effects against " + base.model.name() +
                   " (family of the correction: m = " + std::to_string(rc.family_size) + ")");
  const int rows_ho = 6 * base.sol.n_heldout;
  // The base design and prepared contexts are shared by every candidate (designExtended).
  const detail::Engine::Design base_design = eng.design(base.model, base.lin);
  const std::vector<SampleContext> prepared = eng.prepared(base.lin);
  const std::vector<std::string> base_names = fittedNames(base.model, base.lin);
  for (auto& c : out) {
    if (c.skipped) continue;
    say(options, "  trying " + c.effect);
    Model cand = base.model;
    try {
      cand = base.model.withEffect(c.effect);
    } catch (const ConfigError& err) {
      c.skipped = true;
      c.note = err.what();
      c.verdict = Verdict::kSkipped;
      continue;
    }
    const std::string miss = cannotTry(eng, cand, base.model.estimatesDelay());
    if (!miss.empty()) {
      c.skipped = true;
      c.note = miss;
      c.verdict = Verdict::kSkipped;
      continue;
    }
    Linearization lin = base.lin;
    if (cand.estimatesTilt() && !lin.tilt_columns) {
      eng.tiltColumns(base.model, lin, base.sol.theta);
      lin.tilt_columns = true;
    }
    // Nonlinear candidates are screened to first order at the base solution (their Jacobian
    // columns); --explain then fits them fully (Engine::fitFully).
    if (cand.estimatesMounting() && !lin.mount_columns) {
      eng.mountColumns(base.model, lin, base.sol.theta);
      lin.mount_columns = true;
    }
    if (cand.estimatesDelay() && !lin.delay_column) {
      eng.delayColumn(base.model, lin, base.sol.theta);
      lin.delay_column = true;
    }
    // The base model's columns must keep their meaning in the candidate (nested models).
    Engine::Design X = lin.extraColumns() == base.lin.extraColumns()
                           ? eng.designExtended(base.model, base_design, cand, lin, prepared)
                           : eng.design(cand, lin);
    Solution s = eng.solve(X);
    if (cand.estimatesMounting() && !base.model.estimatesMounting()) {
      // A sensor mounted far off (90 degrees) is out of the first order's reach: always fit the
      // mounting fully from the best of the 24 axis-aligned rotations too, kept when it fits better.
      const Linearization from = bestMountStart(eng, cand);
      if (from.mount.norm() > 0.0) {
        auto full = eng.fitFully(cand, from);
        if (full.second.sse_fit < s.sse_fit) {
          lin = std::move(full.first);
          s = std::move(full.second);
          X = eng.design(cand, lin);
        }
      }
    }
    c.added_params = s.rank - base.sol.rank;
    c.residual_rms = (s.sse_heldout_axis / std::max(1, s.n_heldout)).cwiseSqrt();
    const double rr = 1.0 - s.sse_heldout / base.sol.sse_heldout;
    c.relative_reduction = std::clamp(rr, 0.0, 1.0);
    c.fit_relative_reduction = std::clamp(1.0 - s.sse_fit / base.sol.sse_fit, 0.0, 1.0);
    c.delta_bic = rows_ho * std::log(std::max(1e-300, s.sse_heldout / base.sol.sse_heldout)) +
                  std::max(0, c.added_params) * std::log(static_cast<double>(rows_ho));
    c.next_command = "ftid analyze " + rc.log_cmd + " --model " + shellQuote(base.model.name() + "+" + c.effect);
    RuleInputs in;
    in.family_size = rc.family_size;
    in.family_alpha = options.family_alpha;
    in.heldout_reduction = rr;
    in.min_heldout_reduction = options.min_relative_reduction;
    in.added_params = c.added_params;
    if (c.added_params <= 0) {
      c.note = "adds nothing the data can determine";
      c.p_value = 1.0;
    } else {
      const double dof2 = std::max(1, s.rows_fit - s.rank);
      c.f_statistic = ((base.sol.sse_fit - s.sse_fit) / c.added_params) / (s.sse_fit / dof2);
      const FitView view = fitView(cand, lin, s, &base_names, eng.data().ctx);
      c.p_value = heldOutPValue(rc, base_design, X, view, base.sol.sse_heldout, s);
      in.p_value = c.p_value;
      in.refusals = refusalsOf(view);
    }
    applyRule(in, c);
  }
  std::stable_sort(out.begin(), out.end(), [](const CandidateResult& a, const CandidateResult& b) {
    if (a.skipped != b.skipped) return !a.skipped;
    if (a.significant != b.significant) return a.significant;
    return a.delta_bic < b.delta_bic;
  });
  return out;
}

std::vector<std::string> candidateMenu(const AnalyzeOptions& options) {
  if (!options.candidates.empty()) return options.candidates;
  std::vector<std::string> menu;
  for (const auto& e : effects::registeredEffects()) {
    if (e.base_name == "harmonic" || e.base_name == "poly" || e.base_name == "expr") continue;  // need arguments
    menu.push_back(e.base_name);
  }
  for (const auto& g : defaultGenericMenu()) menu.push_back(g);
  return menu;
}

CandidateResult judgeNested(const RankContext& rc, const Fitted& simple, const Fitted& rich, const std::string& effect) {
  CandidateResult c;
  c.effect = effect;
  c.added_params = rich.sol.rank - simple.sol.rank;
  c.residual_rms = (rich.sol.sse_heldout_axis / std::max(1, rich.sol.n_heldout)).cwiseSqrt();
  const double rr = 1.0 - rich.sol.sse_heldout / simple.sol.sse_heldout;
  c.relative_reduction = std::clamp(rr, 0.0, 1.0);
  c.fit_relative_reduction = std::clamp(1.0 - rich.sol.sse_fit / simple.sol.sse_fit, 0.0, 1.0);
  RuleInputs in;
  in.family_size = rc.family_size;
  in.family_alpha = rc.options.family_alpha;
  in.heldout_reduction = rr;
  // A step of the path must lower the held-out error, whatever margin the ranking uses.
  in.min_heldout_reduction = std::max(rc.options.min_relative_reduction, 0.0);
  in.added_params = c.added_params;
  if (c.added_params > 0) {
    const double dof2 = std::max(1, rich.sol.rows_fit - rich.sol.rank);
    c.f_statistic = std::max(0.0, ((simple.sol.sse_fit - rich.sol.sse_fit) / c.added_params) / (rich.sol.sse_fit / dof2));
    const auto simple_names = fittedNames(simple.model, simple.lin);
    const FitView rich_view = fitView(rich.model, rich.lin, rich.sol, &simple_names, rc.eng.data().ctx);
    c.p_value = heldOutPValue(rc, rc.eng.design(simple.model, simple.lin), rc.eng.design(rich.model, rich.lin), rich_view,
                              simple.sol.sse_heldout, rich.sol);
    in.p_value = c.p_value;
    in.refusals = identifiabilityRefusals(rich_view);
    // A physics refusal is charged to the effect only when the model without it is physical:
    // otherwise the impossibility is not the effect's doing (backward elimination would blame
    // every effect for the whole model's physics).
    if (physicsRefusals(fitView(simple.model, simple.lin, simple.sol, nullptr, rc.eng.data().ctx)).empty()) {
      for (auto& r : physicsRefusals(rich_view)) in.refusals.push_back(std::move(r));
    }
  }
  applyRule(in, c);
  return c;
}

std::vector<std::string> effectNames(const Model& model) {
  std::vector<std::string> out;
  for (const auto& e : model.effectList()) out.push_back(e->name());
  return out;
}

Model canonicalModel(const std::vector<std::string>& effect_names) {
  std::vector<std::string> order;
  for (const auto& e : effects::registeredEffects()) order.push_back(e.base_name);
  const auto rankOf = [&](const std::string& name) {
    const std::string base = name.substr(0, name.find('('));
    const auto it = std::find(order.begin(), order.end(), base);
    return static_cast<int>(it - order.begin());
  };
  std::vector<std::string> names = effect_names;
  std::sort(names.begin(), names.end(), [&](const std::string& a, const std::string& b) {
    const int ra = rankOf(a), rb = rankOf(b);
    return ra != rb ? ra < rb : a < b;
  });
  names.erase(std::unique(names.begin(), names.end()), names.end());
  std::string joined;
  for (const auto& n : names) joined += (joined.empty() ? "" : "+") + n;
  return Model::fromName(joined);
}

}  // namespace ftid::lab::detail
