#pragma once
// The one robust data treatment of an identification (docs/identification.md, "Glitches"):
// isolated spikes in the wrench (CAN bus errors, EMI) are found in the residual of a first fit and
// left out of the fit that follows. `ftid identify`, the cell (`ftid --identify`) and `ftid analyze`
// judge a glitch by the same rule (detectOutliers, ftid/identify/noise.hpp: the residual minus its
// running median beyond kGlitchThreshold robust standard deviations; pose sets against the median).
#include <utility>
#include <vector>

#include "ftid/identify/fit_parameters.hpp"
#include "ftid/identify/noise.hpp"
#include "ftid/identify/saturation.hpp"

namespace ftid::identify {

/// Robust standard deviations beyond which an isolated sample is a glitch (analyze's default,
/// lab::AnalyzeOptions::glitch_threshold).
inline constexpr double kGlitchThreshold = 6.0;

/// The glitches of `residual` (6 x ctx.size(), measured - modelled): a time series is judged
/// against the running median of each segment (segment_starts: the first sample of each log;
/// empty = one log), a static pose set against the median.
Outliers findGlitches(const std::vector<SampleContext>& ctx, const Eigen::Matrix<double, 6, Eigen::Dynamic>& residual,
                      double threshold = kGlitchThreshold, const std::vector<int>& segment_starts = {});

/// measured - modelled for every context, with the model, theta and nonlinear parameters of `set`.
Eigen::Matrix<double, 6, Eigen::Dynamic> residualOf(const ParameterSet& set, const std::vector<SampleContext>& ctx);

/// The contexts without the samples listed (ascending indices); the rest keep their order.
std::vector<SampleContext> withoutSamples(const std::vector<SampleContext>& ctx, const std::vector<int>& samples);

/// Indices into the contexts left after withoutSamples(ctx, removed) mapped back to ctx's.
std::vector<int> originalIndices(const std::vector<int>& removed, const std::vector<int>& kept_indices);

/// The samples a fit kept, as one series: the columns of `residual` and the contexts of the samples
/// with left_out[i] == 0 (left_out empty: all kept), in order, spliced across every run that was
/// left out, as withoutSamples() splices them for `ftid identify`. The noise floor and the glitches
/// are judged on this series (refineNoiseFloor, detectOutliers): a left-out sample has no residual,
/// and a zero in its place would read as a quiet sensor (with fz clipped on 40 % of the samples the
/// floor came out about 15 % low and 190-250 samples of noise were flagged as glitches). Identity: residual.col(k) ==
/// input.col(index[k]) and ctx[k] is input ctx[index[k]]; segment_starts holds, for each input
/// start, the first kept sample at or after it (duplicates dropped).
struct KeptSeries {
  Eigen::Matrix<double, 6, Eigen::Dynamic> residual;
  std::vector<SampleContext> ctx;
  std::vector<int> segment_starts;
  std::vector<int> index;  ///< kept k -> input sample index[k]
};
KeptSeries keptSeries(const Eigen::Matrix<double, 6, Eigen::Dynamic>& residual, const std::vector<SampleContext>& ctx,
                      const std::vector<char>& left_out, const std::vector<int>& segment_starts = {});

/// A fit on data with its glitches left out: `first` is the fit on all of `ctx`; the glitches of its
/// residual are removed and `identify` runs again on the rest (only if there were any).
struct RobustIdentification {
  ParameterSet set;                   ///< the fit without the glitches (or `first` if none)
  /// The contexts it was fitted on when samples were left out; empty (and kept_all) when it was
  /// fitted on all of the input: no copy of a long log's contexts (fittedOn gives either).
  std::vector<SampleContext> samples;
  bool kept_all = false;
  Outliers glitches;                  ///< indices into the original contexts
  Saturation saturation;              ///< saturated samples left out first (leaveOutBadSamples)
  /// The contexts the fit used: `samples`, or `input` (the contexts given to leaveOutBadSamples or
  /// leaveOutGlitches) when nothing was left out.
  const std::vector<SampleContext>& fittedOn(const std::vector<SampleContext>& input) const {
    return kept_all ? input : samples;
  }
};
template <typename IdentifyFn>
RobustIdentification leaveOutGlitches(const std::vector<SampleContext>& ctx, const ParameterSet& first,
                                      const IdentifyFn& identify, double threshold = kGlitchThreshold) {
  RobustIdentification out;
  out.glitches = findGlitches(ctx, residualOf(first, ctx), threshold);
  if (out.glitches.samples.empty()) {
    out.set = first;
    out.kept_all = true;
    return out;
  }
  out.samples = withoutSamples(ctx, out.glitches.samples);
  out.set = identify(out.samples);
  return out;
}

/// The one robust data treatment, whole: the saturated samples (saturation.hpp, found on the
/// readings) are left out before the first fit, then the glitches of that fit's residual
/// (leaveOutGlitches). All indices refer to `ctx`.
template <typename IdentifyFn>
RobustIdentification leaveOutBadSamples(const std::vector<SampleContext>& ctx, const SaturationOptions& saturation,
                                        const IdentifyFn& identify, double threshold = kGlitchThreshold) {
  Saturation sat = findSaturation(ctx, saturation);
  if (sat.samples.empty()) {
    RobustIdentification out = leaveOutGlitches(ctx, identify(ctx), identify, threshold);
    out.saturation = std::move(sat);
    return out;
  }
  std::vector<SampleContext> kept = withoutSamples(ctx, sat.samples);
  RobustIdentification out = leaveOutGlitches(kept, identify(kept), identify, threshold);
  if (out.kept_all) {  // all of `kept`, which is not the caller's input
    out.samples = std::move(kept);
    out.kept_all = false;
  }
  out.glitches.samples = originalIndices(sat.samples, out.glitches.samples);
  out.saturation = std::move(sat);
  return out;
}

}  // namespace ftid::identify
