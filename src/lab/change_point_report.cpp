// Change points in the reports of `ftid analyze` (include/ftid/lab/change_point.hpp): the line that
// leads the text summary, the JSON array and the HTML block near the top of the page.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "change_point_scan.hpp"
#include "ftid/common/error.hpp"
#include "ftid/fileio/json_text.hpp"

namespace ftid::lab {

namespace {

/// Decimals that show a standard deviation with two significant digits.
int decimalsOf(double sd) {
  if (!(sd > 0.0) || !std::isfinite(sd)) return 3;
  return std::clamp(1 - static_cast<int>(std::floor(std::log10(sd))), 0, 9);
}

std::string fixed(double v, int decimals, bool sign) {
  char b[64];
  std::snprintf(b, sizeof b, sign ? "%+.*f" : "%.*f", decimals, v);
  return b;
}

std::string plusMinus(double v, double sd, bool sign) {
  const int d = decimalsOf(sd);
  return fixed(v, d, sign) + " \u00b1 " + fixed(sd, d, false);
}

/// The time as a command-line argument: enough decimals to fall between two samples.
std::string timeArg(const ChangePoint& cp) {
  const double n = std::max(1.0, static_cast<double>(cp.sample));
  const double dt = std::max(1e-9, (cp.t - cp.t_first) / n);
  const int d = std::clamp(static_cast<int>(std::ceil(-std::log10(dt / 4.0))), 0, 9);
  return fixed(cp.t, d, false);
}

std::string escHtml(const std::string& s) {
  std::string o;
  for (char c : s) {
    if (c == '<') o += "&lt;";
    else if (c == '>') o += "&gt;";
    else if (c == '&') o += "&amp;";
    else if (c == '"') o += "&quot;";
    else o += c;
  }
  return o;
}

}  // namespace

std::string describeChangePoint(const ChangePoint& cp) {
  std::string s = "the " + cp.kind + " changed at t = " + plusMinus(cp.t, cp.t_std, false) + " s:";
  std::vector<const ChangeDelta*> shown;
  for (const auto& d : cp.delta) {
    if (std::abs(d.value) > 3.0 * d.std) shown.push_back(&d);
  }
  std::stable_sort(shown.begin(), shown.end(), [](const ChangeDelta* a, const ChangeDelta* b) {
    return std::abs(a->value) / std::max(a->std, 1e-300) > std::abs(b->value) / std::max(b->std, 1e-300);
  });
  if (cp.kind == "payload") {
    // The mass first: it is what a grasp or a release changes.
    const auto it = std::find_if(shown.begin(), shown.end(), [](const ChangeDelta* d) { return d->name == "mass"; });
    if (it != shown.end()) std::rotate(shown.begin(), it, it + 1);
  }
  if (shown.size() > 4) shown.resize(4);
  for (std::size_t k = 0; k < shown.size(); ++k) {
    s += std::string(k ? ", " : " ") + shown[k]->name + " " + plusMinus(shown[k]->value, shown[k]->std, true) + " " +
         shown[k]->unit;
  }
  if (shown.empty()) s += " no single parameter by more than 3 standard errors (all in the JSON)";
  return s;
}

std::vector<std::string> splitCommands(const ChangePoint& cp, const std::string& log_cmd, const std::string& model) {
  const std::string t = timeArg(cp);
  const std::string m = " --model " + shellQuote(model);
  return {"ftid analyze " + log_cmd + " --t-to " + t + m, "ftid analyze " + log_cmd + " --t-from " + t + m};
}

void applyTimeWindow(samples::ContextSet& set, double t_from, double t_to, const std::string& log) {
  if (!(t_from < t_to)) throw DataError(log + ": --t-from " + detail::fmt(t_from, 6) + " is not before --t-to " + detail::fmt(t_to, 6));
  if (set.samples.empty() || (std::isinf(t_from) && std::isinf(t_to))) return;
  const std::size_t k = set.extra_names.size();
  const double first = set.samples.front().t, last = set.samples.back().t;
  std::size_t kept = 0;
  for (std::size_t i = 0; i < set.samples.size(); ++i) {
    const double t = set.samples[i].t;
    if (!(t >= t_from && t < t_to)) continue;
    set.samples[kept] = set.samples[i];
    std::copy_n(set.extra_rows.begin() + static_cast<std::ptrdiff_t>(i * k), k,
                set.extra_rows.begin() + static_cast<std::ptrdiff_t>(kept * k));
    ++kept;
  }
  if (kept == 0) {
    throw DataError(log + ": no sample with " + detail::fmt(t_from, 6) + " <= t < " + detail::fmt(t_to, 6) + " s (its samples span t = " +
                    detail::fmt(first, 6) + " .. " + detail::fmt(last, 6) + " s since the first)");
  }
  set.samples.resize(kept);
  set.extra_rows.resize(kept * k);
  set.repoint();
}

namespace detail {

void reportChangePoints(const RankContext& rc, const Fitted& base, AnalysisResult& result) {
  double best = 0.0;
  for (const auto& c : result.candidates) {
    if (c.significant) best = std::max(best, c.relative_reduction);
  }
  ScanNote note;
  const auto t0 = std::chrono::steady_clock::now();
  const auto cp = findChangePoint(rc, base, best, &note);
  say(rc.options, "change-point scan: " +
                      fmt(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 3) + " s");
  result.change_point_scan_p = note.p_scan;
  if (!cp) {
    if (!note.why.empty()) say(rc.options, "no change point: " + note.why);
    return;
  }
  result.change_points.push_back(*cp);
  const auto cmds = splitCommands(*cp, rc.log_cmd, base.model.name());
  say(rc.options, describeChangePoint(*cp));
  result.warnings.push_back(describeChangePoint(*cp) + ": the log holds two set-ups, which no smooth effect "
                            "describes; analyze each segment (" + cmds[0] + "; " + cmds[1] +
                            ") and write no parameters fitted across the change");
}

std::string changePointText(const AnalysisResult& r) {
  if (r.change_points.empty()) return "";
  std::string s;
  for (const auto& cp : r.change_points) {
    s += describeChangePoint(cp) + "\n";
    s += "  (" + std::string(cp.kind == "payload" ? "payload step: mass, centre of mass" : "offsets step") +
         "; held-out error " + fixed(-100.0 * cp.heldout_reduction, 1, true) + " % with the step; family-wise p = " +
         (cp.family_p < 1e-300 ? std::string("< 1e-300") : fmt(cp.family_p, 2)) + ")\n";
    const auto cmds = splitCommands(cp, shellQuote(r.log), r.report.model);
    s += "  the log holds two set-ups: analyze each segment, not one model with smooth effects:\n";
    for (const auto& c : cmds) s += "    " + c + "\n";
  }
  return s + "\n";
}

std::string changePointHtml(const AnalysisResult& r) {
  if (r.change_points.empty()) return "";
  std::ostringstream o;
  o << "<h2>Change in time</h2>\n";
  for (const auto& cp : r.change_points) {
    o << "<p class=\"warn\"><b>" << escHtml(describeChangePoint(cp)) << "</b> (held-out error "
      << escHtml(fixed(-100.0 * cp.heldout_reduction, 1, true)) << " % with the step). The log holds two set-ups: "
      << "analyze each segment:<br>";
    for (const auto& c : splitCommands(cp, shellQuote(r.log), r.report.model)) o << "<code>" << escHtml(c) << "</code><br>";
    o << "</p>\n";
  }
  return o.str();
}

void addChangePointsJson(const AnalysisResult& r, nlohmann::ordered_json& o) {
  Json list = Json::array();
  for (const auto& cp : r.change_points) {
    Json delta = Json::object();
    for (const auto& d : cp.delta) {
      delta[d.name] = Json{{"value", jsonNumber(d.value)}, {"std", jsonNumber(d.std)}, {"unit", d.unit}};
    }
    Json split = Json::array();
    for (const auto& c : splitCommands(cp, shellQuote(r.log), r.report.model)) split.push_back(c);
    list.push_back(Json{{"t", jsonNumber(cp.t)},
                        {"t_std", jsonNumber(cp.t_std)},
                        {"kind", cp.kind},
                        {"delta", std::move(delta)},
                        {"p_value", jsonNumber(cp.p_value)},
                        {"family_p_value", jsonNumber(cp.family_p)},
                        {"heldout_reduction", jsonNumber(cp.heldout_reduction)},
                        {"split_commands", std::move(split)}});
  }
  o["change_points"] = std::move(list);
  o["change_point_scan_p_value"] = jsonNumber(r.change_point_scan_p);
}

}  // namespace detail

}  // namespace ftid::lab
