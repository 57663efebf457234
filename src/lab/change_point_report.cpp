// Change points in the reports of `ftid analyze` (include/ftid/lab/change_point.hpp): the line that
// leads the text summary, the JSON array and the HTML block near the top of the page.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
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

std::vector<std::string> segmentCommands(const std::vector<ChangePoint>& cps, const std::string& log_cmd,
                                         const std::string& model) {
  const std::string m = " --model " + shellQuote(model);
  std::vector<std::string> out;
  for (std::size_t j = 0; j <= cps.size(); ++j) {
    std::string c = "ftid analyze " + log_cmd;
    if (j > 0) c += " --t-from " + timeArg(cps[j - 1]);
    if (j < cps.size()) c += " --t-to " + timeArg(cps[j]);
    out.push_back(c + m);
  }
  return out;
}

bool undoes(const ChangePoint& first, const ChangePoint& second) {
  if (first.kind != second.kind || first.delta.size() != second.delta.size()) return false;
  double left = 0.0, changed = 0.0;
  bool shown = false;
  for (std::size_t j = 0; j < first.delta.size(); ++j) {
    const ChangeDelta& a = first.delta[j];
    const ChangeDelta& b = second.delta[j];
    const double sd = std::max(a.std, 1e-300);
    left += std::pow((a.value + b.value) / sd, 2);
    changed += std::pow(a.value / sd, 2);
    shown = shown || std::abs(a.value) > 3.0 * a.std;
  }
  return shown && left <= 0.25 * changed;
}

void applyTimeWindow(samples::ContextSet& set, double t_from, double t_to, const std::string& log) {
  if (!(t_from < t_to)) throw DataError(log + ": --t-from " + detail::fmt(t_from, 6) + " is not before --t-to " + detail::fmt(t_to, 6));
  if (set.samples.empty() || (std::isinf(t_from) && std::isinf(t_to))) return;
  const double first = set.samples.front().t, last = set.samples.back().t;
  std::vector<char> keep(set.samples.size(), 0);
  std::size_t kept = 0;
  for (std::size_t i = 0; i < set.samples.size(); ++i) {
    const double t = set.samples[i].t;
    keep[i] = t >= t_from && t < t_to ? 1 : 0;
    kept += static_cast<std::size_t>(keep[i]);
  }
  if (kept == 0) {
    throw DataError(log + ": no sample with " + detail::fmt(t_from, 6) + " <= t < " + detail::fmt(t_to, 6) + " s (its samples span t = " +
                    detail::fmt(first, 6) + " .. " + detail::fmt(last, 6) + " s since the first)");
  }
  set.keepRows(keep);
}

namespace detail {

/// "two set-ups" for one change point, "three set-ups" for two.
std::string setUps(std::size_t change_points) {
  return std::string(change_points == 1 ? "two" : "three") + " set-ups";
}

/// What two change points of one log say together.
std::string transientNote(const std::vector<ChangePoint>& cps) {
  if (cps.size() < 2) return "";
  return undoes(cps[0], cps[1]) ? "the second change undoes the first: a transient, such as a contact with the tool "
                                  "or an object held for a while"
                                : "two changes";
}

void reportChangePoints(const RankContext& rc, const Fitted& base, AnalysisResult& result,
                        const std::function<DynamicsCheck()>& reading_dynamics,
                        const std::function<SmoothPath()>& smooth_path) {
  // The smooth effects a step must beat: every candidate whose held-out gain the rule finds
  // significant, recommended or refused. A refused fit (not identifiable, not physical) is no
  // model to take, but its gain still shows a residual that follows the motion rather than time.
  double best = 0.0;
  for (const auto& c : result.candidates) {
    if (c.verdict == Verdict::kRecommended || c.verdict == Verdict::kRefused) best = std::max(best, c.relative_reduction);
  }
  ScanNote note;
  const auto t0 = std::chrono::steady_clock::now();
  const auto cps = findChangePoints(rc, base, best, &note);
  say(rc.options, "change-point scan: " +
                      fmt(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 3) + " s");
  result.change_point_scan_p = note.p_scan;
  if (cps.empty()) {
    if (!note.why.empty()) say(rc.options, "no change point: " + note.why);
    return;
  }
  // The reading's dynamics compete too (a compliant mount's lag in a slow motion reads as offsets
  // steps); searched only now, when steps would be reported (60 filters, each a fit).
  if (reading_dynamics) {
    const DynamicsCheck d = reading_dynamics();
    if (d.significant && d.relative_reduction > cps.front().heldout_reduction) {
      say(rc.options, "no change point: the steps would lower the held-out error by " +
                          fmt(100.0 * cps.front().heldout_reduction, 3) + " %, less than the reading's dynamics (" +
                          d.effect + ", " + fmt(100.0 * d.relative_reduction, 3) + " %)");
      return;
    }
  }
  // ... and so does the smooth model the path reaches (several effects together, none of which
  // alone beats the steps against base).
  if (smooth_path) {
    say(rc.options, "change points: would the smooth model --explain reaches explain more?");
    const SmoothPath path = smooth_path();
    if (path.heldout_reduction > cps.front().heldout_reduction) {
      say(rc.options, "no change point: the steps would lower the held-out error by " +
                          fmt(100.0 * cps.front().heldout_reduction, 3) + " %, less than " + path.model + " (" +
                          fmt(100.0 * path.heldout_reduction, 3) + " %), which --explain reaches without them");
      return;
    }
  }
  result.change_points = cps;
  const auto cmds = segmentCommands(cps, rc.log_cmd, base.model.name());
  std::string what;
  for (const auto& cp : cps) {
    say(rc.options, describeChangePoint(cp));
    what += (what.empty() ? "" : "; ") + describeChangePoint(cp);
  }
  std::string list;
  for (const auto& c : cmds) list += (list.empty() ? "" : "; ") + c;
  result.warnings.push_back(what + ": the log holds " + setUps(cps.size()) +
                            ", which no smooth effect describes" + (cps.size() > 1 ? " (" + transientNote(cps) + ")" : "") +
                            "; analyze each segment (" + list + ") and write no parameters fitted across a change");
}

std::string changePointText(const AnalysisResult& r) {
  if (r.change_points.empty()) return "";
  std::string s;
  for (const auto& cp : r.change_points) {
    s += describeChangePoint(cp) + "\n";
    s += "  (" + std::string(cp.kind == "payload" ? "payload step: mass, centre of mass" : "offsets step") +
         "; held-out error " + fixed(-100.0 * cp.heldout_reduction, 1, true) + " % with the steps; family-wise p = " +
         (cp.family_p < 1e-300 ? std::string("< 1e-300") : fmt(cp.family_p, 2)) + ")\n";
  }
  if (r.change_points.size() > 1) s += "  " + transientNote(r.change_points) + "\n";
  s += "  the log holds " + setUps(r.change_points.size()) + ": analyze each segment, not one model with smooth effects:\n";
  for (const auto& c : segmentCommands(r.change_points, shellQuote(r.log), r.report.model)) s += "    " + c + "\n";
  return s + "\n";
}

std::string changePointHtml(const AnalysisResult& r) {
  if (r.change_points.empty()) return "";
  std::ostringstream o;
  o << "<h2>Change in time</h2>\n<p class=\"warn\">";
  for (const auto& cp : r.change_points) {
    o << "<b>" << escHtml(describeChangePoint(cp)) << "</b> (held-out error "
      << escHtml(fixed(-100.0 * cp.heldout_reduction, 1, true)) << " % with the steps).<br>";
  }
  if (r.change_points.size() > 1) o << escHtml(transientNote(r.change_points)) << ".<br>";
  o << "The log holds " << setUps(r.change_points.size()) << ": analyze each segment:<br>";
  for (const auto& c : segmentCommands(r.change_points, shellQuote(r.log), r.report.model)) o << "<code>" << escHtml(c) << "</code><br>";
  o << "</p>\n";
  return o.str();
}

void addChangePointsJson(const AnalysisResult& r, nlohmann::ordered_json& o) {
  Json list = Json::array();
  for (const auto& cp : r.change_points) {
    Json delta = Json::object();
    for (const auto& d : cp.delta) {
      delta[d.name] = Json{{"value", jsonNumber(d.value)}, {"std", jsonNumber(d.std)}, {"unit", d.unit}};
    }
    list.push_back(Json{{"t", jsonNumber(cp.t)},
                        {"t_std", jsonNumber(cp.t_std)},
                        {"kind", cp.kind},
                        {"delta", std::move(delta)},
                        {"p_value", jsonNumber(cp.p_value)},
                        {"family_p_value", jsonNumber(cp.family_p)},
                        {"heldout_reduction", jsonNumber(cp.heldout_reduction)}});
  }
  Json split = Json::array();
  for (const auto& c : segmentCommands(r.change_points, shellQuote(r.log), r.report.model)) split.push_back(c);
  o["change_points"] = std::move(list);
  if (!r.change_points.empty()) {
    o["segment_commands"] = std::move(split);
    if (r.change_points.size() > 1) o["change_points_undo"] = undoes(r.change_points[0], r.change_points[1]);
  }
  o["change_point_scan_p_value"] = jsonNumber(r.change_point_scan_p);
}

}  // namespace detail

}  // namespace ftid::lab
