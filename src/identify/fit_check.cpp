// Held-out residual against the noise floor (include/ftid/identify/fit_check.hpp).
#include "ftid/identify/fit_check.hpp"

#include <cmath>
#include <cstdio>
#include <limits>

#include "ftid/common/error.hpp"
#include "ftid/effects/model.hpp"
#include "ftid/identify/fit.hpp"
#include "ftid/identify/noise.hpp"
#include "json_internal.hpp"

namespace ftid::identify {


FitCheck checkFit(const std::vector<SampleContext>& ctx, const IdentifyFn& identify, const std::string& analyze_command,
                  const std::optional<Vec6>& noise_std, int folds) {
  FitCheck out;
  const int n = static_cast<int>(ctx.size());
  out.noise = noise_std ? dataSheetNoiseFloor(*noise_std) : estimateNoiseFloor(ctx);
  out.folds = folds;
  // Predictions use the whole series (a delayed model reads the kinematics of neighbouring samples,
  // which are inputs, not training data), then keep the samples asked for.
  std::vector<int> all_idx(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) all_idx[static_cast<std::size_t>(i)] = i;
  auto predict = [&](const ParameterSet& set, const std::vector<int>& idx) {
    const effects::Model model = effects::Model::fromName(set.model);
    const Eigen::VectorXd theta = thetaFor(model, set);
    const auto full = predictWrench(model, theta, nonlinearFor(model, set), set.tilt_estimated, ctx, all_idx);
    Eigen::Matrix<double, 6, Eigen::Dynamic> sel(6, static_cast<Eigen::Index>(idx.size()));
    for (std::size_t k = 0; k < idx.size(); ++k) sel.col(static_cast<Eigen::Index>(k)) = full.col(idx[k]);
    return sel;
  };
  // The residual of the fit on all data: the noise colour (noise.hpp, refineNoiseFloor) and the
  // glitches, which are left out of the held-out sums (a spike is not a model error).
  std::vector<char> glitch(static_cast<std::size_t>(n), 0);
  {
    std::vector<int> all(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) all[static_cast<std::size_t>(i)] = i;
    const auto pred = predict(identify(ctx), all);
    Eigen::Matrix<double, 6, Eigen::Dynamic> res(6, n);
    for (int i = 0; i < n; ++i) res.col(i) = ctx[static_cast<std::size_t>(i)].wrench_S - pred.col(i);
    if (!noise_std) refineNoiseFloor(out.noise, res, ctx);
    for (int i : detectOutliers(res, !holdsStill(ctx), 6.0).samples) {  // findGlitches' rule
      glitch[static_cast<std::size_t>(i)] = 1;
      ++out.glitches;
    }
  }
  Vec6 ss = Vec6::Zero();
  int counted = 0, failed = 0;
  const std::vector<int> bounds = foldBoundaries(ctx, folds);
  for (int f = 0; f < folds; ++f) {
    const int b0 = bounds[static_cast<std::size_t>(f)];
    const int b1 = bounds[static_cast<std::size_t>(f) + 1];
    std::vector<SampleContext> train;
    train.reserve(static_cast<std::size_t>(n - (b1 - b0)));
    std::vector<int> test;
    for (int i = 0; i < n; ++i) {
      if (i >= b0 && i < b1) {
        test.push_back(i);
      } else {
        train.push_back(ctx[static_cast<std::size_t>(i)]);
      }
    }
    try {
      const auto pred = predict(identify(train), test);
      for (std::size_t k = 0; k < test.size(); ++k) {
        if (glitch[static_cast<std::size_t>(test[k])]) continue;
        ss += (ctx[static_cast<std::size_t>(test[k])].wrench_S - pred.col(static_cast<Eigen::Index>(k))).cwiseAbs2();
        ++counted;
      }
    } catch (const Error&) {
      ++failed;
    }
  }
  out.heldout_rms = counted > 0 ? Vec6((ss / counted).cwiseSqrt()) : Vec6::Constant(std::numeric_limits<double>::quiet_NaN());
  if (out.glitches > 0) {
    out.warnings.push_back(std::to_string(out.glitches) + " glitch" + (out.glitches == 1 ? "" : "es") +
                           " (isolated spikes beyond 6 robust standard deviations) left out of the held-out "
                           "residual");
  }
  if (failed > 0) {
    out.warnings.push_back(std::to_string(failed) + " of " + std::to_string(folds) +
                           " held-out blocks could not be identified without them (too little excitation "
                           "elsewhere): the held-out residual covers the rest");
  }
  if (!out.noise.observable()) {
    out.residual_to_noise = Vec6::Constant(std::numeric_limits<double>::quiet_NaN());
    out.warnings.push_back("the noise floor is not observable (one reading per pose), so the fit cannot be "
                           "judged against it: give the sensor's noise with --noise fx=..,..,tz=..");
    return out;
  }
  std::string above;
  double worst = 0.0;
  for (int a = 0; a < 6; ++a) {
    out.residual_to_noise(a) = out.heldout_rms(a) / std::max(out.noise.std(a), 1e-12);
    if (out.residual_to_noise(a) > kAboveFloorMark) {
      char b[48];
      std::snprintf(b, sizeof b, "%s%s %.2gx", above.empty() ? "" : ", ", kWrenchAxisNames[a], out.residual_to_noise(a));
      above += b;
    }
    worst = std::max(worst, out.residual_to_noise(a));
  }
  if (!above.empty()) {
    char b[32];
    std::snprintf(b, sizeof b, "%.2g", worst);
    out.warnings.push_back("the held-out residual is up to " + std::string(b) + "x the noise floor (" + above +
                           "): the model misses something and its standard errors are too optimistic; run `" +
                           analyze_command + "`");
  }
  return out;
}

std::string formatFitCheck(const FitCheck& c) {
  std::string s = "held-out residual (" + std::to_string(c.folds) + " contiguous blocks) against the noise floor (" +
                  toString(c.noise.method) + "):\n";
  char line[160];
  for (int a = 0; a < 6; ++a) {
    const char* u = a < 3 ? "N" : "Nm";
    char ratio[40] = "(noise not observable)";
    if (std::isfinite(c.residual_to_noise(a))) {
      std::snprintf(ratio, sizeof ratio, "%.2fx%s", c.residual_to_noise(a), c.residual_to_noise(a) > kAboveFloorMark ? "  <- above" : "");
    }
    std::snprintf(line, sizeof line, "  %-3s %10.4g %-2s  noise %10.4g %-2s  %s\n", kWrenchAxisNames[a], c.heldout_rms(a), u,
                  c.noise.std(a), u, ratio);
    s += line;
  }
  for (const auto& w : c.warnings) s += "warning: " + w + "\n";
  return s;
}

namespace {

void addFitCheck(Json& j, const FitCheck& c) {
  j["noise_floor"] = axesJson(c.noise.std);
  j["noise_method"] = toString(c.noise.method);
  j["heldout_rms"] = axesJson(c.heldout_rms);
  j["residual_to_noise"] = axesJson(c.residual_to_noise);
  j["glitches"] = c.glitches;
  j["saturation"] = Json::parse(saturationJson(c.saturation));  // saturation (issue 22)
  j["warnings"] = c.warnings;
}

}  // namespace

std::string fitCheckJson(const FitCheck& check) {
  Json j = Json::object();
  addFitCheck(j, check);
  return jsonText(j);
}

std::string identificationJson(const ParameterSet& set, const FitCheck& check) {
  Json j = parameterSetJson(set);
  addFitCheck(j, check);
  return jsonText(j);
}

}  // namespace ftid::identify
