// The HTML report of `ftid analyze --report`: one self-contained file, inline SVG drawn here, no
// scripts, no fonts or images from anywhere (opens from disk, offline).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <sstream>
#include <string>
#include <vector>

#include "change_point_scan.hpp"
#include "ftid/identify/noise.hpp"
#include "ftid/lab/analyze.hpp"
#include "lab_internal.hpp"  // saturation (issue 22)

namespace ftid::lab {

namespace {

std::string esc(const std::string& s) {
  std::string o;
  for (char c : s) {
    switch (c) {
      case '<': o += "&lt;"; break;
      case '>': o += "&gt;"; break;
      case '&': o += "&amp;"; break;
      case '"': o += "&quot;"; break;
      default: o += c;
    }
  }
  return o;
}

std::string f(double v, int prec = 4) {
  char b[64];
  std::snprintf(b, sizeof b, "%.*g", prec, v);
  return b;
}

std::string px(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.1f", v);
  return b;
}

/// "Nice" tick values covering [lo, hi].
std::vector<double> ticks(double lo, double hi, int target = 5) {
  std::vector<double> t;
  if (!(hi > lo)) return {lo};
  const double raw = (hi - lo) / target;
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  const double r = raw / mag;
  const double step = (r < 1.5 ? 1.0 : r < 3.0 ? 2.0 : r < 7.0 ? 5.0 : 10.0) * mag;
  for (double v = std::ceil(lo / step) * step; v <= hi + 1e-9 * step; v += step) t.push_back(std::abs(v) < 1e-12 * step ? 0.0 : v);
  return t;
}

struct Series {
  std::vector<double> x, y;
  std::string color;
  std::string label;
  bool dots = false;
};

struct Shade {
  double x0, x1;
};

/// One line/scatter plot as an inline SVG element.
std::string plot(const std::string& title, const std::string& xlabel, const std::string& ylabel,
                 const std::vector<Series>& series, const std::vector<Shade>& shades = {},
                 double width = 540, double height = 200, const std::vector<double>& hlines = {},
                 const std::vector<double>& vlines = {}) {
  const double ml = 62, mr = 12, mt = 24, mb = 36;
  double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
  for (const auto& s : series) {
    for (double v : s.x) { x0 = std::min(x0, v); x1 = std::max(x1, v); }
    for (double v : s.y) { y0 = std::min(y0, v); y1 = std::max(y1, v); }
  }
  for (double h : hlines) { y0 = std::min(y0, h); y1 = std::max(y1, h); }
  if (!(x1 > x0)) { x0 -= 1; x1 += 1; }
  if (!(y1 > y0)) { y0 -= 1; y1 += 1; }
  const double pad = 0.05 * (y1 - y0);
  y0 -= pad;
  y1 += pad;
  const double W = width - ml - mr, H = height - mt - mb;
  auto X = [&](double v) { return ml + (v - x0) / (x1 - x0) * W; };
  auto Y = [&](double v) { return mt + (1.0 - (v - y0) / (y1 - y0)) * H; };
  std::ostringstream o;
  o << "<svg width=\"" << width << "\" height=\"" << height
    << "\" viewBox=\"0 0 " << width << " " << height << "\" class=\"plot\">";
  o << "<rect x=\"0\" y=\"0\" width=\"" << width << "\" height=\"" << height << "\" fill=\"#fff\"/>";
  for (const auto& s : shades) {
    o << "<rect x=\"" << px(X(s.x0)) << "\" y=\"" << px(mt) << "\" width=\"" << px(std::max(1.0, X(s.x1) - X(s.x0)))
      << "\" height=\"" << px(H) << "\" fill=\"#f6c6c6\"/>";
  }
  o << "<rect x=\"" << ml << "\" y=\"" << mt << "\" width=\"" << px(W) << "\" height=\"" << px(H)
    << "\" fill=\"none\" stroke=\"#888\"/>";
  for (double t : ticks(x0, x1)) {
    o << "<line x1=\"" << px(X(t)) << "\" x2=\"" << px(X(t)) << "\" y1=\"" << px(mt + H) << "\" y2=\"" << px(mt + H + 4)
      << "\" stroke=\"#888\"/><text x=\"" << px(X(t)) << "\" y=\"" << px(mt + H + 15)
      << "\" text-anchor=\"middle\" class=\"tk\">" << f(t) << "</text>";
  }
  for (double t : ticks(y0, y1, 4)) {
    o << "<line x1=\"" << px(ml - 4) << "\" x2=\"" << px(ml + W) << "\" y1=\"" << px(Y(t)) << "\" y2=\"" << px(Y(t))
      << "\" stroke=\"#eee\"/><text x=\"" << px(ml - 6) << "\" y=\"" << px(Y(t) + 4)
      << "\" text-anchor=\"end\" class=\"tk\">" << f(t, 3) << "</text>";
  }
  for (double h : hlines) {
    o << "<line x1=\"" << px(ml) << "\" x2=\"" << px(ml + W) << "\" y1=\"" << px(Y(h)) << "\" y2=\"" << px(Y(h))
      << "\" stroke=\"#333\" stroke-dasharray=\"4 3\"/>";
  }
  for (double v : vlines) {  // fold boundaries
    if (v <= x0 || v >= x1) continue;
    o << "<line x1=\"" << px(X(v)) << "\" x2=\"" << px(X(v)) << "\" y1=\"" << px(mt) << "\" y2=\"" << px(mt + H)
      << "\" stroke=\"#7a7a7a\" stroke-dasharray=\"2 3\" class=\"fold\"/>";
  }
  for (const auto& s : series) {
    if (s.dots) {
      for (std::size_t i = 0; i < s.x.size(); ++i) {
        o << "<circle cx=\"" << px(X(s.x[i])) << "\" cy=\"" << px(Y(s.y[i])) << "\" r=\"1.3\" fill=\"" << s.color << "\"/>";
      }
    } else {
      o << "<polyline fill=\"none\" stroke=\"" << s.color << "\" stroke-width=\"1.1\" points=\"";
      for (std::size_t i = 0; i < s.x.size(); ++i) o << px(X(s.x[i])) << "," << px(Y(s.y[i])) << " ";
      o << "\"/>";
    }
  }
  o << "<text x=\"" << ml << "\" y=\"16\" class=\"ti\">" << esc(title) << "</text>";
  double lx = ml + W;
  for (auto it = series.rbegin(); it != series.rend(); ++it) {
    if (it->label.empty()) continue;
    lx -= 8.0 * static_cast<double>(it->label.size()) + 18.0;
    o << "<rect x=\"" << px(lx) << "\" y=\"8\" width=\"10\" height=\"10\" fill=\"" << it->color << "\"/><text x=\""
      << px(lx + 13) << "\" y=\"17\" class=\"tk\">" << esc(it->label) << "</text>";
  }
  o << "<text x=\"" << px(ml + W / 2) << "\" y=\"" << px(height - 4) << "\" text-anchor=\"middle\" class=\"tk\">"
    << esc(xlabel) << "</text>";
  o << "<text x=\"12\" y=\"" << px(mt + H / 2) << "\" transform=\"rotate(-90 12 " << px(mt + H / 2)
    << ")\" text-anchor=\"middle\" class=\"tk\">" << esc(ylabel) << "</text>";
  o << "</svg>";
  return o.str();
}

/// Grouped bars: groups (steps) x 6 axes, values relative to the noise floor.
std::string bars(const std::vector<ExplainStep>& steps, const Vec6& noise) {
  const double width = 1100, height = 260, ml = 50, mr = 10, mt = 28, mb = 60;
  double vmax = 1.2;
  for (const auto& s : steps) {
    for (int a = 0; a < 6; ++a) vmax = std::max(vmax, s.residual_rms(a) / noise(a));
  }
  vmax *= 1.05;
  const double W = width - ml - mr, H = height - mt - mb;
  const double gw = W / static_cast<double>(std::max<std::size_t>(1, steps.size()));
  const double bw = gw * 0.8 / 6.0;
  auto Y = [&](double v) { return mt + (1.0 - v / vmax) * H; };
  const char* colors[6] = {"#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b"};
  std::ostringstream o;
  o << "<svg width=\"" << width << "\" height=\"" << height << "\" class=\"plot\">";
  o << "<rect x=\"0\" y=\"0\" width=\"" << width << "\" height=\"" << height << "\" fill=\"#fff\"/>";
  for (double t : ticks(0.0, vmax, 5)) {
    o << "<line x1=\"" << ml << "\" x2=\"" << px(ml + W) << "\" y1=\"" << px(Y(t)) << "\" y2=\"" << px(Y(t))
      << "\" stroke=\"#eee\"/><text x=\"" << px(ml - 6) << "\" y=\"" << px(Y(t) + 4) << "\" text-anchor=\"end\" class=\"tk\">"
      << f(t, 3) << "</text>";
  }
  for (std::size_t k = 0; k < steps.size(); ++k) {
    for (int a = 0; a < 6; ++a) {
      const double v = steps[k].residual_rms(a) / noise(a);
      const double x = ml + gw * static_cast<double>(k) + gw * 0.1 + bw * a;
      o << "<rect x=\"" << px(x) << "\" y=\"" << px(Y(v)) << "\" width=\"" << px(bw * 0.9) << "\" height=\""
        << px(Y(0) - Y(v)) << "\" fill=\"" << colors[a] << "\"><title>" << kWrenchAxisNames[a] << " " << f(v, 3)
        << " x noise</title></rect>";
    }
    const std::string label = k == 0 ? "start" : "+" + steps[k].added;
    o << "<text x=\"" << px(ml + gw * (static_cast<double>(k) + 0.5)) << "\" y=\"" << px(mt + H + 16)
      << "\" text-anchor=\"middle\" class=\"tk\">" << esc(label) << "</text>";
    o << "<text x=\"" << px(ml + gw * (static_cast<double>(k) + 0.5)) << "\" y=\"" << px(mt + H + 30)
      << "\" text-anchor=\"middle\" class=\"tk\">" << f(steps[k].total_ratio, 3) << " x noise</text>";
  }
  o << "<line x1=\"" << ml << "\" x2=\"" << px(ml + W) << "\" y1=\"" << px(Y(1.0)) << "\" y2=\"" << px(Y(1.0))
    << "\" stroke=\"#000\" stroke-dasharray=\"5 3\"/><text x=\"" << px(ml + W - 4) << "\" y=\"" << px(Y(1.0) - 4)
    << "\" text-anchor=\"end\" class=\"tk\">noise floor</text>";
  for (int a = 0; a < 6; ++a) {
    o << "<rect x=\"" << px(ml + 70.0 * a) << "\" y=\"8\" width=\"10\" height=\"10\" fill=\"" << colors[a]
      << "\"/><text x=\"" << px(ml + 70.0 * a + 14) << "\" y=\"17\" class=\"tk\">" << kWrenchAxisNames[a] << "</text>";
  }
  o << "<text x=\"" << px(ml + 450) << "\" y=\"17\" class=\"tk\">held-out residual RMS / noise floor, per step</text>";
  o << "</svg>";
  return o.str();
}

/// Keeps at most `max_points` points by min/max per bucket (keeps spikes visible).
void decimate(const std::vector<double>& x, const std::vector<double>& y, std::size_t max_points,
              std::vector<double>* ox, std::vector<double>* oy) {
  ox->clear();
  oy->clear();
  if (x.size() <= max_points) {
    *ox = x;
    *oy = y;
    return;
  }
  const std::size_t buckets = max_points / 2;
  for (std::size_t b = 0; b < buckets; ++b) {
    const std::size_t i0 = x.size() * b / buckets, i1 = x.size() * (b + 1) / buckets;
    std::size_t imin = i0, imax = i0;
    for (std::size_t i = i0; i < i1; ++i) {
      if (y[i] < y[imin]) imin = i;
      if (y[i] > y[imax]) imax = i;
    }
    const std::size_t a = std::min(imin, imax), c = std::max(imin, imax);
    ox->push_back(x[a]);
    oy->push_back(y[a]);
    if (c != a) {
      ox->push_back(x[c]);
      oy->push_back(y[c]);
    }
  }
}

std::string axisTable(const AnalysisResult& r) {
  std::ostringstream o;
  o << "<table><tr><th>axis</th><th>raw RMS</th><th>held-out residual RMS</th><th>noise floor</th><th>residual / noise</th></tr>";
  for (int a = 0; a < 6; ++a) {
    const double ratio = r.report.residual_rms(a) / r.noise_floor(a);
    o << "<tr" << (ratio > identify::kAboveFloorMark ? " class=\"bad\"" : "") << "><td>" << kWrenchAxisNames[a] << "</td><td>"
      << f(r.report.raw_rms(a)) << "</td><td>" << f(r.report.residual_rms(a)) << "</td><td>" << f(r.noise_floor(a))
      << "</td><td>" << f(ratio, 3) << "</td></tr>";
  }
  o << "</table>";
  return o.str();
}

/// The title, the data and provenance, the noise floor, glitches, warnings and the residual per axis.
void writeSummary(std::ostringstream& o, const AnalysisResult& r) {
  o << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>ftid analyze: " << esc(r.report.model)
    << "</title>\n<style>body{font-family:sans-serif;margin:20px;color:#222;background:#fafafa}"
       "h1{font-size:22px}h2{font-size:17px;margin-top:28px}table{border-collapse:collapse;margin:8px 0}"
       "td,th{border:1px solid #ccc;padding:3px 8px;font-size:13px;text-align:right}th{background:#eee}"
       "td:first-child{text-align:left}tr.bad td{background:#fde2e2}tr.sig td{background:#e3f4e1}"
       ".plot{margin:4px;border:1px solid #ddd}.tk{font-size:10px;fill:#444}.ti{font-size:12px;font-weight:bold}"
       ".warn{background:#fff4d6;border:1px solid #e0c060;padding:4px 8px}code{background:#eee;padding:1px 4px}.grid{display:flex;flex-wrap:wrap}</style></head><body>\n";
  o << "<h1>ftid analyze &mdash; model <code>" << esc(r.report.model) << "</code></h1>\n";
  o << detail::changePointHtml(r);  // a change in time leads the page (change_point_report.cpp)
  o << "<p>Log <code>" << esc(r.log) << "</code>, " << r.n_samples << " fitting samples, "
    << (r.validate_log.empty() ? std::to_string(r.folds) + "-fold held-out validation over contiguous time blocks"
                               : "validated on <code>" + esc(r.validate_log) + "</code>")
    << ". Every residual shown is held out (predicted by a fit that did not see it).</p>\n";
  {
    // Provenance: what produced this report, from which data.
    char when[40] = "?";
    const std::time_t now = std::time(nullptr);
    std::tm tm_utc{};
    if (gmtime_r(&now, &tm_utc) != nullptr) std::strftime(when, sizeof(when), "%Y-%m-%d %H:%M:%S UTC", &tm_utc);
    o << "<p class=\"provenance\">Provenance: ftid " << FTID_VERSION << ", report generated " << when << "; log <code>"
      << esc(r.log) << "</code>";
    if (!r.validate_log.empty()) o << ", validation log <code>" << esc(r.validate_log) << "</code>";
    o << "; robot <code>" << esc(r.robot_urdf.empty() ? std::string("(not recorded)") : r.robot_urdf)
      << "</code>; starting model <code>" << esc(r.report.model) << "</code>"
      << (r.final_report ? "; final model <code>" + esc(r.final_report->model) + "</code>" : std::string())
      << ".</p>\n";
  }
  o << "<p>Noise floor: <b>" << esc(r.noise_method) << "</b> &mdash; " << esc(r.noise_detail) << ".</p>\n";
  if (r.outliers.count > 0) {
    o << "<p>Glitches: " << r.outliers.count << " isolated samples left out of every fit, at t =";
    for (std::size_t k = 0; k < r.outliers.times.size() && k < 40; ++k) o << (k ? ", " : " ") << f(r.outliers.times[k], 4);
    o << (r.outliers.times.size() > 40 ? ", &hellip;" : "") << " s.</p>\n";
  }
  o << detail::saturationHtml(r);  // saturation (issue 22)
  for (const auto& w : r.warnings) o << "<p class=\"warn\"><b>Warning:</b> " << esc(w) << "</p>\n";
  o << "<h2>Residual per axis</h2>" << axisTable(r);
}

/// Measured against the held-out prediction and the held-out residual over time per axis (worst
/// windows shaded, k-fold block boundaries dotted), and the table of the worst windows.
void writeTimePlots(std::ostringstream& o, const AnalysisResult& r) {
  const std::size_t n = r.t.size();
  // k-fold: the boundaries between the contiguous held-out blocks (dotted lines in the plots).
  const std::vector<double>& folds = r.fold_start_t;
  std::vector<Shade> shades;
  for (const auto& w : r.windows) shades.push_back({w.t_start, w.t_end});
  o << "<h2>Measured vs model (held-out prediction)</h2><div class=\"grid\">";
  std::vector<double> xs, ys;
  for (int a = 0; a < 6; ++a) {
    std::vector<double> m(n), p(n);
    for (std::size_t i = 0; i < n; ++i) {
      m[i] = r.measured(a, static_cast<Eigen::Index>(i));
      p[i] = r.predicted(a, static_cast<Eigen::Index>(i));
    }
    Series sm{{}, {}, "#999999", "measured", false}, sp{{}, {}, "#1f77b4", "model", false};
    decimate(r.t, m, 1200, &sm.x, &sm.y);
    decimate(r.t, p, 1200, &sp.x, &sp.y);
    o << plot(kWrenchAxisNames[a], "t [s]", a < 3 ? "N" : "Nm", {sm, sp}, {}, 540, 200, {}, folds);
  }
  o << "</div>\n<h2>Held-out residual over time (worst windows shaded; k-fold block boundaries dotted)</h2><div class=\"grid\">";
  for (int a = 0; a < 6; ++a) {
    std::vector<double> res(n);
    for (std::size_t i = 0; i < n; ++i) {
      res[i] = r.measured(a, static_cast<Eigen::Index>(i)) - r.predicted(a, static_cast<Eigen::Index>(i));
    }
    Series s{{}, {}, "#d62728", "", false};
    decimate(r.t, res, 1200, &s.x, &s.y);
    o << plot(std::string("residual ") + kWrenchAxisNames[a] + " (noise floor +-" + f(r.noise_floor(a), 3) + ")",
              "t [s]", a < 3 ? "N" : "Nm", {s}, shades, 540, 200, {r.noise_floor(a), -r.noise_floor(a)}, folds);
  }
  o << "</div>\n";
  if (!r.windows.empty()) {
    o << "<table><tr><th>window</th><th>t start [s]</th><th>t end [s]</th><th>residual / noise</th><th>worst axis</th></tr>";
    for (std::size_t k = 0; k < r.windows.size(); ++k) {
      const auto& w = r.windows[k];
      o << "<tr><td>" << k + 1 << "</td><td>" << f(w.t_start) << "</td><td>" << f(w.t_end) << "</td><td>"
        << f(w.ratio, 3) << "</td><td>" << kWrenchAxisNames[w.worst_axis] << "</td></tr>";
    }
    o << "</table>\n";
  }
}

/// The residual against the signal it is most related to, and the table of correlations.
void writeCorrelations(std::ostringstream& o, const AnalysisResult& r) {
  const std::size_t n = r.t.size();
  if (!r.correlations.empty() && r.top_signal.size() == n) {
    const auto& c = r.correlations.front();
    o << "<h2>Residual against the most related signal</h2>";
    Series s{{}, {}, "#9467bd", "", true};
    const std::size_t step = std::max<std::size_t>(1, n / 1500);
    for (std::size_t i = 0; i < n; i += step) {
      s.x.push_back(r.top_signal[i]);
      s.y.push_back(r.measured(c.axis, static_cast<Eigen::Index>(i)) - r.predicted(c.axis, static_cast<Eigen::Index>(i)));
    }
    o << plot(std::string("residual ") + kWrenchAxisNames[c.axis] + " vs " + c.signal + " (r = " + f(c.r, 3) + ")",
              c.signal, std::string("residual ") + kWrenchAxisNames[c.axis], {s}, {}, 700, 320);
    o << "<table><tr><th>residual axis</th><th>signal</th><th>r</th></tr>";
    for (const auto& cc : r.correlations) {
      o << "<tr><td>" << kWrenchAxisNames[cc.axis] << "</td><td>" << esc(cc.signal) << "</td><td>" << f(cc.r, 3)
        << (cc.significant ? "" : " (chance)") << "</td></tr>";
    }
    o << "</table>\n";
  }
}

/// Each candidate effect with its verdict under the one rule, and the missing effect if any.
void writeCandidates(std::ostringstream& o, const AnalysisResult& r) {
  o << "<h2>Candidate effects</h2><p>One rule decides (docs/analyze.md): the family-wise p-value min(1, "
    << r.family_size << " p) of the held-out gain below alpha = " << f(r.family_alpha, 2)
    << " (p: the chance of so large a gain from noise alone), identifiable and physical.</p>"
       "<table><tr><th>effect</th><th>held-out reduction</th><th>family-wise p</th>"
       "<th>verdict</th><th>meaning</th><th>next command</th></tr>";
  for (const auto& c : r.candidates) {
    if (c.skipped) continue;
    std::string verdict = verdictWord(c.verdict);
    if (!c.reason.empty()) verdict += ": " + c.reason;
    if (!c.separating_motion.empty()) verdict += "; to separate: " + c.separating_motion;
    o << "<tr" << (c.significant ? " class=\"sig\"" : "") << "><td>" << esc(c.effect) << "</td><td>"
      << f(100.0 * c.relative_reduction, 3) << " %</td><td>"
      << (c.family_p < 1e-300 ? std::string("&lt; 1e-300") : f(c.family_p, 2)) << "</td><td>" << esc(verdict)
      << "</td><td>" << esc(c.description) << "</td><td><code>"
      << esc(c.next_command) << "</code></td></tr>";
  }
  o << "</table>";
  for (const auto& u : r.unphysical) o << "<p><b>Not physically possible:</b> " << esc(u) << "</p>";
  if (!r.unwritable.empty()) {
    o << "<p><b>ftid identify would write no parameters:</b> " << esc(r.unwritable);
    if (!r.writable_alternative.empty()) o << " It can write " << esc(r.writable_alternative) << ".";
    o << "</p>";
  }
  const bool any = !r.candidates.empty() && r.candidates.front().significant;
  o << "<p><b>" << (any ? "Missing effect: " + esc(r.candidates.front().effect) + " &mdash; " + esc(r.candidates.front().description)
                        : std::string("Nothing is missing: no candidate is recommended."))
    << "</b></p>\n";
}

/// --explain's path: the error at each step, and why each remaining candidate was not taken.
void writeExplainSteps(std::ostringstream& o, const AnalysisResult& r) {
  if (!r.steps.empty()) {
    o << "<h2>Explain: the error falling step by step</h2>" << bars(r.steps, r.noise_floor);
    o << "<table><tr><th>step</th><th>model</th>";
    for (int a = 0; a < 6; ++a) o << "<th>" << kWrenchAxisNames[a] << "</th>";
    o << "<th>x noise</th></tr>";
    for (std::size_t k = 0; k < r.steps.size(); ++k) {
      const auto& st = r.steps[k];
      const std::string change = !st.added.empty() ? "+" + st.added : (!st.removed.empty() ? "-" + st.removed : "");
      o << "<tr><td>" << k << "</td><td>" << esc(st.model) << (change.empty() ? "" : " (" + esc(change) + ")") << "</td>";
      for (int a = 0; a < 6; ++a) o << "<td>" << f(r.steps[k].residual_rms(a)) << "</td>";
      o << "<td>" << f(r.steps[k].total_ratio, 3) << "</td></tr>";
    }
    o << "</table>\n";
    for (const auto& c : r.kept_unsupported) {
      o << "<p>" << esc(c.effect) << " is kept though the rule does not support it (" << verdictWord(c.verdict)
        << (c.reason.empty() ? "" : ": " + esc(c.reason)) << "): removing it would raise the held-out error.</p>";
    }
    o << "<p>Against <code>" << esc(r.steps.back().model) << "</code>, why each remaining candidate was not taken:</p>"
         "<table><tr><th>effect</th><th>verdict</th><th>family-wise p</th><th>why</th></tr>";
    for (const auto& c : r.final_candidates) {
      o << "<tr><td>" << esc(c.effect) << "</td><td>" << verdictWord(c.verdict) << "</td><td>"
        << (c.family_p < 1e-300 ? std::string("&lt; 1e-300") : f(c.family_p, 2)) << "</td><td>"
        << esc(c.skipped ? c.note : c.reason) << "</td></tr>";
    }
    o << "</table>\n";
  }
}

/// The held-out residual of the starting and of the final model, in a table and per axis.
void writeBeforeAfter(std::ostringstream& o, const AnalysisResult& r) {
  const std::size_t n = r.t.size();
  if (r.final_report && r.final_residual.cols() == static_cast<Eigen::Index>(n) && n > 0) {
    // Before / after: the same held-out samples, residual of the starting and of the final model.
    o << "<h2>Before and after: held-out residual of the starting model <code>" << esc(r.report.model)
      << "</code> and the final model <code>" << esc(r.final_report->model) << "</code></h2>";
    o << "<table class=\"before-after\"><tr><th>axis</th><th>starting model RMS</th><th>final model RMS</th>"
         "<th>noise floor</th><th>change</th></tr>";
    for (int a = 0; a < 6; ++a) {
      const double before = r.report.residual_rms(a), after = r.final_report->residual_rms(a);
      o << "<tr><td>" << kWrenchAxisNames[a] << "</td><td>" << f(before) << "</td><td>" << f(after) << "</td><td>"
        << f(r.noise_floor(a)) << "</td><td>" << (before > 0.0 ? f(100.0 * (after - before) / before, 3) + " %" : "-")
        << "</td></tr>";
    }
    o << "</table><div class=\"grid\">";
    for (int a = 0; a < 6; ++a) {
      std::vector<double> before(n), after(n);
      for (std::size_t i = 0; i < n; ++i) {
        const auto k = static_cast<Eigen::Index>(i);
        before[i] = r.measured(a, k) - r.predicted(a, k);
        after[i] = r.final_residual(a, k);
      }
      Series sb{{}, {}, "#d62728", "start", false}, sa{{}, {}, "#1f77b4", "final", false};
      decimate(r.t, before, 1200, &sb.x, &sb.y);
      decimate(r.t, after, 1200, &sa.x, &sa.y);
      o << plot(std::string("residual ") + kWrenchAxisNames[a] + ": start RMS " + f(r.report.residual_rms(a), 3) +
                    ", final RMS " + f(r.final_report->residual_rms(a), 3),
                "t [s]", a < 3 ? "N" : "Nm", {sb, sa}, {}, 540, 200, {r.noise_floor(a), -r.noise_floor(a)});
    }
    o << "</div>\n";
  }
}

/// Issue 22 (sensor and mount dynamics): the residual's spectrum per axis against the noise model
/// (log10 PSD; the motion band shaded, a significant peak dotted), the rule and one line per axis,
/// and the autocorrelation against the noise model's.
void writeSpectrum(std::ostringstream& o, const AnalysisResult& r) {
  const ResidualSpectrum& s = r.spectrum;
  o << "<h2>Spectrum of the held-out residual</h2><p>" << esc(spectrumRule(s)) << ".</p>";
  if (!s.valid) return;
  o << "<ul class=\"spectrum\">";
  for (int a = 0; a < 6; ++a) o << "<li>" << esc(spectrumLine(s, a)) << "</li>";
  o << "</ul>";
  if (r.dynamics.tested || !r.dynamics.note.empty()) o << "<p><b>" << esc(dynamicsLine(r.dynamics, r.noise_floor)) << "</b></p>";
  if (!delayAgainstLagLine(r.dynamics).empty()) o << "<p>" << esc(delayAgainstLagLine(r.dynamics)) << "</p>";
  o << "<div class=\"grid\">";
  auto lg = [](double v) { return std::log10(std::max(v, 1e-300)); };
  for (int a = 0; a < 6; ++a) {
    const AxisSpectrum& ax = s.axes[static_cast<std::size_t>(a)];
    Series sr{{}, {}, "#1f77b4", "residual", false}, sn{{}, {}, "#000000", "noise model", false};
    for (std::size_t k = 1; k < s.f_hz.size(); ++k) {
      sr.x.push_back(lg(s.f_hz[k]));
      sr.y.push_back(lg(ax.psd[k]));
      sn.x.push_back(lg(s.f_hz[k]));
      sn.y.push_back(lg(ax.noise_psd[k]));
    }
    std::vector<double> peak;  // significant peaks dotted
    if (ax.peak.significant) peak.push_back(lg(ax.peak.f_hz));
    if (ax.beyond.significant && ax.beyond.f_hz != ax.peak.f_hz) peak.push_back(lg(ax.beyond.f_hz));
    o << plot(std::string(kWrenchAxisNames[a]) + " residual PSD (motion band shaded)", "log10 f [Hz]",
              std::string("log10 PSD [") + (a < 3 ? "N" : "Nm") + "^2/Hz]", {sr, sn},
              {{lg(s.f_hz[1]), lg(std::max(s.motion_band_hz, s.f_hz[1]))}}, 540,
              200, {}, peak);
  }
  o << "</div><h2>Autocorrelation of the held-out residual</h2><div class=\"grid\">";
  for (int a = 0; a < 6; ++a) {
    const AxisSpectrum& ax = s.axes[static_cast<std::size_t>(a)];
    Series sr{{}, {}, "#1f77b4", "residual", false}, sn{{}, {}, "#000000", "noise model", false};
    for (std::size_t k = 0; k < ax.acf.size(); ++k) {
      sr.x.push_back(static_cast<double>(k) * s.dt_s);
      sr.y.push_back(ax.acf[k]);
      sn.x.push_back(static_cast<double>(k) * s.dt_s);
      sn.y.push_back(ax.noise_acf[k]);
    }
    o << plot(std::string(kWrenchAxisNames[a]) + " residual autocorrelation", "lag [s]", "r", {sr, sn}, {}, 360, 180,
              {0.0});
  }
  o << "</div>\n";
}

/// The parameters of the final (or the only) model, and the footer.
void writeParameters(std::ostringstream& o, const AnalysisResult& r) {
  const ModelReport& fr = r.final_report ? *r.final_report : r.report;
  o << "<h2>Parameters of <code>" << esc(fr.model) << "</code></h2><table><tr><th>name</th><th>value</th><th>std</th><th>unit</th></tr>";
  for (const auto& p : fr.params) {
    o << "<tr><td>" << esc(p.name) << "</td><td>" << f(p.value, 6) << "</td><td>" << f(p.std, 3) << "</td><td>"
      << esc(p.unit) << "</td></tr>";
  }
  o << "</table>";
  if (fr.inertia) o << "<p>Inertia about the centre of mass: " << esc(fr.inertia->explanation) << "</p>";
  o << "<p style=\"font-size:11px;color:#777\">Analysis took " << f(r.seconds, 3)
    << " s. Conventions: docs/conventions.md; method: docs/analyze.md.</p>\n</body></html>\n";
}

}  // namespace

std::string renderHtml(const AnalysisResult& r) {
  std::ostringstream o;
  writeSummary(o, r);
  writeSpectrum(o, r);  // issue 22: sensor and mount dynamics
  writeTimePlots(o, r);
  writeCorrelations(o, r);
  writeCandidates(o, r);
  writeExplainSteps(o, r);
  writeBeforeAfter(o, r);
  writeParameters(o, r);
  return o.str();
}

}  // namespace ftid::lab
