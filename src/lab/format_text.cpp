// Human-readable output of `ftid analyze` (analyze.hpp).
#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <sstream>
#include <string>

#include "change_point_scan.hpp"
#include "ftid/identify/noise.hpp"
#include "ftid/identify/imu.hpp"
#include "ftid/lab/analyze.hpp"
#include "lab_internal.hpp"  // saturation (issue 22)
#include "spectrum_report.hpp"

namespace ftid::lab {

namespace {

std::string line(const char* format, ...) __attribute__((format(printf, 1, 2)));
std::string line(const char* format, ...) {
  char buf[512];
  va_list args;
  va_start(args, format);
  std::vsnprintf(buf, sizeof buf, format, args);
  va_end(args);
  return std::string(buf) + "\n";
}

const char* unitOf(int axis) { return axis < 3 ? "N" : "Nm"; }

std::string axisTable(const Vec6& raw, const Vec6& res, const Vec6& noise) {
  std::string s = line("  %-5s %12s %16s %12s %9s", "axis", "raw RMS", "held-out resid.", "noise floor", "x noise");
  for (int a = 0; a < 6; ++a) {
    const double ratio = noise(a) > 0.0 ? res(a) / noise(a) : 0.0;
    s += line("  %-5s %9.4f %-2s %13.4f %-2s %9.4f %-2s %8.2f%s", kWrenchAxisNames[a], raw(a), unitOf(a), res(a),
              unitOf(a), noise(a), unitOf(a), ratio, ratio > identify::kAboveFloorMark ? "  <- model fails here" : "");
  }
  return s;
}

std::string paramBlock(const ModelReport& r) {
  std::string s = line("parameters of %s (value +- standard error, fitted on all data):", r.model.c_str());
  for (const auto& p : r.params) {
    s += line("  %-16s %14.6g +- %-11.3g %s", p.name.c_str(), p.value, p.std, p.unit.c_str());
  }
  if (r.inertia) s += "  inertia about the centre of mass: " + r.inertia->explanation + "\n";
  return s;
}

/// A p-value as text: below the smallest double's range it underflows to 0 (say how small instead).
std::string pText(double p) {
  char b[32];
  if (p < 1e-300) {
    std::snprintf(b, sizeof(b), "< 1e-300");
  } else {
    std::snprintf(b, sizeof(b), "%.2g", p);
  }
  return b;
}

/// One line per candidate: its verdict and why, in words.
std::string whyNot(const std::vector<CandidateResult>& ranking) {
  std::string s;
  for (const auto& c : ranking) {
    const std::string why = c.skipped ? c.note : c.reason;
    s += "  " + c.effect + ": " + verdictWord(c.verdict) + (why.empty() ? "" : " - " + why) + "\n";
  }
  return s;
}

/// The summary: the model and its validation, led by any change in time, then how the noise floor
/// was found, the glitches left out and any saturation.
std::string summaryText(const AnalysisResult& r) {
  std::string s;
  s += line("model %s: %d fitting samples, %s", r.report.model.c_str(), r.n_samples,
            r.validate_log.empty() ? (std::to_string(r.folds) + "-fold held-out validation (contiguous time blocks)").c_str()
                                   : ("validated on " + r.validate_log).c_str());
  s = detail::changePointText(r) + s;  // a change in time leads the summary (change_point_report.cpp)
  s += line("noise floor (%s): %s", r.noise_method.c_str(), r.noise_detail.c_str());
  if (r.outliers.count > 0) {
    std::string times;
    for (std::size_t k = 0; k < r.outliers.times.size() && k < 12; ++k) {
      char b[48];
      std::snprintf(b, sizeof b, "%s%.3f", k ? ", " : "", r.outliers.times[k]);
      times += b;
    }
    if (r.outliers.times.size() > 12) times += ", ...";
    s += line("glitches: %d isolated samples left out of every fit, at t = %s s", r.outliers.count, times.c_str());
  }
  s += detail::saturationText(r);  // saturation (issue 22)
  return s;
}

/// The held-out residual per axis against the noise floor, its spectrum and the reading's dynamics.
std::string residualText(const AnalysisResult& r) {
  std::string s = "\n" + axisTable(r.report.raw_rms, r.report.residual_rms, r.noise_floor);
  s += line("  (all residuals are held out: each block predicted by a fit that did not see it)");
  s += detail::spectrumText(r.spectrum);  // issue 22: sensor and mount dynamics
  if (r.dynamics.tested || !r.dynamics.note.empty()) s += dynamicsLine(r.dynamics, r.noise_floor) + "\n";
  if (!delayAgainstLagLine(r.dynamics).empty()) s += "  " + delayAgainstLagLine(r.dynamics) + "\n";
  return s;
}

/// The sensor's IMU against the kinematics (and the last model), or why it was not checked
/// (issue 23); empty when there is neither.
std::string imuText(const AnalysisResult& r) {
  if (!r.imu.used && r.imu.not_used_reason.empty()) return {};
  std::string s = "\nthe sensor's IMU against the kinematics" +
                  std::string(r.imu.used ? " and " + (r.final_report ? r.final_report->model : r.report.model) : "") +
                  ":\n";
  if (!r.imu.used) s += "  not checked: " + r.imu.not_used_reason + "\n";
  if (r.imu.used) s += identify::formatImuEstimate(r.imu.estimate);
  for (const auto& c : r.imu.comparisons) s += std::string(c.disagrees ? "  DISAGREE " : "  agree    ") + c.message + "\n";
  if (!r.imu.tilt_not_compared.empty()) s += "  " + r.imu.tilt_not_compared + "\n";
  return s;
}

/// Where the model fails: the worst time windows, the signals the residual moves with and the
/// extra log columns taken as signals.
std::string whereItFailsText(const AnalysisResult& r) {
  std::string s;
  if (!r.windows.empty()) {
    s += "\nwhere it fails (time windows with the largest held-out residual, x noise floor):\n";
    for (const auto& w : r.windows) {
      s += line("  t = %7.2f .. %7.2f s   %6.2f x noise   worst axis %s", w.t_start, w.t_end, w.ratio,
                kWrenchAxisNames[w.worst_axis]);
    }
  }
  if (!r.correlations.empty()) {
    s += "\nthe residual moves with (Pearson r of the held-out residual with measured signals):\n";
    for (const auto& c : r.correlations) {
      s += line("  %-4s ~ %-22s r = %+6.3f%s", kWrenchAxisNames[c.axis], c.signal.c_str(), c.r,
                c.significant ? "" : "   (not above chance)");
    }
  }
  if (!r.extra_signals.empty()) {  // extra log columns as candidate signals (docs/analyze.md)
    std::string cols;
    for (const auto& c : r.extra_signals) cols += (cols.empty() ? "" : ", ") + c;
    s += "extra log columns taken as signals (correlations; candidates payload(C), poly(C,1)): " + cols + "\n";
  }
  return s;
}

/// The candidate effects under the one rule: the table of those tried, then the skipped ones and
/// the refused (confounded) ones.
std::string candidateTable(const AnalysisResult& r) {
  std::string s;
  const int family = r.family_size;
  std::ostringstream margin;
  margin << 100.0 * r.heldout_margin;
  const std::string falls = r.heldout_margin > 0.0 ? " (and the held-out error falls by more than " + margin.str() + " %)"
                                                   : std::string();
  s += line("\ncandidate effects (one rule, docs/analyze.md: recommended when the family-wise p = min(1, %d p) of its "
            "held-out gain is below alpha = %.2g%s, and the fit is identifiable and physical; p = the chance of so "
            "large a gain from noise alone):",
            family, r.family_alpha, falls.c_str());
  s += line("  %-20s %9s  %-14s %s", "effect", "held-out", "family-wise p", "verdict");
  for (const auto& c : r.candidates) {
    if (c.skipped) continue;
    s += line("  %-20s %7.1f %%  %-14s %-16s %s", c.effect.c_str(), 100.0 * c.relative_reduction,
              pText(c.family_p).c_str(), verdictWord(c.verdict), c.description.c_str());
  }
  for (const auto& c : r.candidates) {
    if (c.skipped) s += line("  %-20s skipped: %s", c.effect.c_str(), c.note.c_str());
  }
  for (const auto& c : r.candidates) {
    if (!c.confounded) continue;
    s += "  " + c.effect + " is NOT recommended (refused): " + c.confound + ".\n";
    if (!c.separating_motion.empty()) s += "    what would resolve it: " + c.separating_motion + ".\n";
  }
  return s;
}

/// The ranking's conclusion: a change in time, the missing effect (the best candidate when it is
/// in the table and recommended) with the next command, or why nothing is missing.
std::string missingEffectText(const AnalysisResult& r) {
  const bool shown = std::any_of(r.candidates.begin(), r.candidates.end(),
                                 [](const CandidateResult& c) { return !c.skipped; });
  std::string s;
  if (!r.change_points.empty()) {
    s += "\nmissing effect: a change in time (see the top); the candidates above would only imitate the step\n";
  } else if (shown && r.candidates.front().significant) {
    const auto& best = r.candidates.front();
    s += "\nmissing effect: " + best.effect + " - " + best.description + "\n";
    s += "next: " + best.next_command + "\n";
  } else {
    s += "\nnothing is missing: no candidate is recommended. Why each was not taken:\n" + whyNot(r.candidates);
  }
  return s;
}

/// --explain's path: the held-out residual per axis at each step, the noise floor, and where and
/// why the path ends; empty without steps.
std::string explainText(const AnalysisResult& r) {
  if (r.steps.empty()) return {};
  std::string s;
  s += "\nexplain (forward selection with backward elimination under the rule; held-out residual RMS per axis):\n";
  s += line("  %-4s %-22s %-40s %8s %8s %8s %8s %8s %8s %9s", "step", "change", "model", "fx", "fy", "fz", "tx", "ty",
            "tz", "x noise");
  for (std::size_t k = 0; k < r.steps.size(); ++k) {
    const auto& st = r.steps[k];
    const std::string change = !st.added.empty() ? "+" + st.added : (!st.removed.empty() ? "-" + st.removed : "start");
    s += line("  %-4zu %-22s %-40s %8.4f %8.4f %8.4f %8.4f %8.4f %8.4f %9.2f", k, change.c_str(), st.model.c_str(),
              st.residual_rms(0), st.residual_rms(1), st.residual_rms(2), st.residual_rms(3), st.residual_rms(4),
              st.residual_rms(5), st.total_ratio);
  }
  s += line("  noise floor                                                          %8.4f %8.4f %8.4f %8.4f %8.4f %8.4f",
            r.noise_floor(0), r.noise_floor(1), r.noise_floor(2), r.noise_floor(3), r.noise_floor(4), r.noise_floor(5));
  const bool more = std::any_of(r.final_candidates.begin(), r.final_candidates.end(),
                                [](const CandidateResult& c) { return c.significant; });
  std::string kept;
  for (const auto& c : r.kept_unsupported) {
    kept += std::string(kept.empty() ? "" : "; ") + c.effect + " (" + verdictWord(c.verdict) +
            (c.reason.empty() ? "" : ": " + c.reason) + ")";
  }
  const std::string support =
      kept.empty() ? "the rule supports each of its effects"
                   : "the rule supports each of its effects except " + kept +
                         ", kept because removing it would raise the held-out error (no step of the path raises it)";
  s += more ? "  the path stops at " + r.steps.back().model + " at the step limit; the verdicts against it:\n"
            : "  the path ends at " + r.steps.back().model + ": no candidate is recommended against it (or its full " +
                  "fit is not) and " + support + ". Why each remaining candidate was not taken:\n";
  s += whyNot(r.final_candidates);
  return s;
}

/// What to do with the result: for the path's last model the commands that write its parameters
/// (or why identify would not, and what it can write); for an impossible model, what is wrong.
std::string closingText(const AnalysisResult& r) {
  std::string s;
  if (!r.steps.empty() && r.unphysical.empty() && !r.unwritable.empty()) {
    // Possible, but identify would refuse to write it: say so, and what it can write.
    const std::string& m = r.steps.back().model;
    s += "\nftid identify writes no parameter file for " + m + ": " + r.unwritable + "\n";
    s += "  for one, record a richer motion (ftid design: more orientations, more wrist rotation) and identify on it";
    if (!r.writable_alternative.empty()) {
      s += ",\n  or leave the inertia terms out of the compensation:\n  ftid identify --log " + shellQuote(r.log) +
           " --model " + shellQuote(r.writable_alternative) + " --out params.yaml";
    }
    s += "\n";
  } else if (!r.steps.empty() && r.unphysical.empty()) {
    // --explain closes with the commands that turn the final model into parameters and exports.
    s += "\nidentify the final model, write its parameters and the UR / ros2_control exports:\n";
    s += "  ftid identify --log " + shellQuote(r.log) + " --model " + shellQuote(r.steps.back().model) +
         " --out params.yaml\n";
    s += "  (writes params.yaml.ros2.yaml and params.yaml.urscript; or: ftid export --params params.yaml)\n";
  } else if (!r.unphysical.empty()) {
    // Impossible answers are never exported: say what is wrong instead.
    const std::string& m = r.final_report ? r.final_report->model : r.report.model;
    s += "\n" + m + " is not physically possible, so there are no parameters to write from it:\n";
    for (const auto& u : r.unphysical) s += "  - " + u + "\n";
    s += "  (record a richer excitation, check the set-up, or run --explain to find the missing effect)\n";
  }
  return s;
}

}  // namespace

std::string formatText(const AnalysisResult& r) {
  std::string s = summaryText(r);
  s += residualText(r);
  s += imuText(r);
  s += whereItFailsText(r);
  s += candidateTable(r);
  s += missingEffectText(r);
  s += explainText(r);
  s += "\n" + paramBlock(r.final_report ? *r.final_report : r.report);
  for (const auto& w : r.warnings) s += "warning: " + w + "\n";
  s += closingText(r);
  return s;
}

}  // namespace ftid::lab
