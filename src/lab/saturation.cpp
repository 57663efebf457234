// Saturation in the laboratory (issue 22, docs/analyze.md "Saturation"): the samples at a range
// limit (identify::findSaturation, the one rule of include/ftid/identify/saturation.hpp) are left
// out of every fit and held-out sum through the dataset's exclusions, as glitches are.
#include "ftid/identify/saturation.hpp"

#include <cstdio>
#include <string>
#include <vector>

#include "lab_internal.hpp"

namespace ftid::lab::detail {

void excludeSaturation(Dataset& d, const AnalyzeOptions& options, AnalysisResult& result) {
  // Each log on its own (the fitting log, a validation log): a log's flat top is judged against
  // that log's own levels.
  for (std::size_t k = 0; k < d.segment_start.size(); ++k) {
    const int begin = d.segment_start[k];
    const int end = k + 1 < d.segment_start.size() ? d.segment_start[k + 1] : d.size();
    const std::vector<SampleContext> log(d.ctx.begin() + begin, d.ctx.begin() + end);
    const identify::Saturation sat = identify::findSaturation(log, options.saturation);
    result.saturation.insert(result.saturation.end(), sat.axes.begin(), sat.axes.end());
    result.saturated_samples += static_cast<int>(sat.samples.size());
    if (!sat.samples.empty() && d.excluded.empty()) d.excluded.assign(d.ctx.size(), 0);
    for (const int i : sat.samples) d.excluded[static_cast<std::size_t>(begin + i)] = 1;
    for (const auto& s : sat.axes) say(options, identify::saturationLine(s));
  }
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
