// JSON output of `ftid analyze` (analyze.hpp): one object, keys documented in docs/analyze.md.
#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>

#include "ftid/lab/analyze.hpp"

namespace ftid::lab {

namespace {

std::string num(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return buf;
}

std::string str(const std::string& s) {
  std::string o = "\"";
  for (char c : s) {
    switch (c) {
      case '"': o += "\\\""; break;
      case '\\': o += "\\\\"; break;
      case '\n': o += "\\n"; break;
      case '\t': o += "\\t"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char b[8];
          std::snprintf(b, sizeof b, "\\u%04x", c);
          o += b;
        } else {
          o += c;
        }
    }
  }
  return o + "\"";
}

std::string axes(const Vec6& v) {
  std::string o = "{";
  for (int a = 0; a < 6; ++a) o += std::string(a ? ", " : "") + "\"" + kWrenchAxisNames[a] + "\": " + num(v(a));
  return o + "}";
}

std::string params(const ModelReport& r) {
  std::string o = "{";
  for (std::size_t k = 0; k < r.params.size(); ++k) {
    const auto& p = r.params[k];
    o += std::string(k ? ", " : "") + str(p.name) + ": {\"value\": " + num(p.value) + ", \"std\": " + num(p.std) +
         ", \"unit\": " + str(p.unit) + "}";
  }
  return o + "}";
}

std::string report(const ModelReport& r) {
  std::string o = "{\"model\": " + str(r.model) + ", \"residual_rms\": " + axes(r.residual_rms) +
                  ", \"fit_residual_rms\": " + axes(r.fit_residual_rms) +
                  ", \"condition_number\": " + num(r.condition_number) + ", \"parameters\": " + params(r);
  if (r.inertia) {
    o += ", \"inertia_com\": {\"value\": [";
    for (int k = 0; k < 6; ++k) o += (k ? ", " : "") + num(r.inertia->value(k));
    o += "], \"std\": [";
    for (int k = 0; k < 6; ++k) o += (k ? ", " : "") + num(r.inertia->std(k));
    o += "], \"positive_definite\": " + std::string(r.inertia->positive_definite ? "true" : "false") +
         ", \"triangle_inequalities\": " + (r.inertia->triangle_inequalities ? "true" : "false") +
         ", \"explanation\": " + str(r.inertia->explanation) + "}";
  }
  return o + "}";
}

}  // namespace

std::string formatJson(const AnalysisResult& r) {
  std::ostringstream o;
  o << "{\"model\": " << str(r.report.model) << ",\n";
  o << " \"log\": " << str(r.log) << ", \"validate_log\": " << str(r.validate_log) << ",\n";
  o << " \"samples\": " << r.n_samples << ", \"heldout_samples\": " << r.n_eval << ", \"folds\": " << r.folds << ",\n";
  o << " \"residual_rms\": " << axes(r.report.residual_rms) << ",\n";
  o << " \"noise_floor\": " << axes(r.noise_floor) << ",\n";
  o << " \"noise_method\": " << str(r.noise_method) << ", \"noise_detail\": " << str(r.noise_detail)
    << ", \"noise_ar1\": " << axes(r.noise_ar1) << ",\n";
  o << " \"outliers\": {\"count\": " << r.outliers.count << ", \"times\": [";
  for (std::size_t k = 0; k < r.outliers.times.size(); ++k) o << (k ? ", " : "") << num(r.outliers.times[k]);
  o << "]},\n \"warnings\": [";
  for (std::size_t k = 0; k < r.warnings.size(); ++k) o << (k ? ", " : "") << str(r.warnings[k]);
  o << "],\n";
  o << " \"raw_rms\": " << axes(r.report.raw_rms) << ",\n";
  o << " \"fit\": " << report(r.report) << ",\n";
  o << " \"windows\": [";
  for (std::size_t k = 0; k < r.windows.size(); ++k) {
    const auto& w = r.windows[k];
    o << (k ? ", " : "") << "{\"t_start\": " << num(w.t_start) << ", \"t_end\": " << num(w.t_end)
      << ", \"ratio\": " << num(w.ratio) << ", \"worst_axis\": " << str(kWrenchAxisNames[w.worst_axis]) << "}";
  }
  o << "],\n \"correlations\": [";
  for (std::size_t k = 0; k < r.correlations.size(); ++k) {
    const auto& c = r.correlations[k];
    o << (k ? ", " : "") << "{\"signal\": " << str(c.signal) << ", \"axis\": " << str(kWrenchAxisNames[c.axis])
      << ", \"r\": " << num(c.r) << ", \"significant\": " << (c.significant ? "true" : "false") << "}";
  }
  o << "],\n \"candidates\": [";
  bool first = true;
  for (const auto& c : r.candidates) {
    o << (first ? "\n  " : ",\n  ");
    first = false;
    o << "{\"effect\": " << str(c.effect) << ", \"relative_reduction\": " << num(c.relative_reduction)
      << ", \"significant\": " << (c.significant ? "true" : "false") << ", \"p_value\": " << num(c.p_value)
      << ", \"f_statistic\": " << num(c.f_statistic) << ", \"added_params\": " << c.added_params
      << ", \"delta_bic\": " << num(c.delta_bic) << ", \"residual_rms\": " << axes(c.residual_rms)
      << ", \"description\": " << str(c.description) << ", \"next_command\": " << str(c.next_command)
      << ", \"skipped\": " << (c.skipped ? "true" : "false") << ", \"note\": " << str(c.note)
      << ", \"confounded\": " << (c.confounded ? "true" : "false") << ", \"confound\": " << str(c.confound)
      << ", \"separating_motion\": " << str(c.separating_motion) << "}";
  }
  o << "]";
  if (!r.steps.empty()) {
    o << ",\n \"steps\": [";
    for (std::size_t k = 0; k < r.steps.size(); ++k) {
      const auto& s = r.steps[k];
      o << (k ? ",\n  " : "\n  ") << "{\"model\": " << str(s.model) << ", \"added\": " << str(s.added)
        << ", \"residual_rms\": " << axes(s.residual_rms) << ", \"ratio_to_noise\": " << num(s.total_ratio)
        << ", \"p_value\": " << num(s.p_value) << "}";
    }
    o << "]";
  }
  if (r.final_report) o << ",\n \"final\": " << report(*r.final_report);
  o << ",\n \"seconds\": " << num(r.seconds) << "}\n";
  return o.str();
}

}  // namespace ftid::lab
