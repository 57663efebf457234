// Saturation and clipping of the wrench readings (include/ftid/identify/saturation.hpp).
#include "ftid/identify/saturation.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "ftid/common/error.hpp"
#include "ftid/fileio/json_text.hpp"

namespace ftid::identify {

namespace {

/// Tests per data set: 6 axes x 2 extremes (the family of the Bonferroni correction).
constexpr int kFlatTopTests = 12;

int axisIndex(const std::string& name) {
  for (int a = 0; a < 6; ++a) {
    if (name == kWrenchAxisNames[a]) return a;
  }
  return -1;
}

/// Whether sample i's reading differs from sample i-1's on some axis (the first sample is fresh).
std::vector<char> freshReadings(const std::vector<SampleContext>& ctx) {
  std::vector<char> fresh(ctx.size(), 1);
  for (std::size_t i = 1; i < ctx.size(); ++i) fresh[i] = ctx[i].wrench_S != ctx[i - 1].wrench_S ? 1 : 0;
  return fresh;
}

/// Fresh readings of one axis, sorted so that the extreme of `side` comes first.
std::vector<double> sortedFresh(const std::vector<SampleContext>& ctx, const std::vector<char>& fresh, int axis,
                                int side) {
  std::vector<double> v;
  for (std::size_t i = 0; i < ctx.size(); ++i) {
    const double x = side * ctx[i].wrench_S(axis);
    if (fresh[i] != 0 && std::isfinite(x)) v.push_back(x);  // a non-finite reading is no level
  }
  std::sort(v.begin(), v.end(), [](double x, double y) { return x > y; });
  return v;
}

/// Number of leading entries of `v` (descending) from `begin` within `tol` of v[begin].
std::size_t levelCount(const std::vector<double>& v, std::size_t begin, double tol) {
  std::size_t k = begin;
  while (k < v.size() && v[k] >= v[begin] - tol) ++k;
  return k - begin;
}

/// The flat-top test of one axis at one extreme: the level (signed back) and the family p-value,
/// or family_p = 1 when the axis is constant or has too few levels.
struct FlatTop {
  double level = 0.0;
  double tol = 0.0;
  double family_p = 1.0;
};

FlatTop flatTop(const std::vector<SampleContext>& ctx, const std::vector<char>& fresh, int axis, int side) {
  FlatTop out;
  const std::vector<double> v = sortedFresh(ctx, fresh, axis, side);
  if (v.size() < 2) return out;
  const double span = v.front() - v.back();
  if (!(span > 0.0) || !std::isfinite(span)) return out;  // a constant axis has no extreme level
  out.tol = kLevelTolerance * span;
  out.level = side * v.front();
  const std::size_t c_top = levelCount(v, 0, out.tol);
  if (c_top >= v.size()) return out;
  const std::size_t c_next = levelCount(v, c_top, out.tol);
  out.family_p = std::min(1.0, kFlatTopTests * flatTopPValue(static_cast<int>(c_top), static_cast<int>(c_next)));
  return out;
}

/// The samples of `axis` at the limit of `side`: on the flat top (when `top` is significant) or
/// at or beyond the rated limit (when given).
SaturatedAxis atLimit(const std::vector<SampleContext>& ctx, const FlatTop& top, double rated, int axis, int side,
                      std::vector<char>& saturated) {
  SaturatedAxis s;
  s.axis = axis;
  s.side = side;
  s.flat_top = top.family_p < kSaturationAlpha;
  s.family_p = top.family_p;
  for (std::size_t i = 0; i < ctx.size(); ++i) {
    const double x = side * ctx[i].wrench_S(axis);
    const bool on_top = s.flat_top && x >= side * top.level - top.tol;
    const bool beyond = rated > 0.0 && x >= rated;
    if (!on_top && !beyond) continue;
    s.rated = s.rated || beyond;
    saturated[i] = 1;
    ++s.count;
    if (static_cast<int>(s.times.size()) < kMaxSaturationTimes) s.times.push_back(ctx[i].t);
  }
  s.value = s.flat_top ? top.level : side * rated;
  s.fraction = static_cast<double>(s.count) / static_cast<double>(std::max<std::size_t>(1, ctx.size()));
  return s;
}

}  // namespace

Vec6 parseRatedRange(const std::string& text) {
  Vec6 out = Vec6::Zero();
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    const auto eq = item.find('=');
    const std::string key = item.substr(0, eq);
    const int a = axisIndex(key);
    if (eq == std::string::npos || a < 0) {
      throw ConfigError("--rated-range: '" + item + "' is not axis=limit with axis fx, fy, fz, tx, ty or tz");
    }
    const std::string value = item.substr(eq + 1);
    char* end = nullptr;
    const double limit = std::strtod(value.c_str(), &end);
    if (value.empty() || end != value.c_str() + value.size() || !std::isfinite(limit) || limit <= 0.0) {
      throw ConfigError("--rated-range: the limit of " + key + " must be a positive number [N or Nm], not '" + value + "'");
    }
    out(a) = limit;
  }
  return out;
}

double flatTopPValue(int c_top, int c_next) {
  const int n = c_top + c_next;
  if (c_top <= 0 || n <= 0) return 1.0;
  // P(X >= c_top) = sum_{k >= c_top} C(n, k) 2^-n, summed in logs (n may be thousands).
  double p = 0.0;
  for (int k = c_top; k <= n; ++k) {
    p += std::exp(std::lgamma(n + 1.0) - std::lgamma(k + 1.0) - std::lgamma(n - k + 1.0) - n * std::log(2.0));
  }
  return std::min(1.0, p);
}

Saturation findSaturation(const std::vector<SampleContext>& ctx, const SaturationOptions& options) {
  Saturation out;
  out.n = static_cast<int>(ctx.size());
  const std::vector<char> fresh = freshReadings(ctx);
  std::vector<char> saturated(ctx.size(), 0);
  for (int a = 0; a < 6; ++a) {
    for (int side : {1, -1}) {
      const FlatTop top = options.flat_tops ? flatTop(ctx, fresh, a, side) : FlatTop{};
      const SaturatedAxis s = atLimit(ctx, top, options.rated_range(a), a, side, saturated);
      if (s.count > 0) out.axes.push_back(s);
    }
  }
  for (std::size_t i = 0; i < ctx.size(); ++i) {
    if (saturated[i] != 0) out.samples.push_back(static_cast<int>(i));
  }
  return out;
}

std::string saturationLine(const SaturatedAxis& s) {
  const char* unit = s.axis < 3 ? "N" : "Nm";
  char line[320];
  std::snprintf(line, sizeof line, "%s %s %.4g %s on %d sample%s (%.1f %%) - left out of the fit; %s",
                kWrenchAxisNames[s.axis], s.flat_top ? "saturates at" : "reaches its rated range at", s.value, unit,
                s.count, s.count == 1 ? "" : "s", 100.0 * s.fraction,
                "check the sensor's range or the tool load");
  return line;
}

std::string saturationJson(const std::vector<SaturatedAxis>& axes) {
  Json out = Json::array();
  for (const auto& s : axes) {
    Json times = Json::array();
    for (const double t : s.times) times.push_back(jsonNumber(t));
    out.push_back({{"axis", kWrenchAxisNames[s.axis]}, {"side", s.side > 0 ? "max" : "min"},
                   {"value", jsonNumber(s.value)}, {"count", s.count}, {"fraction", jsonNumber(s.fraction)},
                   {"times", std::move(times)},
                   {"source", s.flat_top ? (s.rated ? "flat_top+rated_range" : "flat_top") : "rated_range"},
                   {"family_p", jsonNumber(s.family_p)}});
  }
  return jsonText(out);
}

}  // namespace ftid::identify
