// Physical validity of an identified parameter set (include/ftid/identify/physical_check.hpp).
#include "ftid/identify/physical_check.hpp"

#include <cmath>
#include <cstdio>

#include "ftid/effects/model.hpp"
#include "ftid/effects/rigid_body.hpp"
#include "ftid/fileio/json_text.hpp"

namespace ftid::identify {

namespace {

const NamedValue* findParam(const ParameterSet& set, const std::string& name) {
  for (const auto& p : set.params) {
    if (p.name == name) return &p;
  }
  return nullptr;
}

std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.4g", v);
  return buf;
}

/// "inertia about the centre of mass: <explanation>" for sets with all six i_s_* and a positive
/// mass (the analyze report's words); empty otherwise.
std::string inertiaPart(const ParameterSet& set, const NamedValue& mass) {
  Eigen::Matrix<double, 10, 1> p = Eigen::Matrix<double, 10, 1>::Zero();
  Eigen::Matrix<double, 10, 10> cov = Eigen::Matrix<double, 10, 10>::Zero();
  p(0) = mass.value;
  cov(0, 0) = mass.std * mass.std;
  const char* mc[3] = {"mass_com_x", "mass_com_y", "mass_com_z"};
  for (int k = 0; k < 3; ++k) {
    if (const NamedValue* v = findParam(set, mc[k])) {
      p(1 + k) = v->value;
      cov(1 + k, 1 + k) = v->std * v->std;
    }
  }
  for (int k = 0; k < 6; ++k) {
    const NamedValue* v = findParam(set, effects::kInertiaParamNames[k]);
    if (v == nullptr) return "";
    p(4 + k) = v->value;
    cov(4 + k, 4 + k) = v->std * v->std;
  }
  if (!(mass.value > 0.0) || !p.allFinite() || !cov.allFinite()) return "";
  return "; inertia about the centre of mass: " + effects::inertiaAboutCom(p, cov).explanation;
}

}  // namespace

std::optional<VaryingMass> varyingMass(const ParameterSet& set, const std::vector<effects::SampleContext>& samples) {
  if (set.model.empty()) return std::nullopt;
  const effects::Model model = effects::Model::fromName(set.model);
  Eigen::VectorXd theta = Eigen::VectorXd::Zero(model.numParams());
  for (const auto& p : set.params) {
    const int c = model.paramIndex().column(p.name);
    if (c >= 0) theta(c) = p.value;
  }
  const auto low = model.smallestPayloadMass(samples, theta);
  if (!low) return std::nullopt;
  VaryingMass v{low->mass_kg, samples[low->sample].t, ""};
  for (const auto& e : model.effectList()) {
    if (e->changesPayloadMass()) v.effects += (v.effects.empty() ? "" : ", ") + e->name();
  }
  return v;
}

PhysicalValidity checkPhysicalValidity(const ParameterSet& set, const std::optional<VaryingMass>& varying) {
  PhysicalValidity out = checkPhysicalValidity(set);
  if (!out.valid || !varying || varying->mass_kg > 0.0) return out;
  out.valid = false;
  out.problem = params::ParameterProblem{
      "parameters.mass", "the mass moving with its signal (" + varying->effects + ") is " + number(varying->mass_kg) +
                             " kg at t = " + number(varying->t_s) + " s (must be > 0 at every sample)"};
  const auto arrow = out.line.find(" -> ");
  out.line = out.line.substr(0, arrow) + " -> REFUSED: '" + out.problem->key + "': " + out.problem->message;
  return out;
}

PhysicalValidity checkPhysicalValidity(const ParameterSet& set) {
  PhysicalValidity out;
  const NamedValue* mass = findParam(set, "mass");
  // A positive mass whose standard error exceeds a third of it is not determined (zero lies within
  // 3 standard errors): the root cause, named first, since its inertia and centre of mass then
  // carry no information whatever their point values (a non-positive mass is findParameterProblem's).
  if (mass != nullptr && mass->value > 0.0 && !(kMaxMassRelativeStd * mass->value >= mass->std)) {
    out.problem = params::ParameterProblem{
        "parameters.mass", "mass " + number(mass->value) + " +- " + number(mass->std) +
                               " kg is not determined by the data (its standard error exceeds a third of it)"};
  } else {
    out.problem = params::findParameterProblem(set);
  }
  out.valid = !out.problem.has_value();
  std::string s = "physical validity: ";
  if (mass != nullptr) {
    s += "mass " + number(mass->value) + " +- " + number(mass->std) + " kg " +
         (mass->value > 0.0 ? "(positive)" : "(NOT positive)");
    s += inertiaPart(set, *mass);
  } else {
    s += "no mass in model " + set.model;
  }
  s += out.valid ? " -> physically valid within the uncertainty"
                 : " -> REFUSED: '" + out.problem->key + "': " + out.problem->message;
  out.line = s;
  return out;
}

std::string physicalRefusal(const PhysicalValidity& validity) {
  if (validity.valid) return "";
  return "the identified parameters are not physically usable ('" + validity.problem->key + "': " +
         validity.problem->message +
         "); no parameter file or export written. Check the set-up, excite the payload longer or with more "
         "motion, or fit a model that explains the data (ftid analyze)";
}

std::string identificationJson(const ParameterSet& set, const FitCheck& check, const PhysicalValidity& validity) {
  Json j = Json::parse(identificationJson(set, check));
  Json v = Json::object();
  v["valid"] = validity.valid;
  v["key"] = validity.problem ? Json(validity.problem->key) : Json(nullptr);
  v["reason"] = validity.problem ? Json(validity.problem->message) : Json(nullptr);
  v["line"] = validity.line;
  j["physical_validity"] = v;
  return jsonText(j);
}

}  // namespace ftid::identify
