// The parameter-set part of `ftid identify --json` (parameter_set.hpp toJson; the fit check's part
// is in identify/fit_check.cpp): built with nlohmann-json under the one output policy of
// ftid/fileio/json_text.hpp (round-trip numbers, null for non-finite ones). Keys:
// docs/identification.md "Outputs". Kept apart from the fit machinery so the parameter_yaml fuzz
// target links it alone.
#include <algorithm>
#include <string>
#include <vector>

#include "ftid/fileio/json_text.hpp"
#include "ftid/params/parameter_json.hpp"

namespace ftid::params {

Json axesJson(const Vec6& v) {
  Json o = Json::object();
  for (int a = 0; a < 6; ++a) o[kWrenchAxisNames[a]] = jsonNumber(v(a));
  return o;
}

Json parameterSetJson(const ParameterSet& set) {
  Json j = Json::object();
  j["model"] = set.model;
  j["method"] = set.provenance.method;
  j["n_samples"] = set.provenance.n_samples;
  Json params = Json::object();
  auto entry = [&](const std::string& name, double value, double sd) {
    params[name] = Json{{"value", jsonNumber(value)}, {"std", jsonNumber(sd)}};
  };
  std::vector<std::string> done;
  for (const char* name : {"mass", "weight", "com_x", "com_y", "com_z", "f0_x", "f0_y", "f0_z", "t0_x", "t0_y",
                           "t0_z"}) {
    if (const NamedValue* p = set.find(name)) {
      entry(name, p->value, p->std);
      done.emplace_back(name);
    }
  }
  entry("tilt_u", set.tilt_u_rad, set.tilt_u_std);
  entry("tilt_v", set.tilt_v_rad, set.tilt_v_std);
  for (const auto& p : set.params) {
    if (std::find(done.begin(), done.end(), p.name) == done.end()) entry(p.name, p.value, p.std);
  }
  j["parameters"] = std::move(params);
  j["residual_rms"] = axesJson(set.residual_rms);
  j["condition_number"] = jsonNumber(set.condition_number);
  j["tilt_estimated"] = set.tilt_estimated;
  Json units = Json::object();
  for (const auto* group : {&set.params, &set.derived}) {
    for (const auto& p : *group) units[p.name] = p.unit;
  }
  units["tilt_u"] = "rad";
  units["tilt_v"] = "rad";
  j["units"] = std::move(units);
  Json extras = Json::object();
  for (const auto& e : set.extras) extras[e.name] = jsonNumber(e.value);
  j["extras"] = std::move(extras);
  j["data_file"] = set.provenance.data_file;
  j["time_origin_unix_s"] = jsonNumber(set.time_origin_unix_s);  // null: no time origin
  return j;
}

std::string toJson(const ParameterSet& set) { return jsonText(parameterSetJson(set)); }

}  // namespace ftid::params
