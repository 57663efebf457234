// The residual's spectrum in the laboratory's reports (spectrum_report.hpp).
#include "spectrum_report.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace ftid::lab::detail {

namespace {

/// 4 significant digits: the plots and the peak need no more, and the JSON stays small.
Json short4(double v) {
  if (!std::isfinite(v)) return Json(nullptr);
  char b[32];
  std::snprintf(b, sizeof b, "%.4g", v);
  return Json(std::strtod(b, nullptr));
}

Json array4(const std::vector<double>& v) {
  Json a = Json::array();
  for (const double x : v) a.push_back(short4(x));
  return a;
}

Json peakJson(const SpectralPeak& p) {
  return Json{{"f_hz", short4(p.f_hz)},
              {"ratio", short4(p.ratio)},
              {"family_p_value", jsonNumber(p.p_family)},
              {"significant", p.significant},
              {"in_motion_band", p.in_motion_band}};
}

}  // namespace

ResidualSpectrum spectrumOfAnalysis(const AnalysisResult& r, const std::vector<char>& excluded,
                                    double colour_scale_sd) {
  const auto n = static_cast<Eigen::Index>(r.t.size());
  const bool final = r.final_report.has_value() && r.final_residual.cols() == n;
  const Eigen::Matrix<double, 6, Eigen::Dynamic> residual = final ? r.final_residual : r.measured - r.predicted;
  const Eigen::Matrix<double, 6, Eigen::Dynamic> modelled = r.measured - residual;
  SpectrumInput in;
  in.t = &r.t;
  in.residual = &residual;
  in.modelled = &modelled;
  in.excluded = excluded;
  in.noise_std = r.noise_floor;
  in.noise_ar1 = r.noise_ar1;
  in.noise_known = r.noise_method != "not_observable";
  in.log_scale_sd = noiseLevelScaleSd(r.n_samples, colour_scale_sd, r.noise_method == "data_sheet");
  return residualSpectrum(in);
}

std::string spectrumWarning(const ResidualSpectrum& s, const DynamicsCheck& dynamics, const std::string& missing) {
  if (!s.valid) return "";
  std::string axes;
  for (int a = 0; a < 6; ++a) {
    const SpectralPeak& p = s.axes[static_cast<std::size_t>(a)].beyond;
    if (!p.significant) continue;
    char b[96];
    std::snprintf(b, sizeof b, "%s%s %.3g Hz (%.3gx)", axes.empty() ? "" : ", ", kWrenchAxisNames[a], p.f_hz, p.ratio);
    axes += b;
  }
  if (axes.empty()) return "";
  char band[48];
  std::snprintf(band, sizeof band, "0-%.3g Hz", s.motion_band_hz);
  const std::string head = "the held-out residual has a peak beyond the motion band (" + std::string(band) + ") on " + axes;
  if (!missing.empty()) {
    // The residual of a model without the recommended effect: its terms (products of the motion's
    // frequencies, for rigid_body) may be the peak; judging it before adding the effect would
    // contradict the verdict.
    return head + ": the model lacks " + missing + " (the missing effect this analysis names), which may account for it; judge the "
                  "spectrum of the model with it (--explain does)";
  }
  if (dynamics.tested && !dynamics.significant) {
    // The search for a filter of the reading found none: the peak is the residual's own, not a
    // resonance or filter of the reading (the two lines must not contradict each other).
    return head + ": no filter of the reading explains it (dynamics of the reading: nothing of the kind), so it is a "
                  "disturbance of its own at those frequencies, e.g. contacts or pushes, vibration from the process "
                  "or the cell; see where it fails and docs/analyze.md, \"The residual's spectrum\"";
  }
  return head + ": the reading has dynamics of its own, a resonance (a compliant mount or tool) or the sensor's filter, "
                "which no effect of the model's menu describes (a sensor_delay taken for it stands in for part of it); "
                "see the dynamics of the reading and docs/analyze.md, \"The residual's spectrum\"";
}

std::string spectrumText(const ResidualSpectrum& s) {
  std::string out = "\n" + spectrumRule(s) + (s.valid ? ":\n" : "\n");
  if (!s.valid) return out;
  for (int a = 0; a < 6; ++a) out += "  " + spectrumLine(s, a) + "\n";
  if (!s.noise_known) out += "  (the noise floor is not observable here: no peak is called)\n";
  return out;
}

Json spectrumJson(const ResidualSpectrum& s) {
  Json o = Json::object();
  o["valid"] = s.valid;
  o["note"] = s.note;
  if (!s.valid) return o;
  o["rule"] = spectrumRule(s);
  o["segment"] = s.segment;
  o["segments"] = s.segments;
  o["dof"] = jsonNumber(s.dof);
  o["bins_tested"] = s.bins_tested;
  o["alpha"] = jsonNumber(s.alpha);
  o["noise_level_log_sd"] = jsonNumber(s.log_scale_sd);
  o["resolution_hz"] = jsonNumber(s.f_hz.size() > 1 ? s.f_hz[1] : 0.0);
  o["motion_band_hz"] = Json::array({0.0, jsonNumber(s.motion_band_hz)});
  for (int a = 0; a < 6; ++a) {
    const AxisSpectrum& ax = s.axes[static_cast<std::size_t>(a)];
    o[kWrenchAxisNames[a]] = Json{{"f_hz", array4(s.f_hz)},
                                  {"psd", array4(ax.psd)},
                                  {"noise_psd", array4(ax.noise_psd)},
                                  {"peak", peakJson(ax.peak)},
                                  {"beyond_band_peak", peakJson(ax.beyond)}};
  }
  return o;
}

Json dynamicsJson(const DynamicsCheck& d) {
  Json o = Json::object();
  o["tested"] = d.tested;
  o["note"] = d.note;
  if (!d.tested) return o;
  o["effect"] = d.effect;
  o["f_hz"] = jsonNumber(d.f_hz);
  o["zeta"] = jsonNumber(d.zeta);
  o["relative_reduction"] = jsonNumber(d.relative_reduction);
  Json rms = Json::object();
  for (int a = 0; a < 6; ++a) rms[kWrenchAxisNames[a]] = jsonNumber(d.residual_rms(a));
  o["residual_rms"] = std::move(rms);
  o["p_value"] = jsonNumber(d.p_value);
  o["family_p_value"] = jsonNumber(d.family_p);
  o["grid_points"] = d.grid_points;
  o["significant"] = d.significant;
  const DynamicsCheck::DelayAgainstLag& g = d.delay;
  if (g.tested) {
    Json lag{{"lag_s", jsonNumber(g.lag_s)},
             {"model_delay_s", jsonNumber(g.model_delay_s)},
             {"delay_s", jsonNumber(g.delay_s)},
             {"imu_compared", g.imu_compared}};
    if (g.imu_compared) {
      lag["imu_delay_s"] = jsonNumber(g.imu_delay_s);
      lag["held"] = Json{{"effect", g.held_effect}, {"f_hz", jsonNumber(g.held_f_hz)}, {"zeta", jsonNumber(g.held_zeta)},
                         {"lag_s", jsonNumber(g.held_lag_s)}};
      lag["family_p_value"] = jsonNumber(g.family_p);
      lag["delay_is_lag"] = g.delay_is_lag;
      lag["reason"] = g.reason;  // the rule's reason for not taking the free delay ("" when it takes it)
    }
    o["delay_against_lag"] = std::move(lag);
  }
  return o;
}

std::string dynamicsWarning(const DynamicsCheck& d, const Vec6& noise_floor) {
  if (!d.significant) return "";
  const std::string line = delayAgainstLagLine(d);
  const std::string lag = line.empty() ? std::string() : "; " + line;
  return dynamicsLine(d, noise_floor) + lag +
         "; a diagnosis only: identify, ftidd and compensate do not model or invert it (docs/effects.md, "
         "\"Dynamics of the reading\"): stiffen the mount, or change the sensor's filter";
}

Json autocorrelationJson(const ResidualSpectrum& s) {
  Json o = Json::object();
  if (!s.valid) return o;
  o["lag_s"] = jsonNumber(s.dt_s);
  for (int a = 0; a < 6; ++a) {
    const AxisSpectrum& ax = s.axes[static_cast<std::size_t>(a)];
    o[kWrenchAxisNames[a]] = Json{{"r", array4(ax.acf)}, {"noise", array4(ax.noise_acf)}};
  }
  return o;
}

}  // namespace ftid::lab::detail
