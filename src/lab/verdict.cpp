// The laboratory's one decision rule (include/ftid/lab/verdict.hpp, docs/analyze.md "The verdict").
#include "ftid/lab/verdict.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <sstream>

#include "ftid/effects/cable.hpp"
#include "ftid/effects/rigid_body.hpp"
#include "ftid/identify/physical_check.hpp"
#include "ftid/params/parameter_set.hpp"

namespace ftid::lab {

namespace {

constexpr double kPi = 3.14159265358979323846;

std::string fmt(double v, int precision = 4) {
  std::ostringstream s;
  s.precision(precision);
  s << v;
  return s.str();
}

bool isMassLike(const std::string& n) {
  return n == "mass" || n.rfind("mass_com_", 0) == 0 || n == "tilt_u" || n == "tilt_v";
}

/// The payload's physical parameters (what a confound must not corrupt).
bool isPhysical(const std::string& n) { return isMassLike(n) || n.rfind("i_s_", 0) == 0; }

/// Why two parameters cannot be told apart, and what motion would separate them.
std::pair<std::string, std::string> explainPair(const std::string& a, const std::string& b) {
  auto has = [&](const std::string& key) { return a.find(key) != std::string::npos || b.find(key) != std::string::npos; };
  const bool mass = isMassLike(a) || isMassLike(b);
  if (has("cable_kp_z") && mass) {
    return {"a constant vertical pull is indistinguishable from the weight without translational acceleration",
            "move with translational acceleration (a dynamic excitation, e.g. from ftid design) instead of static poses"};
  }
  if (has("cable") && mass) {
    return {"without translational acceleration the cable's pull over these poses looks like the weight or its lever",
            "move with translational acceleration (a dynamic excitation) and through a larger range of positions, "
            "not only orientations"};
  }
  if (has("cable") && (has("f0_") || has("t0_"))) {
    return {"the cable's pull over these poses looks like the offsets",
            "move the tool through a larger range of positions, not only orientations, so the pull changes with position"};
  }
  if (has("i_s_") || has("inertia")) {
    return {"rotational inertia shows only under angular acceleration", "excite wrist rotations with larger angular acceleration"};
  }
  if (has("delay")) return {"a delay shows only where the wrench changes", "move faster (a wider excitation bandwidth)"};
  if ((has("temp") || has("dt_")) && (has("poly(t") || has("time") || has("d_dt"))) {
    return {"temperature and time change together in this log",
            "record longer, or at several temperatures, so temperature does not follow time"};
  }
  if (mass) {
    return {"it changes together with the weight in this data", "more distinct orientations and translational acceleration"};
  }
  return {"they change together in this data", "a motion that changes one without the other (more distinct orientations, "
                                               "positions and accelerations)"};
}

int columnOf(const FitView& f, const std::string& name) {
  const auto it = std::find(f.names.begin(), f.names.end(), name);
  return it == f.names.end() ? -1 : static_cast<int>(it - f.names.begin());
}

double sdOf(const FitView& f, int k) {
  return k >= 0 && k < f.covariance.rows() ? std::sqrt(std::max(0.0, f.covariance(k, k))) : 0.0;
}

bool isAdded(const FitView& f, int k) { return k >= 0 && static_cast<std::size_t>(k) < f.added.size() && f.added[static_cast<std::size_t>(k)]; }

/// The largest standard error a payload parameter may have in the richer model and still count as
/// determined; <= 0: not a payload parameter judged here.
double determinedBound(const FitView& f, const std::string& name) {
  const int cm = columnOf(f, "mass");
  const double m = cm >= 0 ? std::abs(f.theta(cm)) : 0.0;
  if (name == "mass") return 0.1 * m;                          // 10 % of the mass
  if (name.rfind("mass_com_", 0) == 0) return 0.01 * m;         // 1 cm of the centre of mass
  if (name == "tilt_u" || name == "tilt_v") return 3.0 * kPi / 180.0;  // 3 degrees
  return 0.0;
}

}  // namespace

const char* verdictWord(Verdict v) {
  switch (v) {
    case Verdict::kRecommended: return "recommended";
    case Verdict::kNotSignificant: return "not significant";
    case Verdict::kNoHeldOutGain: return "no held-out gain";
    case Verdict::kRefused: return "refused";
    case Verdict::kNothingToAdd: return "nothing to add";
    case Verdict::kSkipped: return "skipped";
  }
  return "?";
}

Decision decide(const RuleInputs& in) {
  Decision d;
  const double m = static_cast<double>(std::max(1, in.family_size));
  d.family_p = std::min(1.0, m * std::max(0.0, in.p_value));
  if (in.added_params <= 0) {
    d.verdict = Verdict::kNothingToAdd;
    d.family_p = 1.0;
    d.reason = "the data determine none of its parameters beyond the model's";
    return d;
  }
  if (!(d.family_p < in.family_alpha)) {
    d.verdict = Verdict::kNotSignificant;
    d.reason = "its held-out gain is within chance: family-wise p = " + fmt(d.family_p, 2) + ", not below alpha = " +
               fmt(in.family_alpha, 2);
    return d;
  }
  if (!(in.heldout_reduction > in.min_heldout_reduction)) {
    d.verdict = Verdict::kNoHeldOutGain;
    d.reason = "it helps only in-sample: the held-out error " +
               (in.heldout_reduction <= 0.0 ? std::string("does not fall")
                                            : "falls by only " + fmt(100.0 * in.heldout_reduction, 2) + " %") +
               (in.min_heldout_reduction > 0.0 ? " (needs more than " + fmt(100.0 * in.min_heldout_reduction, 2) + " %)"
                                                : std::string());
    return d;
  }
  if (!in.refusals.empty()) {
    d.verdict = Verdict::kRefused;
    for (const auto& r : in.refusals) {
      d.reason += (d.reason.empty() ? "" : "; ") + r.reason;
      if (d.separating_motion.empty()) d.separating_motion = r.separating_motion;
    }
    return d;
  }
  d.verdict = Verdict::kRecommended;
  return d;
}

std::vector<Refusal> identifiabilityRefusals(const FitView& f) {
  std::vector<Refusal> out;
  const int n = static_cast<int>(f.names.size());
  // Directions the data do not determine at all: an added and a payload parameter sharing one.
  for (Eigen::Index nc = 0; nc < f.null_space.cols(); ++nc) {
    int ja = -1, ib = -1;
    double va = 0.1, vb = 0.1;
    for (int k = 0; k < n && k < f.null_space.rows(); ++k) {
      const double v = std::abs(f.null_space(k, nc));
      if (isAdded(f, k) && v > va) {
        va = v;
        ja = k;
      } else if (!isAdded(f, k) && isPhysical(f.names[static_cast<std::size_t>(k)]) && v > vb) {
        vb = v;
        ib = k;
      }
    }
    if (ja >= 0 && ib >= 0) {
      const auto& a = f.names[static_cast<std::size_t>(ja)];
      const auto& b = f.names[static_cast<std::size_t>(ib)];
      const auto [why, how] = explainPair(a, b);
      out.push_back({a + " and " + b + " are confounded (the data determine only their combination): " + why, how});
      return out;
    }
  }
  // A payload parameter that the richer model no longer determines, because the added parameters
  // take over its role: its multiple correlation with the whole added block in M+E's own
  // covariance, R^2 = S_iA S_AA^-1 S_Ai / S_ii (several added parameters can share the role, each
  // with a modest pairwise correlation). The added parameter with the largest |r| is named.
  std::vector<int> block;
  for (int j = 0; j < n; ++j) {
    if (isAdded(f, j) && sdOf(f, j) > 0.0) block.push_back(j);
  }
  if (block.empty()) return out;
  const auto na = static_cast<Eigen::Index>(block.size());
  Eigen::MatrixXd s_aa(na, na);
  for (Eigen::Index a = 0; a < na; ++a) {
    for (Eigen::Index b = 0; b < na; ++b) s_aa(a, b) = f.covariance(block[static_cast<std::size_t>(a)], block[static_cast<std::size_t>(b)]);
  }
  const Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> s_aa_inv(s_aa);
  for (int i = 0; i < n; ++i) {
    if (isAdded(f, i)) continue;
    const std::string& name = f.names[static_cast<std::size_t>(i)];
    const double bound = determinedBound(f, name);
    const double sd = sdOf(f, i);
    if (!(bound > 0.0) || sd <= bound) continue;
    Eigen::VectorXd s_ai(na);
    double worst = 0.0;
    int partner = -1;
    for (Eigen::Index a = 0; a < na; ++a) {
      const int j = block[static_cast<std::size_t>(a)];
      s_ai(a) = f.covariance(j, i);
      const double r = std::abs(s_ai(a) / (sd * sdOf(f, j)));
      if (r > worst) {
        worst = r;
        partner = j;
      }
    }
    const double r2 = std::clamp(s_ai.dot(s_aa_inv.solve(s_ai)) / (sd * sd), 0.0, 1.0);
    const double multiple_r = std::sqrt(r2);
    if (partner < 0 || multiple_r < 0.9) continue;  // not the candidate's doing
    const auto& pname = f.names[static_cast<std::size_t>(partner)];
    const auto [why, how] = explainPair(pname, name);
    out.push_back({name + " is no longer determined with " + pname + " (" + fmt(f.theta(i), 4) + " +- " + fmt(sd, 3) +
                       ", multiple correlation with the added parameters " + fmt(multiple_r, 4) + ", |correlation| with " +
                       pname + " " + fmt(worst, 4) + "): " + pname + " and the " +
                       (name == "mass" ? std::string("mass") : name) + " are confounded: " + why,
                   how});
    return out;
  }
  return out;
}

std::vector<Refusal> physicsRefusals(const FitView& f) {
  std::vector<Refusal> out;
  if (f.model == nullptr) return out;
  const int cm = columnOf(f, "mass");
  if (cm >= 0) {
    const double m = f.theta(cm);
    if (!(m > 0.0)) {
      out.push_back({"the mass is " + fmt(m, 4) + " kg (must be > 0)", "more distinct orientations"});
    } else if (f.model->contains("rigid_body")) {
      std::vector<int> cols = {cm, columnOf(f, "mass_com_x"), columnOf(f, "mass_com_y"), columnOf(f, "mass_com_z")};
      for (const char* nm : effects::kInertiaParamNames) cols.push_back(columnOf(f, nm));
      if (std::all_of(cols.begin(), cols.end(), [](int k) { return k >= 0; })) {
        Eigen::Matrix<double, 10, 1> pv;
        Eigen::Matrix<double, 10, 10> cv;
        for (int i = 0; i < 10; ++i) {
          pv(i) = f.theta(cols[static_cast<std::size_t>(i)]);
          for (int j = 0; j < 10; ++j) cv(i, j) = f.covariance(cols[static_cast<std::size_t>(i)], cols[static_cast<std::size_t>(j)]);
        }
        const auto in = effects::inertiaAboutCom(pv, cv);
        if (!in.valid_within_uncertainty) {
          out.push_back({"the inertia about the centre of mass is not physical: " + in.explanation,
                         "excite wrist rotations with larger angular acceleration"});
        }
      }
    }
  }
  if (f.samples != nullptr && cm >= 0 && f.theta(cm) > 0.0 && f.theta.size() >= f.model->numParams()) {
    const auto low = f.model->smallestPayloadMass(*f.samples, f.theta.head(f.model->numParams()));
    if (low && !(low->mass_kg > 0.0)) {
      std::string by;
      for (const auto& e : f.model->effectList()) {
        if (e->changesPayloadMass()) by += (by.empty() ? "" : ", ") + e->name();
      }
      out.push_back({"the payload mass, moving with its signal (" + by + "), is " + fmt(low->mass_kg, 4) + " kg at t = " +
                         fmt((*f.samples)[low->sample].t, 4) + " s (must be > 0 at every sample)",
                     "move the signal over its range while the robot moves"});
    }
  }
  const int ck = columnOf(f, effects::kCableStiffnessParam);
  if (ck >= 0) {
    const double k = f.theta(ck), sd = sdOf(f, ck);
    if (k + 2.0 * sd < 0.0) {
      out.push_back({"the cable's spring constant is " + fmt(k, 4) + " +- " + fmt(sd, 3) + " N/m (a spring cannot push)",
                     "move the tool through a larger range of positions"});
    }
  }
  return out;
}

std::string writeRefusal(const FitView& f) {
  if (f.model == nullptr) return {};
  params::ParameterSet set;
  set.model = f.model->name();
  bool has_mass = false;
  const std::size_t n = std::min(f.names.size(), static_cast<std::size_t>(f.theta.size()));
  for (std::size_t i = 0; i < n; ++i) {
    const std::string& nm = f.names[i];
    if (nm != "mass" && nm.rfind("mass_com_", 0) != 0 && nm.rfind("i_s_", 0) != 0) continue;
    const int k = static_cast<int>(i);
    set.params.push_back({nm, f.theta(k), std::sqrt(std::max(0.0, f.covariance(k, k))), ""});
    has_mass = has_mass || nm == "mass";
  }
  if (!has_mass) return {};
  // As `ftid identify --out`: an inertia within its uncertainty is projected, then the check.
  std::string not_projected;
  params::projectInertiaWithinUncertainty(&set, &not_projected);
  const identify::PhysicalValidity validity = identify::checkPhysicalValidity(set);
  if (validity.valid) return {};
  return validity.problem->message + (not_projected.empty() ? "" : " (" + not_projected + ")");
}

double wrapAngle(double rad) {
  if (!std::isfinite(rad)) return rad;
  double w = std::remainder(rad, 2.0 * kPi);  // [-pi, pi]
  if (w <= -kPi) w += 2.0 * kPi;
  return w;
}

}  // namespace ftid::lab
