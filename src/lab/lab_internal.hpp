#pragma once
// Internals of the model laboratory shared by analyze.cpp (the analysis), select.cpp (the ranking
// of candidates under the one rule, lab/verdict.hpp) and explain.cpp (the path of --explain).
// Private to ftid_lab.
#include <string>
#include <vector>

#include "engine.hpp"
#include "ftid/lab/analyze.hpp"
#include "ftid/lab/verdict.hpp"

namespace ftid::lab::detail {

/// One model fitted on the engine's data (full nonlinear fit, folds).
struct Fitted {
  effects::Model model;
  Linearization lin;
  Solution sol;
};

/// Everything a ranking needs besides the model it ranks against.
struct RankContext {
  const Engine& eng;
  const std::vector<std::string>& menu;
  const AnalyzeOptions& options;
  std::string log_cmd;     ///< the log part of the suggested commands (already shell-quoted)
  double scale_sd = 0.0;   ///< colourScaleSd of the noise estimate
  /// m of the Bonferroni correction, the same in every ranking and step of the path: the menu's
  /// effects that can be tried on this data (familySize), whatever the model they are tried against.
  int family_size = 1;
};

void say(const AnalyzeOptions& o, const std::string& line);
/// Saturation (issue 22, saturation.cpp): marks the samples of d at a range limit as excluded (left
/// out of every fit and held-out sum) and reports them in result (lines to options.progress).
void excludeSaturation(Dataset& d, const AnalyzeOptions& options, AnalysisResult& result);
/// The text summary's lines and the HTML report's block of result.saturation ("" when none).
std::string saturationText(const AnalysisResult& r);
std::string saturationHtml(const AnalysisResult& r);
std::string fmt(double v, int precision = 4);

ModelReport makeReport(const Engine& eng, const effects::Model& model, const Linearization& lin, const Solution& sol);
double totalRatio(const Vec6& rms, const Vec6& noise);

/// Checks the signals a model needs against the data; "" if fine, else the reason.
std::string missingSignal(const effects::Model& model, const std::vector<SampleContext>& ctx);
/// The scale uncertainty of a candidate's F statistic that the estimated noise colour brings.
double colourScaleSd(const Vec6& ar1, const Vec6& ar1_std);
std::vector<std::string> candidateMenu(const AnalyzeOptions& options);

/// Parameter names of a fit in column order: the model's, then tilt_u, tilt_v, the mounting
/// angles and the delay as the linearisation has columns for them.
std::vector<std::string> fittedNames(const effects::Model& model, const Linearization& lin);
/// The rule's view of a fit (lab/verdict.hpp): values (nonlinear ones at lin + correction), its own
/// covariance; `added` marks the names `simpler` lacks (nullptr: none added); `samples`: the fit's
/// samples, for the physics that depends on them (FitView::samples).
FitView fitView(const effects::Model& model, const Linearization& lin, const Solution& sol,
                const std::vector<std::string>* simpler_names, const std::vector<SampleContext>& samples);

/// The law of the held-out gain under "the candidate adds nothing" (docs/analyze.md, "The verdict:
/// one rule"). Z: the richer model's solved (prewhitened) design; simple_cols: the columns of Z
/// that are the simpler model's. With e the whitened noise (white, variance sigma^2, under the
/// estimated noise model) and every fold's fit linear in e, the gain
/// Delta = SSE_heldout(simple) - SSE_heldout(rich) = sum over folds f (test block h) of
///   -2 u_hS' b_f + b_f' G_hSS b_f + 2 u_h' c_f - c_f' G_h c_f
/// (u_b = Z_b' e_b, G_b = Z_b' Z_b per block; c_f, b_f the rich and simple fold fits) is a quadratic
/// form in the u_b ~ N(0, sigma^2 G_b), independent across blocks, so Delta / sigma^2 =
/// sum_k lambda_k chi2_1: returns the lambda_k (weightedChiSquareSurvival gives its tail).
std::vector<double> heldOutNullWeights(const Engine& eng, const Engine::Design& Z, const std::vector<int>& simple_cols);
/// The candidate's p-value: P(Delta_null >= the observed held-out gain), Delta_null the gain of
/// adding the columns rich_view marks as added (rich's design) to the simpler model's own design
/// (heldOutNullWeights on [simple's columns | those columns]).
double heldOutPValue(const RankContext& rc, const Engine::Design& simple, const Engine::Design& rich,
                     const FitView& rich_view, double simple_sse_heldout, const Solution& rich_sol);

/// Ranks the menu against `base`, each candidate judged by the rule (screened to first order in
/// its nonlinear parameters). Recommended ones first, then by held-out BIC.
std::vector<CandidateResult> rankCandidates(const RankContext& rc, const Fitted& base);
/// The family of the Bonferroni correction, computed once per analysis: the effects of the menu
/// that are valid, not in the paper's model (the floor of every model) and that the data can show
/// (their signals present; a delay not on a static pose set). Independent of the starting model.
int familySize(const Engine& eng, const std::vector<std::string>& menu);
/// The rule on two full fits: `rich` = `simple` + `effect`.
CandidateResult judgeNested(const RankContext& rc, const Fitted& simple, const Fitted& rich, const std::string& effect);

/// The best start of the full fit of `cand` (a model with mounting): the model's initial
/// linearisation with the mounting angles of the one of the 24 axis-aligned rotations whose linear
/// solve fits best in-sample.
Linearization bestMountStart(const Engine& eng, const effects::Model& cand);

/// Canonical model of a set of effects: paper's first, then in the registry's order (same set,
/// same name, whatever the order of the steps that built it).
effects::Model canonicalModel(const std::vector<std::string>& effect_names);
std::vector<std::string> effectNames(const effects::Model& model);

/// --explain: forward selection with backward elimination under the rule (docs/analyze.md,
/// "Explain"); fills result.steps, final_report, final_residual, final_candidates; returns the
/// last model of the path.
Fitted explainPath(const RankContext& rc, const Fitted& start, AnalysisResult& result);

}  // namespace ftid::lab::detail
