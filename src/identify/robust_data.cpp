// The one robust data treatment of an identification (include/ftid/identify/robust_data.hpp).
#include "ftid/identify/robust_data.hpp"

#include <algorithm>

#include "ftid/effects/model.hpp"
#include "ftid/identify/fit.hpp"

namespace ftid::identify {

Outliers findGlitches(const std::vector<SampleContext>& ctx, const Eigen::Matrix<double, 6, Eigen::Dynamic>& residual,
                      double threshold, const std::vector<int>& segment_starts) {
  if (ctx.empty() || residual.cols() != static_cast<Eigen::Index>(ctx.size())) return {};
  // A pose set's neighbours may be other poses: the median. A log that moves (holdsStill: at least
  // kMinMovingSamples moving samples, however long it rests) is a time series, whose model error
  // between the rests the running median follows (judged against the median, a log that moved for
  // 10 s and rested for 10 s had 972 of its 2,501 samples taken for glitches).
  return detectOutliers(residual, !holdsStill(ctx), threshold, segment_starts);
}

Eigen::Matrix<double, 6, Eigen::Dynamic> residualOf(const ParameterSet& set, const std::vector<SampleContext>& ctx) {
  const int n = static_cast<int>(ctx.size());
  std::vector<int> all(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) all[static_cast<std::size_t>(i)] = i;
  const effects::Model model = effects::Model::fromName(set.model);
  const Eigen::VectorXd theta = thetaFor(model, set);
  Eigen::Matrix<double, 6, Eigen::Dynamic> res =
      predictWrench(model, theta, nonlinearFor(model, set), set.tilt_estimated, ctx, all);
  for (int i = 0; i < n; ++i) res.col(i) = ctx[static_cast<std::size_t>(i)].wrench_S - res.col(i);
  return res;
}

std::vector<SampleContext> withoutSamples(const std::vector<SampleContext>& ctx, const std::vector<int>& samples) {
  std::vector<SampleContext> out;
  out.reserve(ctx.size() - std::min(ctx.size(), samples.size()));
  std::size_t k = 0;
  for (std::size_t i = 0; i < ctx.size(); ++i) {
    while (k < samples.size() && samples[k] < static_cast<int>(i)) ++k;
    if (k < samples.size() && samples[k] == static_cast<int>(i)) continue;
    out.push_back(ctx[i]);
  }
  return out;
}

std::vector<int> originalIndices(const std::vector<int>& removed, const std::vector<int>& kept_indices) {
  // kept index j is original j + (number of removed indices <= it), both lists ascending.
  std::vector<int> out;
  out.reserve(kept_indices.size());
  std::size_t r = 0;
  for (int j : kept_indices) {
    while (r < removed.size() && removed[r] <= j + static_cast<int>(r)) ++r;
    out.push_back(j + static_cast<int>(r));
  }
  return out;
}

KeptSeries keptSeries(const Eigen::Matrix<double, 6, Eigen::Dynamic>& residual, const std::vector<SampleContext>& ctx,
                      const std::vector<char>& left_out, const std::vector<int>& segment_starts) {
  const int n = static_cast<int>(std::min<Eigen::Index>(residual.cols(), static_cast<Eigen::Index>(ctx.size())));
  KeptSeries out;
  for (int i = 0; i < n; ++i) {
    if (static_cast<std::size_t>(i) < left_out.size() && left_out[static_cast<std::size_t>(i)] != 0) continue;
    out.index.push_back(i);
  }
  const auto m = static_cast<Eigen::Index>(out.index.size());
  out.residual.resize(6, m);
  out.ctx.reserve(out.index.size());
  for (Eigen::Index k = 0; k < m; ++k) {
    const int i = out.index[static_cast<std::size_t>(k)];
    out.residual.col(k) = residual.col(i);
    out.ctx.push_back(ctx[static_cast<std::size_t>(i)]);
  }
  for (int start : segment_starts.empty() ? std::vector<int>{0} : segment_starts) {
    const auto first = std::lower_bound(out.index.begin(), out.index.end(), start);
    const int k = static_cast<int>(first - out.index.begin());
    if (k < m && (out.segment_starts.empty() || out.segment_starts.back() != k)) out.segment_starts.push_back(k);
  }
  if (out.segment_starts.empty() || out.segment_starts.front() != 0) out.segment_starts.insert(out.segment_starts.begin(), 0);
  return out;
}

}  // namespace ftid::identify
