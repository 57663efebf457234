// --explain: the path from the starting model to the model the rule supports, independent of the
// start (docs/analyze.md, "Explain"): backward elimination of every effect the rule does not
// support, then forward selection of the best recommended candidate, repeated until neither moves.
#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <set>

#include "lab_internal.hpp"
#include "ftid/common/error.hpp"
#include "ftid/effects/model.hpp"

namespace ftid::lab::detail {

using effects::Model;

namespace {

/// The paper's effects are the floor of every model: never removed.
bool isPaperEffect(const std::string& name) {
  return name == "offsets" || name == "gravity" || name == "tilt" || name == "linear_inertia";
}

ExplainStep stepOf(const Fitted& f, const Vec6& noise) {
  ExplainStep st;
  st.model = f.model.name();
  st.residual_rms = (f.sol.sse_heldout_axis / std::max(1, f.sol.n_heldout)).cwiseSqrt();
  st.total_ratio = totalRatio(st.residual_rms, noise);
  st.heldout_sse = f.sol.sse_heldout;
  return st;
}

/// How strongly the rule rejects an effect (for choosing which to remove first): refusals, then
/// no held-out gain, then nothing to add, then the largest family-wise p-value.
double rejection(const CandidateResult& c) {
  switch (c.verdict) {
    case Verdict::kRefused: return 4.0;
    case Verdict::kNoHeldOutGain: return 3.0;
    case Verdict::kNothingToAdd: return 2.0;
    default: return 1.0 + std::min(1.0, c.family_p) * 0.5;
  }
}

/// A removal the backward step may take: the smaller model, the rule's verdict on the effect
/// against it, and the held-out BIC change of the removal (lower: the data prefer the smaller model).
struct Removal {
  Fitted small;
  CandidateResult judged;
  double heldout_bic = 0.0;
};

/// Which of two removals goes first: the effect the rule rejects more strongly, then the one whose
/// removal has the lower held-out BIC, then by name (never the spelling order of the model).
bool removeBefore(const Removal& a, const Removal& b) {
  const double ra = rejection(a.judged), rb = rejection(b.judged);
  if (ra != rb) return ra > rb;
  if (a.heldout_bic != b.heldout_bic) return a.heldout_bic < b.heldout_bic;
  return a.judged.effect < b.judged.effect;
}

/// Full fit of `model` from the linearisation of `from`; a second start (the model's own initial
/// linearisation) when the first ends unphysical or not better held out, keeping the better one.
Fitted fitFrom(const Engine& eng, const Model& model, const Fitted& from) {
  auto [lin, sol] = eng.fitFully(model, from.lin);
  Fitted a{model, lin, sol};
  if (model.estimatesMounting() && !from.model.estimatesMounting()) {
    // A mounting error of any size: also from the best of the 24 axis-aligned rotations.
    const Linearization start = bestMountStart(eng, model);
    if (start.mount.norm() > 0.0) {
      auto [lin3, sol3] = eng.fitFully(model, start);
      if (sol3.sse_fit < a.sol.sse_fit) a = Fitted{model, lin3, sol3};
    }
  }
  const bool physical = physicsRefusals(fitView(a.model, a.lin, a.sol, nullptr, eng.data().ctx)).empty();
  if (physical && a.sol.sse_heldout < from.sol.sse_heldout) return a;
  auto [lin2, sol2] = eng.fitFully(model, eng.initial(model));
  Fitted b{model, lin2, sol2};
  const bool physical2 = physicsRefusals(fitView(b.model, b.lin, b.sol, nullptr, eng.data().ctx)).empty();
  if (physical2 != physical) return physical2 ? b : a;
  return b.sol.sse_fit < a.sol.sse_fit ? b : a;
}

/// Candidates a forward step fits fully and looks one step beyond.
constexpr int kLookaheadWidth = 3;
/// ... among those whose screened log held-out ratio reaches this fraction of the best one's.
constexpr double kLookaheadReach = 0.6;

struct Lookahead {
  Fitted fit;                          ///< the model with the candidate, fully fitted
  CandidateResult judged;              ///< the rule on the full fit
  std::vector<CandidateResult> after;  ///< the ranking against it
  double score = 0.0;                  ///< held-out BIC of its best continuation, against the current model
};

/// Held-out BIC change, against `cur`, of the candidate's model or of it plus the best recommended
/// effect after it, whichever is lower (rows: 6 per held-out sample; q: the rank gained).
double lookaheadScore(const Fitted& cur, const Lookahead& la) {
  const double rows = 6.0 * std::max(1, cur.sol.n_heldout);
  const double q1 = std::max(0, la.fit.sol.rank - cur.sol.rank);
  const double base = rows * std::log(la.fit.sol.sse_heldout / cur.sol.sse_heldout) + q1 * std::log(rows);
  double best = base;
  for (const auto& d : la.after) {
    if (!d.significant) continue;
    const double sse = la.fit.sol.sse_heldout * std::max(1e-300, 1.0 - d.relative_reduction);
    best = std::min(best, rows * std::log(sse / cur.sol.sse_heldout) + (q1 + d.added_params) * std::log(rows));
  }
  return best;
}

/// Where the path stands between steps: the current model, the ranking against it, the effect just
/// added (judged against exactly the model without it), the models already visited, and the rule's
/// verdict on each removal by the (canonical) model the effect was removed from.
struct PathState {
  Fitted cur;
  std::vector<CandidateResult> ranking;
  std::string just_added;
  std::set<std::string> visited;
  std::map<std::string, CandidateResult> removed_from;
};

/// Records one step of the path: the model now current, the effect added or removed, its p-values.
void recordStep(const PathState& ps, const CandidateResult& judged, bool added, AnalysisResult& result) {
  ExplainStep st = stepOf(ps.cur, result.noise_floor);
  (added ? st.added : st.removed) = judged.effect;
  st.p_value = judged.p_value;
  st.family_p = judged.family_p;
  result.steps.push_back(st);
}

/// Parameters a full fit of `m` estimates: its linear ones and the nonlinear ones (tilt, mounting,
/// delay), which an effect such as `mounting` or `sensor_delay` adds alone.
int fittedCount(const Model& m) {
  return m.numParams() + (m.estimatesTilt() ? 2 : 0) + (m.estimatesMounting() ? 3 : 0) + (m.estimatesDelay() ? 1 : 0);
}

/// Backward: the effect of the model the rule supports least, if it does not support it. A
/// removal never raises the held-out error, except of an effect refused on a constraint
/// (identifiability or physics): a model the rule cannot stand behind is left even at a cost.
/// `kept`: the effects the rule does not support that stay because their removal would raise it.
std::optional<Removal> backwardElimination(const RankContext& rc, const PathState& ps,
                                           std::vector<CandidateResult>* kept) {
  const Fitted& cur = ps.cur;
  std::optional<Removal> drop;
  kept->clear();
  for (const auto& name : effectNames(cur.model)) {
    // The effect just added was judged against exactly the model without it: skip the repeat.
    if (isPaperEffect(name) || name == ps.just_added) continue;
    std::vector<std::string> rest = effectNames(cur.model);
    rest.erase(std::remove(rest.begin(), rest.end(), name), rest.end());
    Model smaller = canonicalModel(rest);
    if (fittedCount(smaller) == fittedCount(cur.model) || ps.visited.count(smaller.name()) != 0) continue;
    say(rc.options, "explain: would " + name + " be taken again against " + smaller.name() + "?");
    Fitted small = fitFrom(rc.eng, smaller, cur);
    CandidateResult c = judgeNested(rc, small, cur, name);
    if (c.verdict == Verdict::kRecommended) continue;
    if (c.verdict != Verdict::kRefused && small.sol.sse_heldout > cur.sol.sse_heldout) {
      kept->push_back(std::move(c));  // not supported, but its removal would raise the held-out error
      continue;
    }
    const double rows = 6.0 * std::max(1, cur.sol.n_heldout);
    const double bic = rows * std::log(std::max(1e-300, small.sol.sse_heldout / cur.sol.sse_heldout)) -
                       std::max(0, c.added_params) * std::log(rows);
    Removal cand{std::move(small), std::move(c), bic};
    if (!drop || removeBefore(cand, *drop)) drop = std::move(cand);
  }
  return drop;
}

/// Takes the removal the backward pass chose: the smaller model becomes current, ranked afresh.
void takeRemoval(const RankContext& rc, int step, Removal& drop, PathState& ps, AnalysisResult& result) {
  say(rc.options, "explain step " + std::to_string(step + 1) + ": removing " + drop.judged.effect + " (" +
                      drop.judged.reason + ")");
  ps.removed_from[canonicalModel(effectNames(ps.cur.model)).name()] = drop.judged;
  ps.cur = std::move(drop.small);
  ps.just_added.clear();
  recordStep(ps, drop.judged, /*added=*/false, result);
  ps.visited.insert(ps.cur.model.name());
  ps.ranking = rankCandidates(rc, ps.cur);
}

/// Log held-out ratio (screened) of a candidate: negative when it lowers the held-out error.
double screenedLogRatio(const CandidateResult& cand) {
  return std::log(std::max(1e-300, 1.0 - cand.relative_reduction));
}

/// The verdict on a candidate recommended when screened whose model `next` the path removed it
/// from earlier: its full fit is not supported there. Not silently: the verdict says so.
CandidateResult removedEarlier(const CandidateResult& cand, const std::string& next,
                               const std::map<std::string, CandidateResult>& removed_from) {
  CandidateResult earlier;
  earlier.effect = cand.effect;
  earlier.verdict = Verdict::kNoHeldOutGain;
  const auto it = removed_from.find(next);
  if (it != removed_from.end()) earlier = it->second;
  earlier.reason = "removed earlier: its full fit is not supported" +
                   (it != removed_from.end() && !it->second.reason.empty() ? " (" + it->second.reason + ")"
                                                                             : std::string());
  if (earlier.verdict == Verdict::kRecommended) earlier.verdict = Verdict::kNoHeldOutGain;
  return earlier;
}

/// Forward: among the best recommended candidates whose full fit the rule still recommends,
/// the one whose best continuation (itself, or itself plus the best recommended effect after
/// it) has the lowest held-out BIC: one step of look-ahead keeps a flexible effect (crosstalk,
/// a harmonic) from taking the place of the physical one it imitates. The candidates recommended
/// when screened but not on their full fit are appended to `rejected`.
std::optional<Lookahead> forwardWithLookahead(const RankContext& rc, const PathState& ps,
                                              std::vector<CandidateResult>& rejected) {
  const Fitted& cur = ps.cur;
  std::optional<Lookahead> best;
  int tried = 0;
  // Only candidates that come close to the best one's screened gain can win by looking ahead:
  // their log held-out ratio at least kLookaheadReach of the best one's.
  double best_log_ratio = 0.0;
  int first_params = 0;
  for (const auto& cand : ps.ranking) {
    if (cand.significant) best_log_ratio = std::min(best_log_ratio, screenedLogRatio(cand));
  }
  for (const auto& cand : ps.ranking) {
    if (!cand.significant) break;  // recommended ones come first
    if (tried >= kLookaheadWidth) break;
    // ... and that are leaner than the first one taken into account (look-ahead exists to let a
    // lean physical effect beat a flexible one that imitates it).
    if (tried > 0 && (screenedLogRatio(cand) > kLookaheadReach * best_log_ratio || cand.added_params >= first_params)) {
      continue;
    }
    std::vector<std::string> names = effectNames(cur.model);
    names.push_back(effects::createEffect(cand.effect)->name());
    Model next = canonicalModel(names);
    if (ps.visited.count(next.name()) != 0) {
      rejected.push_back(removedEarlier(cand, next.name(), ps.removed_from));
      continue;
    }
    Fitted rich = fitFrom(rc.eng, next, cur);
    CandidateResult full = judgeNested(rc, cur, rich, cand.effect);
    if (full.verdict != Verdict::kRecommended || !(rich.sol.sse_heldout < cur.sol.sse_heldout)) {
      say(rc.options, "explain: " + cand.effect + " not taken after its full fit: " + full.reason);
      rejected.push_back(std::move(full));
      continue;
    }
    if (tried == 0) first_params = cand.added_params;
    ++tried;  // the look-ahead width counts the candidates that pass their full fit
    Lookahead la{std::move(rich), std::move(full), {}, 0.0};
    la.after = rankCandidates(rc, la.fit);
    la.score = lookaheadScore(cur, la);
    if (!best || la.score < best->score) best = std::move(la);
  }
  return best;
}

/// When nothing is taken, the ranking says what the full fit found (the verdict the path acted on).
void markRejected(const std::vector<CandidateResult>& rejected, std::vector<CandidateResult>& ranking) {
  for (const auto& r : rejected) {
    for (auto& c : ranking) {
      if (c.effect != r.effect) continue;
      c.verdict = r.verdict == Verdict::kRecommended ? Verdict::kNoHeldOutGain : r.verdict;
      c.family_p = r.family_p;
      c.reason = r.reason.empty() ? std::string("the held-out error does not fall (on its full fit)")
                 : r.reason.rfind("removed earlier", 0) == 0 ? r.reason
                                                              : r.reason + " (on its full fit)";
      c.significant = false;
      c.confounded = c.verdict == Verdict::kRefused;
      c.confound = c.confounded ? c.reason : "";
      c.separating_motion = c.confounded ? r.separating_motion : "";
    }
  }
}

/// Takes the candidate the forward step chose: its model becomes current, with the ranking
/// already computed against it by the look-ahead.
void takeAddition(const RankContext& rc, int step, Lookahead& best, PathState& ps, AnalysisResult& result) {
  say(rc.options, "explain step " + std::to_string(step + 1) + ": adding " + best.judged.effect +
                      " (held-out residual -" + fmt(100.0 * best.judged.relative_reduction, 3) + "%)");
  ps.cur = std::move(best.fit);
  ps.just_added = effects::createEffect(best.judged.effect)->name();
  recordStep(ps, best.judged, /*added=*/true, result);
  ps.visited.insert(ps.cur.model.name());
  ps.ranking = std::move(best.after);
}

}  // namespace

Fitted explainPath(const RankContext& rc, const Fitted& start, AnalysisResult& result) {
  result.steps.push_back(stepOf(start, result.noise_floor));
  PathState ps{start, result.candidates, {}, {start.model.name(), canonicalModel(effectNames(start.model)).name()}, {}};
  for (int step = 0; step < rc.options.max_explain_steps; ++step) {
    if (std::optional<Removal> drop = backwardElimination(rc, ps, &result.kept_unsupported)) {
      takeRemoval(rc, step, *drop, ps, result);
      continue;
    }
    std::vector<CandidateResult> rejected;  // recommended when screened, not on the full fit
    std::optional<Lookahead> best = forwardWithLookahead(rc, ps, rejected);
    if (!best) {
      markRejected(rejected, ps.ranking);
      break;
    }
    takeAddition(rc, step, *best, ps, result);
  }
  Fitted cur = std::move(ps.cur);
  // The same set of effects always ends under the same name (and column order).
  Model canon = canonicalModel(effectNames(cur.model));
  if (canon.name() != cur.model.name()) {
    auto [lin, sol] = rc.eng.fitFully(canon, cur.lin);
    cur = Fitted{std::move(canon), lin, sol};
    result.steps.back().model = cur.model.name();
  }
  result.final_report = makeReport(rc.eng, cur.model, cur.lin, cur.sol);
  result.final_residual = cur.sol.heldout_residual;
  result.final_candidates = std::move(ps.ranking);
  return cur;
}

}  // namespace ftid::lab::detail
