// Saturation in the laboratory (issue 22, docs/analyze.md "Saturation"): the samples at a range
// limit (identify::findSaturation, the one rule of include/ftid/identify/saturation.hpp) are left
// out of every fit and held-out sum through the dataset's exclusions, as glitches are.
#include "ftid/identify/saturation.hpp"

#include <cstdio>
#include <string>

#include "lab_internal.hpp"

namespace ftid::lab::detail {

void excludeSaturation(Dataset& d, const AnalyzeOptions& options, AnalysisResult& result) {
  const identify::Saturation sat = identify::findSaturation(d.ctx, options.saturation);
  result.saturation = sat.axes;
  result.saturated_samples = static_cast<int>(sat.samples.size());
  if (sat.samples.empty()) return;
  if (d.excluded.empty()) d.excluded.assign(d.ctx.size(), 0);
  for (const int i : sat.samples) d.excluded[static_cast<std::size_t>(i)] = 1;
  for (const auto& s : sat.axes) say(options, identify::saturationLine(s));
}

std::string saturationText(const AnalysisResult& r) {
  std::string s;
  for (const auto& a : r.saturation) s += "saturation: " + identify::saturationLine(a) + "\n";
  return s;
}

std::string saturationHtml(const AnalysisResult& r) {
  if (r.saturation.empty()) return "";
  std::string s = "<h2>Saturation</h2>\n<p>Samples at a range limit of the sensor (a flat top, or the rated "
                  "range); they are left out of every fit and held-out sum, the plots keep them.</p>\n<table>"
                  "<tr><th>axis</th><th>limit</th><th>samples</th><th>share</th><th>found as</th><th>first at t [s]</th></tr>\n";
  for (const auto& a : r.saturation) {
    char row[400];
    std::string times;
    for (const double t : a.times) times += (times.empty() ? "" : ", ") + fmt(t, 4);
    if (a.count > static_cast<int>(a.times.size())) times += ", &hellip;";
    std::snprintf(row, sizeof row, "<tr class=\"bad\"><td>%s</td><td>%.4g %s</td><td>%d</td><td>%.1f %%</td><td>%s</td><td>%s</td></tr>\n",
                  kWrenchAxisNames[a.axis], a.value, a.axis < 3 ? "N" : "Nm", a.count, 100.0 * a.fraction,
                  a.flat_top ? (a.rated ? "flat top, rated range" : "flat top") : "rated range", times.c_str());
    s += row;
  }
  return s + "</table>\n<p>Check the sensor's range or the tool load.</p>\n";
}

}  // namespace ftid::lab::detail
