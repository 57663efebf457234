// The text of an identification run (src/cell/run_report.hpp).
#include "run_report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "ftid/identify/noise.hpp"

namespace ftid::cell::internal {

std::string fmt(int decimals, double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
  return buf;
}

std::string expectedAccuracy(const trajectory::TrajectoryFile& f, const std::string& model_name) {
  const auto get = [&](const std::string& k) {
    const auto it = f.predicted_std.find(k);
    return it == f.predicted_std.end() ? -1.0 : it->second;
  };
  const auto d = f.design.find("model");
  const std::string designed_for = d == f.design.end() ? std::string("?") : d->second;
  if (f.predicted_std.empty()) {
    return "  expected accuracy: unknown (the trajectory file records no predicted standard errors)";
  }
  std::string s = "  expected accuracy (1 sigma, predicted by the design for model " + designed_for + "):";
  const double m = get("mass");
  if (m >= 0) s += " mass " + fmt(4, m) + " kg";
  double c = 0.0;
  for (const char* k : {"com_x", "com_y", "com_z"}) c = std::max(c, get(k));
  if (c > 0) s += ", centre of mass " + fmt(2, 1000.0 * c) + " mm";
  const double t = std::max(get("tilt_u"), get("tilt_v"));
  if (t > 0) s += ", tilt " + fmt(3, t * 180.0 / M_PI) + " deg";
  double f0 = 0.0;
  for (const char* k : {"f0_x", "f0_y", "f0_z"}) f0 = std::max(f0, get(k));
  if (f0 > 0) s += ", F0 " + fmt(3, f0) + " N";
  double t0 = 0.0;
  for (const char* k : {"t0_x", "t0_y", "t0_z"}) t0 = std::max(t0, get(k));
  if (t0 > 0) s += ", T0 " + fmt(4, t0) + " Nm";
  if (designed_for != model_name) s += "\n  (you fit " + model_name + ": the figures are indicative only)";
  return s;
}

std::string axisTable(const Vec6& heldout, const Vec6& noise, const Vec6& raw) {
  std::ostringstream o;
  o << "  axis   raw RMS   held-out residual   noise floor   ratio\n";
  for (int i = 0; i < 6; ++i) {
    const double ratio = noise(i) > 0 ? heldout(i) / noise(i) : 0.0;
    char line[160];
    std::snprintf(line, sizeof(line), "  %-4s %9.4f %12.4f %16.4f %10.2f%s\n", kWrenchAxisNames[i], raw(i),
                  heldout(i), noise(i), ratio, ratio > identify::kAboveFloorMark ? "   <- above noise" : "");
    o << line;
  }
  return o.str();
}

std::string axesAboveFloor(const Vec6& heldout, const Vec6& noise) {
  std::string out;
  for (int i = 0; i < 6; ++i) {
    const double ratio = noise(i) > 0 ? heldout(i) / noise(i) : 0.0;
    if (!(ratio > identify::kAboveFloorMark)) continue;
    out += (out.empty() ? "" : ", ") + std::string(kWrenchAxisNames[i]) + " " + fmt(2, ratio) + "x";
  }
  return out;
}

}  // namespace ftid::cell::internal
