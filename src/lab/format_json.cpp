// JSON output of `ftid analyze` (analyze.hpp): one object, keys documented in docs/analyze.md.
// Built with nlohmann-json under the output policy of ftid/fileio/json_text.hpp (round-trip
// numbers, null for non-finite ones).
#include <string>

#include "ftid/fileio/json_text.hpp"
#include "ftid/identify/offline.hpp"
#include "change_point_scan.hpp"
#include "ftid/lab/analyze.hpp"
#include "spectrum_report.hpp"

namespace ftid::lab {

namespace {

Json axes(const Vec6& v) {
  Json o = Json::object();
  for (int a = 0; a < 6; ++a) o[kWrenchAxisNames[a]] = jsonNumber(v(a));
  return o;
}

Json params(const ModelReport& r) {
  Json o = Json::object();
  for (const auto& p : r.params) {
    o[p.name] = Json{{"value", jsonNumber(p.value)}, {"std", jsonNumber(p.std)}, {"unit", p.unit}};
  }
  return o;
}

Json report(const ModelReport& r) {
  Json o = Json::object();
  o["model"] = r.model;
  o["residual_rms"] = axes(r.residual_rms);
  o["fit_residual_rms"] = axes(r.fit_residual_rms);
  o["condition_number"] = jsonNumber(r.condition_number);
  o["parameters"] = params(r);
  if (r.inertia) {
    Json value = Json::array(), sd = Json::array();
    for (int k = 0; k < 6; ++k) {
      value.push_back(jsonNumber(r.inertia->value(k)));
      sd.push_back(jsonNumber(r.inertia->std(k)));
    }
    o["inertia_com"] = Json{{"value", std::move(value)},
                            {"std", std::move(sd)},
                            {"positive_definite", r.inertia->positive_definite},
                            {"triangle_inequalities", r.inertia->triangle_inequalities},
                            {"explanation", r.inertia->explanation}};
  }
  return o;
}

}  // namespace

std::string formatJson(const AnalysisResult& r) {
  Json o = Json::object();
  o["model"] = r.report.model;
  o["log"] = r.log;
  o["validate_log"] = r.validate_log;
  o["samples"] = r.n_samples;
  o["heldout_samples"] = r.n_eval;
  o["folds"] = r.folds;
  o["residual_rms"] = axes(r.report.residual_rms);
  o["noise_floor"] = axes(r.noise_floor);
  o["noise_method"] = r.noise_method;
  o["noise_detail"] = r.noise_detail;
  o["noise_ar1"] = axes(r.noise_ar1);
  Json times = Json::array();
  for (const double t : r.outliers.times) times.push_back(jsonNumber(t));
  o["outliers"] = Json{{"count", r.outliers.count}, {"times", std::move(times)}};
  o["saturation"] = Json::parse(identify::saturationJson(r.saturation));  // saturation (issue 22)
  o["warnings"] = r.warnings;
  o["raw_rms"] = axes(r.report.raw_rms);
  o["fit"] = report(r.report);
  Json windows = Json::array();
  for (const auto& w : r.windows) {
    windows.push_back(Json{{"t_start", jsonNumber(w.t_start)},
                           {"t_end", jsonNumber(w.t_end)},
                           {"ratio", jsonNumber(w.ratio)},
                           {"worst_axis", kWrenchAxisNames[w.worst_axis]}});
  }
  o["windows"] = std::move(windows);
  Json correlations = Json::array();
  for (const auto& c : r.correlations) {
    correlations.push_back(Json{{"signal", c.signal},
                                {"axis", kWrenchAxisNames[c.axis]},
                                {"r", jsonNumber(c.r)},
                                {"significant", c.significant}});
  }
  o["correlations"] = std::move(correlations);
  o["extra_signals"] = r.extra_signals;  // extra log columns taken as signals (docs/analyze.md)
  Json candidates = Json::array();
  for (const auto& c : r.candidates) {
    Json e = Json::object();
    e["effect"] = c.effect;
    e["relative_reduction"] = jsonNumber(c.relative_reduction);
    e["significant"] = c.significant;
    e["p_value"] = jsonNumber(c.p_value);
    e["f_statistic"] = jsonNumber(c.f_statistic);
    e["added_params"] = c.added_params;
    e["delta_bic"] = jsonNumber(c.delta_bic);
    e["residual_rms"] = axes(c.residual_rms);
    e["description"] = c.description;
    e["next_command"] = c.next_command;
    e["skipped"] = c.skipped;
    e["note"] = c.note;
    e["confounded"] = c.confounded;
    e["confound"] = c.confound;
    e["separating_motion"] = c.separating_motion;
    e["verdict"] = verdictWord(c.verdict);
    e["family_p_value"] = jsonNumber(c.family_p);
    e["reason"] = c.reason;
    candidates.push_back(std::move(e));
  }
  o["candidates"] = std::move(candidates);
  o["family_alpha"] = jsonNumber(r.family_alpha);
  o["family_size"] = r.family_size;
  o["heldout_margin"] = jsonNumber(r.heldout_margin);
  o["unphysical"] = r.unphysical;
  o["unwritable"] = r.unwritable;
  o["writable_alternative"] = r.writable_alternative;
  detail::addChangePointsJson(r, o);  // change_points (change_point_report.cpp)
  if (!r.steps.empty()) {
    Json why = Json::array();
    for (const auto& c : r.final_candidates) {
      why.push_back(Json{{"effect", c.effect},
                         {"verdict", verdictWord(c.verdict)},
                         {"family_p_value", jsonNumber(c.family_p)},
                         {"reason", c.skipped ? c.note : c.reason}});
    }
    o["final_candidates"] = std::move(why);
    Json kept = Json::array();
    for (const auto& c : r.kept_unsupported) {
      kept.push_back(Json{{"effect", c.effect},
                          {"verdict", verdictWord(c.verdict)},
                          {"family_p_value", jsonNumber(c.family_p)},
                          {"reason", c.reason}});
    }
    o["kept_unsupported"] = std::move(kept);
  }
  if (!r.steps.empty()) {
    Json steps = Json::array();
    for (const auto& s : r.steps) {
      steps.push_back(Json{{"model", s.model},
                           {"added", s.added},
                           {"removed", s.removed},
                           {"family_p_value", jsonNumber(s.family_p)},
                           {"residual_rms", axes(s.residual_rms)},
                           {"ratio_to_noise", jsonNumber(s.total_ratio)},
                           {"p_value", jsonNumber(s.p_value)}});
    }
    o["steps"] = std::move(steps);
  }
  if (r.final_report) o["final"] = report(*r.final_report);
  // Issue 22 (sensor and mount dynamics): the residual's spectrum and autocorrelation.
  o["spectrum"] = detail::spectrumJson(r.spectrum);
  o["autocorrelation"] = detail::autocorrelationJson(r.spectrum);
  o["dynamics"] = detail::dynamicsJson(r.dynamics);
  o["imu"] = Json::parse(identify::imuReportJson(r.imu));  // issue 23 (docs/analyze.md "The IMU")
  o["seconds"] = jsonNumber(r.seconds);
  return jsonText(o, 1) + "\n";
}

}  // namespace ftid::lab
