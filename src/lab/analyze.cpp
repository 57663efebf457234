// The model laboratory: held-out validation, diagnostics, candidate ranking, forward selection
// (include/ftid/lab/analyze.hpp, docs/analyze.md).
#include <algorithm>
#include <chrono>
#include <memory>
#include <tuple>
#include <cmath>
#include <sstream>

#include "engine.hpp"
#include "ftid/effects/nonlinear.hpp"
#include "ftid/common/error.hpp"
#include "ftid/effects/cable.hpp"
#include "ftid/effects/model.hpp"
#include "ftid/effects/signal_source.hpp"
#include "ftid/identify/noise.hpp"
#include "ftid/lab/analyze.hpp"

namespace ftid::lab {

namespace {

using detail::Dataset;
using detail::Engine;
using detail::Linearization;
using detail::Mat6X;
using detail::Solution;
using effects::Model;

/// Paper effects are the base of every model: never offered as candidates unless missing.
bool isGenericBase(const std::string& name) { return name == "harmonic" || name == "poly"; }

void say(const AnalyzeOptions& o, const std::string& line) {
  if (o.progress) o.progress(line);
}

std::string fmt(double v, int precision = 4) {
  std::ostringstream s;
  s.precision(precision);
  s << v;
  return s.str();
}

/// Checks the signals a model needs against the data; "" if fine, else the reason.
std::string missingSignal(const Model& model, const std::vector<SampleContext>& ctx) {
  const std::uint32_t s = model.signals();
  if ((s & effects::kSignalTemperature) && !ctx.front().has_temp) return "the log has no temp column";
  for (const auto& e : model.effectList()) {
    const std::string n = e->name();
    const auto open = n.find('(');
    if (open == std::string::npos) continue;
    const auto comma = n.find(',', open);
    const std::string sig = n.substr(open + 1, (comma == std::string::npos ? n.size() - 1 : comma) - open - 1);
    if (sig.empty()) continue;
    try {
      const auto src = effects::SignalSource::parse(sig);
      if (!src.available(ctx.front())) {
        if (!ctx.front().has_joints && (sig.rfind("q", 0) == 0)) {
          return "needs the joint angle signal '" + sig + "'; the log gives the sensor pose, not joint angles";
        }
        return "the log has no signal '" + sig + "'";
      }
    } catch (const ConfigError&) {
      // Effect arguments that are not signals (temperature_drift(20)) are the effect's business.
    }
  }
  return "";
}

ModelReport makeReport(const Engine& eng, const Model& model, const Linearization& lin, const Solution& sol) {
  ModelReport r;
  r.model = model.name();
  const auto params = model.params();
  const int p = model.numParams();
  const auto stdOf = [&](int k) { return std::sqrt(std::max(0.0, sol.covariance(k, k))); };
  for (int k = 0; k < p; ++k) {
    r.params.push_back({params[static_cast<std::size_t>(k)].name, params[static_cast<std::size_t>(k)].unit,
                        sol.theta(k), stdOf(k)});
  }
  r.tilt_estimated = lin.tilt_columns;
  r.tilt_u_rad = lin.u + (lin.tilt_columns ? sol.theta(p) : 0.0);
  r.tilt_v_rad = lin.v + (lin.tilt_columns ? sol.theta(p + 1) : 0.0);
  if (lin.tilt_columns) {
    r.params.push_back({"tilt_u", "rad", r.tilt_u_rad, stdOf(p)});
    r.params.push_back({"tilt_v", "rad", r.tilt_v_rad, stdOf(p + 1)});
  }
  if (lin.mount_columns) {
    const int c = lin.mountColumn(p);
    for (int k = 0; k < 3; ++k) {
      r.params.push_back({effects::kMountParamNames[k], "rad", lin.mount(k) + sol.theta(c + k), stdOf(c + k)});
    }
  }
  if (lin.delay_column) {
    const int c = lin.delayColumn(p);
    r.params.push_back({effects::kDelayParamName, "s", lin.delay + sol.theta(c), stdOf(c)});
  }
  const auto& idx = model.paramIndex();
  const int cm = idx.column("mass");
  if (cm >= 0 && sol.theta(cm) > 0.0) {
    const double m = sol.theta(cm);
    r.params.push_back({"weight", "N", m * kStandardGravity, stdOf(cm) * kStandardGravity});
    const char* axes[3] = {"x", "y", "z"};
    for (int a = 0; a < 3; ++a) {
      const int cc = idx.column(std::string("mass_com_") + axes[a]);
      if (cc < 0) continue;
      // com = mc / m: gradient (-mc/m^2, 1/m).
      const double mc = sol.theta(cc);
      const double g0 = -mc / (m * m), g1 = 1.0 / m;
      const double var = g0 * g0 * sol.covariance(cm, cm) + 2.0 * g0 * g1 * sol.covariance(cm, cc) +
                         g1 * g1 * sol.covariance(cc, cc);
      r.params.push_back({std::string("com_") + axes[a], "m", mc / m, std::sqrt(std::max(0.0, var))});
    }
    if (model.contains("rigid_body")) {
      std::vector<int> cols = {cm, idx.column("mass_com_x"), idx.column("mass_com_y"), idx.column("mass_com_z")};
      for (const char* n : effects::kInertiaParamNames) cols.push_back(idx.column(n));
      Eigen::Matrix<double, 10, 1> pv;
      Eigen::Matrix<double, 10, 10> cv;
      for (int i = 0; i < 10; ++i) {
        pv(i) = sol.theta(cols[static_cast<std::size_t>(i)]);
        for (int j = 0; j < 10; ++j) cv(i, j) = sol.covariance(cols[static_cast<std::size_t>(i)], cols[static_cast<std::size_t>(j)]);
      }
      r.inertia = effects::inertiaAboutCom(pv, cv);
      const char* in[6] = {"i_c_xx", "i_c_yy", "i_c_zz", "i_c_xy", "i_c_xz", "i_c_yz"};
      for (int k = 0; k < 6; ++k) r.params.push_back({in[k], "kg*m^2", r.inertia->value(k), r.inertia->std(k)});
    }
  }
  const int ck = idx.column(effects::kCableStiffnessParam);
  if (ck >= 0 && std::abs(sol.theta(ck)) > 0.0) {
    const double k = sol.theta(ck);
    const char* axes[3] = {"x", "y", "z"};
    for (int a = 0; a < 3; ++a) {
      const int cu = idx.column(effects::kCableAttachParams[a]);
      const double u = sol.theta(cu);
      const double g0 = -u / (k * k), g1 = 1.0 / k;
      const double var = g0 * g0 * sol.covariance(ck, ck) + 2.0 * g0 * g1 * sol.covariance(ck, cu) +
                         g1 * g1 * sol.covariance(cu, cu);
      r.params.push_back({std::string("cable_attach_") + axes[a], "m", u / k, std::sqrt(std::max(0.0, var))});
    }
  }
  // RMS per axis.
  const auto& tests = eng.testSamples();
  for (int i : tests) r.raw_rms += eng.data().ctx[static_cast<std::size_t>(i)].wrench_S.cwiseAbs2();
  r.raw_rms = (r.raw_rms / std::max<double>(1.0, static_cast<double>(tests.size()))).cwiseSqrt();
  r.residual_rms = (sol.sse_heldout_axis / std::max(1, sol.n_heldout)).cwiseSqrt();
  r.fit_residual_rms = (sol.sse_fit_axis / std::max(1, eng.data().n_fit)).cwiseSqrt();
  r.condition_number = sol.condition_number;
  return r;
}

double totalRatio(const Vec6& rms, const Vec6& noise) {
  return std::sqrt(rms.cwiseQuotient(noise).cwiseAbs2().mean());
}

struct Fitted {
  Model model;
  Linearization lin;
  Solution sol;
};

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

/// Confounds and plausibility of candidate `cand` (solution s) against the base fit; "" if fine.
void checkConfounds(const Fitted& base, const Model& cand, const Linearization& lin, const Solution& s,
                    CandidateResult& c) {
  const auto& cn = cand.paramIndex().names();
  const int pc = cand.numParams();
  std::vector<std::string> names = cn;
  // The nonlinear columns after the linear ones, in the engine's order (tilt, mounting, delay).
  if (lin.tilt_columns) {
    names.push_back("tilt_u");
    names.push_back("tilt_v");
  }
  if (lin.mount_columns) {
    for (const char* m : effects::kMountParamNames) names.push_back(m);
  }
  if (lin.delay_column) names.push_back(effects::kDelayParamName);
  const Eigen::MatrixXd& C = s.covariance;
  auto sd = [&](int k) { return std::sqrt(std::max(0.0, C(k, k))); };
  std::vector<std::string> reasons;
  std::string motion;
  // Correlations between an added parameter and one of the base model's.
  double worst = 0.0;
  int wi = -1, wj = -1;
  for (int j = 0; j < pc; ++j) {
    if (base.model.paramIndex().column(cn[static_cast<std::size_t>(j)]) >= 0) continue;  // not added
    for (int i = 0; i < static_cast<int>(names.size()); ++i) {
      if (i == j || (i < pc && base.model.paramIndex().column(cn[static_cast<std::size_t>(i)]) < 0)) continue;
      if (!isPhysical(names[static_cast<std::size_t>(i)])) continue;  // nuisance pairs do not matter
      const double den = sd(i) * sd(j);
      if (!(den > 0.0)) continue;
      const double r = std::abs(C(i, j) / den);
      if (r > worst) {
        worst = r;
        wi = i;
        wj = j;
      }
    }
  }
  // Directions the data do not determine at all: which added and which physical parameter share one.
  for (Eigen::Index nc = 0; nc < s.null_space.cols() && worst <= 0.99; ++nc) {
    int ja = -1, ib = -1;
    double va = 0.1, vb = 0.1;
    for (int k = 0; k < static_cast<int>(names.size()) && k < s.null_space.rows(); ++k) {
      const double v = std::abs(s.null_space(k, nc));
      const bool added = k < pc && base.model.paramIndex().column(cn[static_cast<std::size_t>(k)]) < 0;
      if (added && v > va) {
        va = v;
        ja = k;
      } else if (!added && isPhysical(names[static_cast<std::size_t>(k)]) && v > vb) {
        vb = v;
        ib = k;
      }
    }
    if (ja >= 0 && ib >= 0) {
      worst = 1.0;
      wi = ib;
      wj = ja;
    }
  }
  if (worst > 0.99) {
    const auto [why, how] = explainPair(names[static_cast<std::size_t>(wj)], names[static_cast<std::size_t>(wi)]);
    reasons.push_back(names[static_cast<std::size_t>(wj)] + " and " + names[static_cast<std::size_t>(wi)] +
                      " are confounded (|correlation| " + fmt(worst, 4) + "): " + why);
    motion = how;
  }
  // Plausibility of the mass.
  const int cm = cand.paramIndex().column("mass");
  const int bm = base.model.paramIndex().column("mass");
  if (cm >= 0 && bm >= 0) {
    const double m = s.theta(cm), msd = sd(cm);
    const double mb = base.sol.theta(bm);
    const double mbsd = std::sqrt(std::max(0.0, base.sol.covariance(bm, bm)));
    // How strongly an added parameter takes over the mass's role in the candidate.
    double mass_corr = 0.0;
    for (int j = 0; j < pc; ++j) {
      if (base.model.paramIndex().column(cn[static_cast<std::size_t>(j)]) >= 0) continue;
      const double den = sd(cm) * sd(j);
      if (den > 0.0) mass_corr = std::max(mass_corr, std::abs(C(cm, j)) / den);
    }
    if (m <= 0.0) {
      reasons.push_back("it makes the mass " + fmt(m, 4) + " kg (<= 0)");
    } else if (msd > m) {
      reasons.push_back("the mass is no longer determined (" + fmt(m, 4) + " +- " + fmt(msd, 3) + " kg)");
    } else if (mbsd > 0.0 && std::abs(m - mb) > 3.0 * mbsd && mass_corr > 0.99) {
      reasons.push_back("it moves the mass from " + fmt(mb, 5) + " to " + fmt(m, 5) + " kg, " +
                        fmt(std::abs(m - mb) / mbsd, 3) + " standard errors of the simpler model's, while its "
                        "parameters take over the mass's role (|r| " + fmt(mass_corr, 4) + ")");
    }
    if (motion.empty() && !reasons.empty()) {
      std::string partner;
      for (int j = 0; j < pc; ++j) {
        if (base.model.paramIndex().column(cn[static_cast<std::size_t>(j)]) < 0) {
          const double den = sd(cm) * sd(j);
          if (den > 0.0 && (partner.empty() || std::abs(C(cm, j)) / den > 0.5)) partner = cn[static_cast<std::size_t>(j)];
        }
      }
      const auto [why, how] = explainPair(partner, "mass");
      reasons.back() += " (" + partner + " and the mass: " + why + ")";
      motion = how;
    }
  }
  // Plausibility of a newly added rigid body.
  if (cand.contains("rigid_body") && !base.model.contains("rigid_body") && cm >= 0) {
    const auto& idx = cand.paramIndex();
    std::vector<int> cols = {cm, idx.column("mass_com_x"), idx.column("mass_com_y"), idx.column("mass_com_z")};
    for (const char* n : effects::kInertiaParamNames) cols.push_back(idx.column(n));
    bool ok = true;
    for (int k : cols) ok = ok && k >= 0;
    if (ok) {
      Eigen::Matrix<double, 10, 1> pv;
      Eigen::Matrix<double, 10, 10> cv;
      for (int i = 0; i < 10; ++i) {
        pv(i) = s.theta(cols[static_cast<std::size_t>(i)]);
        for (int j = 0; j < 10; ++j) cv(i, j) = C(cols[static_cast<std::size_t>(i)], cols[static_cast<std::size_t>(j)]);
      }
      const auto in = effects::inertiaAboutCom(pv, cv);
      if (!in.valid_within_uncertainty) {
        reasons.push_back("the inertia it gives is not physical: " + in.explanation);
        if (motion.empty()) motion = "excite wrist rotations with larger angular acceleration";
      }
    }
  }
  if (reasons.empty()) return;
  c.confounded = true;
  c.significant = false;
  std::string all;
  for (const auto& r : reasons) all += (all.empty() ? "" : "; ") + r;
  c.confound = all;
  c.separating_motion = motion;
}

/// The scale uncertainty of a candidate's F statistic that the estimated noise colour brings. The
/// candidates (and the model) vary at the motion's frequencies, far below the band where phi is
/// fitted; whitened with an estimate phi^ of the true phi, noise there keeps the factor
/// r = S_true(0) / S_phi^(0) = ((1 - phi^) / (1 - phi))^2 of its variance, which the F test's
/// denominator (the whole band, where the factor averages to 1) does not see:
/// sd(ln r) = 2 sd(phi^) / (1 - phi^). Axes with their own phi: the mean of the variances (an
/// upper bound for a statistic that pools them).
double colourScaleSd(const Vec6& ar1, const Vec6& ar1_std) {
  double v = 0.0;
  for (int a = 0; a < 6; ++a) {
    if (ar1(a) > 0.0 && ar1_std(a) > 0.0) v += std::pow(2.0 * ar1_std(a) / std::max(1e-3, 1.0 - ar1(a)), 2) / 6.0;
  }
  return std::sqrt(v);
}

/// Ranks the candidates against the fitted model `base`.
/// log_scale_sd: the uncertainty of the F statistic's scale from the noise colour's estimate
/// (colourScaleSd).
std::vector<CandidateResult> rankCandidates(const Engine& eng, const Fitted& base, const std::vector<std::string>& menu,
                                            const AnalyzeOptions& options, const std::string& log_cmd,
                                            double log_scale_sd) {
  std::vector<CandidateResult> out;
  std::vector<std::string> todo;
  for (const auto& name : menu) {
    CandidateResult c;
    c.effect = name;
    try {
      auto e = effects::createEffect(name);
      c.description = e->description();
      if (base.model.contains(e->name())) continue;
    } catch (const ConfigError& err) {
      c.skipped = true;
      c.note = err.what();
      out.push_back(c);
      continue;
    }
    out.push_back(c);
  }
  const int tested = static_cast<int>(std::count_if(out.begin(), out.end(), [](const auto& c) { return !c.skipped; }));
  const double alpha_each = options.family_alpha / std::max(1, tested);
  say(options, "ranking " + std::to_string(tested) + " candidate effects against " + base.model.name());
  const int rows_ho = 6 * base.sol.n_heldout;
  // The base design and prepared contexts are shared by every candidate (designExtended).
  const detail::Engine::Design base_design = eng.design(base.model, base.lin);
  const std::vector<SampleContext> prepared = eng.prepared(base.lin);
  for (auto& c : out) {
    if (c.skipped) continue;
    say(options, "  trying " + c.effect);
    Model cand = base.model;
    try {
      cand = base.model.withEffect(c.effect);
    } catch (const ConfigError& err) {
      c.skipped = true;
      c.note = err.what();
      continue;
    }
    std::string miss = missingSignal(cand, eng.data().ctx);
    if (miss.empty() && eng.data().static_data && cand.estimatesDelay() && !base.model.estimatesDelay()) {
      miss = "static pose set: a delay shows only while the wrench changes (the time between poses is not motion)";
    }
    if (!miss.empty()) {
      c.skipped = true;
      c.note = miss;
      continue;
    }
    Linearization lin = base.lin;
    if (cand.estimatesTilt() && !lin.tilt_columns) {
      eng.tiltColumns(base.model, lin, base.sol.theta);
      lin.tilt_columns = true;
    }
    // Nonlinear candidates are screened to first order at the base solution (their Jacobian
    // columns); --explain then fits them fully (Engine::fitFully).
    if (cand.estimatesMounting() && !lin.mount_columns) {
      eng.mountColumns(base.model, lin, base.sol.theta);
      lin.mount_columns = true;
    }
    if (cand.estimatesDelay() && !lin.delay_column) {
      eng.delayColumn(base.model, lin, base.sol.theta);
      lin.delay_column = true;
    }
    // The base model's columns must keep their meaning in the candidate (nested models).
    const Solution s = lin.extraColumns() == base.lin.extraColumns()
                           ? eng.solve(eng.designExtended(base.model, base_design, cand, lin, prepared))
                           : eng.solve(eng.design(cand, lin));
    c.added_params = s.rank - base.sol.rank;
    c.residual_rms = (s.sse_heldout_axis / std::max(1, s.n_heldout)).cwiseSqrt();
    const double rr = 1.0 - s.sse_heldout / base.sol.sse_heldout;
    c.relative_reduction = std::clamp(rr, 0.0, 1.0);
    c.fit_relative_reduction = std::clamp(1.0 - s.sse_fit / base.sol.sse_fit, 0.0, 1.0);
    c.delta_bic = rows_ho * std::log(std::max(1e-300, s.sse_heldout / base.sol.sse_heldout)) +
                  std::max(0, c.added_params) * std::log(static_cast<double>(rows_ho));
    c.next_command = "ftid analyze " + log_cmd + " --model " + base.model.name() + "+" + c.effect;
    if (c.added_params <= 0) {
      c.note = "adds nothing the data can determine";
      c.p_value = 1.0;
      continue;
    }
    const double dof2 = std::max(1, s.rows_fit - s.rank);
    c.f_statistic = ((base.sol.sse_fit - s.sse_fit) / c.added_params) / (s.sse_fit / dof2);
    c.p_value = chiSquareSurvivalUncertainScale(c.f_statistic * c.added_params, c.added_params, log_scale_sd);
    c.significant = c.p_value < alpha_each && rr >= options.min_relative_reduction;
    if (c.significant) checkConfounds(base, cand, lin, s, c);
  }
  std::stable_sort(out.begin(), out.end(), [](const CandidateResult& a, const CandidateResult& b) {
    if (a.skipped != b.skipped) return !a.skipped;
    if (a.significant != b.significant) return a.significant;
    return a.delta_bic < b.delta_bic;
  });
  return out;
}

std::vector<std::string> candidateMenu(const AnalyzeOptions& options) {
  if (!options.candidates.empty()) return options.candidates;
  std::vector<std::string> menu;
  for (const auto& e : effects::registeredEffects()) {
    if (isGenericBase(e.base_name)) continue;
    menu.push_back(e.base_name);
  }
  for (const auto& g : defaultGenericMenu()) menu.push_back(g);
  return menu;
}

/// Signals the residual is correlated against: name and per-sample value.
struct SignalSeries {
  std::string name;
  std::vector<double> values;
};

std::vector<SignalSeries> diagnosticSignals(const Engine& eng, const Linearization& lin) {
  const auto& tests = eng.testSamples();
  const auto& ctx = eng.data().ctx;
  std::vector<std::string> names = {"t", "q1", "q2", "q3", "q4", "q5", "q6", "qd1", "qd2", "qd3", "qd4", "qd5", "qd6",
                                    "wx", "wy", "wz", "alx", "aly", "alz", "ax", "ay", "az"};
  if (ctx.front().has_temp) names.push_back("temp");
  std::vector<SignalSeries> out;
  for (const auto& n : names) {
    const auto src = effects::SignalSource::parse(n);
    SignalSeries s{n, {}};
    for (int i : tests) s.values.push_back(src.read(ctx[static_cast<std::size_t>(i)]));
    out.push_back(std::move(s));
  }
  const char* sq[3] = {"wx^2", "wy^2", "wz^2"};
  for (int a = 0; a < 3; ++a) {
    SignalSeries s{sq[a], {}};
    for (int i : tests) s.values.push_back(std::pow(ctx[static_cast<std::size_t>(i)].w_S(a), 2));
    out.push_back(std::move(s));
  }
  if (lin.dw_dt.cols() == eng.data().size()) {
    for (int a = 0; a < 6; ++a) {
      SignalSeries s{std::string("d") + kWrenchAxisNames[a] + "/dt (model)", {}};
      for (int i : tests) s.values.push_back(lin.dw_dt(a, i));
      out.push_back(std::move(s));
    }
  }
  return out;
}

double pearson(const std::vector<double>& x, const Eigen::RowVectorXd& y) {
  const std::size_t n = x.size();
  double mx = 0.0, my = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    mx += x[i];
    my += y(static_cast<Eigen::Index>(i));
  }
  mx /= static_cast<double>(n);
  my /= static_cast<double>(n);
  double sxy = 0.0, sxx = 0.0, syy = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double dx = x[i] - mx;
    const double dy = y(static_cast<Eigen::Index>(i)) - my;
    sxy += dx * dy;
    sxx += dx * dx;
    syy += dy * dy;
  }
  if (sxx <= 0.0 || syy <= 0.0) return 0.0;
  return sxy / std::sqrt(sxx * syy);
}

}  // namespace

std::vector<std::string> defaultGenericMenu() {
  return {"harmonic(q4,1)", "harmonic(q5,1)", "harmonic(q6,1)", "poly(t,2)", "poly(temp,2)"};
}

AnalysisResult analyze(const std::vector<SampleContext>& fit, const std::vector<SampleContext>* validate,
                       const AnalyzeOptions& options, const std::string& log_name, const std::string& validate_name) {
  const auto t_start = std::chrono::steady_clock::now();
  AnalysisResult result;
  result.log = log_name;
  result.validate_log = validate != nullptr ? validate_name : "";
  const int n_fit = static_cast<int>(fit.size());
  if (validate == nullptr && options.folds < 2) throw ConfigError("--folds must be at least 2");
  const int min_samples = validate != nullptr ? 20 : 20 * options.folds;
  if (n_fit < min_samples) {
    throw DataError(log_name + ": " + std::to_string(n_fit) + " samples are too few for the analysis (need " +
                    std::to_string(min_samples) + ")");
  }
  if (validate != nullptr && validate->size() < 8) throw DataError(validate_name + ": too few samples to validate on");

  Dataset d;
  d.ctx = fit;
  d.n_fit = n_fit;
  d.max_delay_s = options.max_delay_s;
  d.segment_start = {0};
  if (validate != nullptr) {
    d.external = true;
    d.ctx.insert(d.ctx.end(), validate->begin(), validate->end());
    d.blocks = {{0, n_fit, true}, {n_fit, static_cast<int>(d.ctx.size()), false}};
    d.segment_start.push_back(n_fit);
    if (validate->front().has_temp != fit.front().has_temp) {
      throw DataError(validate_name + ": the validation log must have the same columns (temp) as " + log_name);
    }
  } else {
    for (int f = 0; f < options.folds; ++f) {
      d.blocks.push_back({static_cast<int>(static_cast<long long>(n_fit) * f / options.folds),
                          static_cast<int>(static_cast<long long>(n_fit) * (f + 1) / options.folds), true});
    }
  }
  // The noise floor: data sheet, or detected from the fitting log's readings.
  identify::NoiseFloor nf =
      options.noise_std ? identify::dataSheetNoiseFloor(*options.noise_std) : identify::estimateNoiseFloor(fit);
  result.noise_method = identify::toString(nf.method);
  result.noise_detail = nf.detail;
  result.noise_ar1 = nf.ar1;
  result.noise_ar1_std = nf.ar1_std;
  result.noise_floor = nf.std;
  d.ar1 = nf.ar1;
  (void)identify::poseGroups(fit, &d.static_data);
  // Guard noise-free data: a floor far below the signal would make the weights meaningless.
  const double tiny = 1e-9;
  const Vec6 innovation = nf.innovationStd();
  for (int a = 0; a < 6; ++a) d.weights(a) = 1.0 / std::max(innovation(a), tiny);
  result.n_samples = n_fit;
  result.folds = validate != nullptr ? 1 : options.folds;

  Model model = Model::fromName(options.model);
  const std::string miss = missingSignal(model, d.ctx);
  if (!miss.empty()) throw DataError("model '" + model.name() + "' cannot be fitted: " + miss);
  if (d.static_data && model.estimatesDelay()) {
    // As for the candidates below, and as identify::fitModel refuses: no number for a delay.
    throw DataError("model '" + model.name() +
                    "' cannot be fitted: static pose set: a delay shows only while the wrench changes (the time "
                    "between poses is not motion); leave sensor_delay out");
  }
  const std::string log_cmd = log_name + (validate != nullptr ? " --validate " + validate_name : "");

  say(options, "noise floor: " + nf.detail);
  say(options, "fitting " + model.name() + " (" + std::to_string(model.numParams()) + " parameters) on " +
                   std::to_string(n_fit) + " samples, " +
                   (validate != nullptr ? "validating on " + validate_name
                                        : std::to_string(options.folds) + "-fold held-out blocks"));
  auto fitStart = [&](const Engine& e) {
    auto fitted = e.fitFully(model, e.initial(model));
    if (fitted.second.rank < fitted.second.p) {
      throw IdentificationError("model '" + model.name() + "': the data determine only " +
                                std::to_string(fitted.second.rank) + " of its " + std::to_string(fitted.second.p) +
                                " parameters (too little excitation for this model; see docs/analyze.md)");
    }
    return fitted;
  };
  if (!nf.observable()) {
    // One reading per pose: the cross-validated residual of the starting model is the scale
    // (provisional weights: the spread of each axis' readings).
    for (int a = 0; a < 6; ++a) {
      double m = 0.0, ss = 0.0;
      for (int i = 0; i < n_fit; ++i) m += fit[static_cast<std::size_t>(i)].wrench_S(a) / n_fit;
      for (int i = 0; i < n_fit; ++i) ss += std::pow(fit[static_cast<std::size_t>(i)].wrench_S(a) - m, 2);
      d.weights(a) = 1.0 / std::max(std::sqrt(ss / n_fit), tiny);
    }
    const Engine provisional(d);
    const auto fitted = fitStart(provisional);
    const Vec6 cv = (fitted.second.sse_heldout_axis / std::max(1, fitted.second.n_heldout)).cwiseSqrt();
    result.noise_floor = cv;
    for (int a = 0; a < 6; ++a) d.weights(a) = 1.0 / std::max(cv(a), tiny);
    result.warnings.push_back("the noise floor is not observable (one reading per pose): the scale is the "
                              "cross-validated residual of " + model.name() +
                              ", so residual/noise ratios near 1 say nothing about the model; give the "
                              "sensor's noise with --noise fx=..,..,tz=..");
  }
  auto eng = std::make_unique<Engine>(d);
  result.n_eval = static_cast<int>(eng->testSamples().size());
  auto [lin, sol] = fitStart(*eng);

  // The residual of the first fit settles the noise colour (dense data) and shows the glitches
  // (isolated samples far outside its robust spread); both change the weights: re-fit.
  {
    const int n_all = eng->data().size();
    const Mat6X pred = eng->predict(model, lin, sol.theta, false);
    Mat6X res(6, n_all);
    for (int i = 0; i < n_all; ++i) res.col(i) = eng->data().ctx[static_cast<std::size_t>(i)].wrench_S - pred.col(i);
    bool changed = false;
    d = eng->data();
    if (!options.noise_std) {
      const Vec6 before = nf.ar1;
      identify::refineNoiseFloor(nf, res.leftCols(n_fit), fit);
      if (nf.observable() && (nf.method == identify::NoiseMethod::kWhite || nf.method == identify::NoiseMethod::kColoured)) {
        result.noise_method = identify::toString(nf.method);
        result.noise_detail = nf.detail;
        result.noise_ar1 = nf.ar1;
        result.noise_ar1_std = nf.ar1_std;
        result.noise_floor = nf.std;
        d.ar1 = nf.ar1;
        const Vec6 inn = nf.innovationStd();
        for (int a = 0; a < 6; ++a) d.weights(a) = 1.0 / std::max(inn(a), tiny);
        changed = changed || before != nf.ar1;
      }
    }
    if (options.glitch_threshold > 0.0) {
      bool is_static = false;
      (void)identify::poseGroups(fit, &is_static);
      const auto flagged = identify::detectOutliers(res, !is_static, options.glitch_threshold, d.segment_start);
      if (!flagged.samples.empty()) {
        d.excluded.assign(static_cast<std::size_t>(n_all), 0);
        for (std::size_t k = 0; k < flagged.samples.size(); ++k) {
          const int i = flagged.samples[k];
          d.excluded[static_cast<std::size_t>(i)] = 1;
          result.outliers.times.push_back(d.ctx[static_cast<std::size_t>(i)].t);
          result.outliers.axes.push_back(flagged.axes[k]);
        }
        result.outliers.count = static_cast<int>(flagged.samples.size());
        say(options, std::to_string(result.outliers.count) + " glitch" + (result.outliers.count == 1 ? "" : "es") +
                         " (isolated samples beyond " + fmt(options.glitch_threshold, 3) +
                         " robust standard deviations) left out");
        changed = true;
      }
    }
    if (changed) {
      say(options, "re-fitting " + model.name() + " (" + nf.detail + ")");
      eng = std::make_unique<Engine>(d);
      std::tie(lin, sol) = fitStart(*eng);
    }
  }
  const Engine& engine = *eng;
  Fitted base{model, lin, sol};
  result.report = makeReport(engine, model, lin, sol);

  // Time series of the evaluated data.
  const auto& tests = engine.testSamples();
  result.measured.resize(6, static_cast<Eigen::Index>(tests.size()));
  for (std::size_t k = 0; k < tests.size(); ++k) {
    const auto& c = engine.data().ctx[static_cast<std::size_t>(tests[k])];
    result.t.push_back(c.t);
    result.measured.col(static_cast<Eigen::Index>(k)) = c.wrench_S;
  }
  result.predicted = result.measured - sol.heldout_residual;
  // Statistics of the residual without the glitches (the plots keep them).
  Mat6X stat_res = sol.heldout_residual;
  for (std::size_t k = 0; k < tests.size(); ++k) {
    if (engine.excluded(tests[k])) stat_res.col(static_cast<Eigen::Index>(k)).setZero();
  }

  // Where it fails: windows.
  Vec6 w;
  for (int a = 0; a < 6; ++a) w(a) = 1.0 / std::max(result.noise_floor(a), 1e-9);
  const int n_eval = result.n_eval;
  const int nw = std::max(1, std::min(options.window_count, n_eval / 4));
  std::vector<FailWindow> windows;
  for (int k = 0; k < nw; ++k) {
    const int a = static_cast<int>(static_cast<long long>(n_eval) * k / nw);
    const int b = static_cast<int>(static_cast<long long>(n_eval) * (k + 1) / nw);
    Vec6 ss = Vec6::Zero();
    for (int i = a; i < b; ++i) ss += stat_res.col(i).cwiseProduct(w).cwiseAbs2();
    ss /= std::max(1, b - a);
    FailWindow fw;
    fw.t_start = result.t[static_cast<std::size_t>(a)];
    fw.t_end = result.t[static_cast<std::size_t>(b - 1)];
    fw.ratio = std::sqrt(ss.mean());
    ss.maxCoeff(&fw.worst_axis);
    result.window_ratio.push_back(fw.ratio);
    windows.push_back(fw);
  }
  result.window_length_s = n_eval > 1 ? (result.t.back() - result.t.front()) / nw : 0.0;
  std::sort(windows.begin(), windows.end(), [](const FailWindow& x, const FailWindow& y) { return x.ratio > y.ratio; });
  windows.resize(std::min<std::size_t>(windows.size(), static_cast<std::size_t>(std::max(0, options.top_windows))));
  result.windows = windows;

  // ... and with what: correlations of the held-out residual with measured signals.
  const auto signals = diagnosticSignals(engine, lin);
  std::vector<SignalCorrelation> corr;
  const double thresh = 5.0 / std::sqrt(std::max(1.0, static_cast<double>(n_eval)));
  for (const auto& s : signals) {
    for (int a = 0; a < 6; ++a) {
      const double r = pearson(s.values, stat_res.row(a));
      corr.push_back({s.name, a, r, std::abs(r) > thresh});
    }
  }
  std::sort(corr.begin(), corr.end(), [](const auto& x, const auto& y) { return std::abs(x.r) > std::abs(y.r); });
  corr.resize(std::min<std::size_t>(corr.size(), static_cast<std::size_t>(std::max(1, options.top_correlations))));
  result.correlations = corr;
  if (!corr.empty()) {
    for (const auto& s : signals) {
      if (s.name == corr.front().signal) result.top_signal = s.values;
    }
  }

  // Which effect is missing.
  const auto menu = candidateMenu(options);
  const double scale_sd = colourScaleSd(result.noise_ar1, result.noise_ar1_std);
  result.candidates = rankCandidates(engine, base, menu, options, log_cmd, scale_sd);

  if (options.explain) {
    ExplainStep s0;
    s0.model = model.name();
    s0.residual_rms = result.report.residual_rms;
    s0.total_ratio = totalRatio(s0.residual_rms, result.noise_floor);
    result.steps.push_back(s0);
    Fitted cur = base;
    std::vector<CandidateResult> ranking = result.candidates;
    for (int step = 0; step < options.max_explain_steps; ++step) {
      if (ranking.empty() || !ranking.front().significant) break;
      const CandidateResult best = ranking.front();
      Model next = cur.model.withEffect(best.effect);
      say(options, "explain step " + std::to_string(step + 1) + ": adding " + best.effect + " (held-out residual -" +
                       fmt(100.0 * best.relative_reduction, 3) + "%)");
      auto [nlin, nsol] = engine.fitFully(next, cur.lin);
      cur = Fitted{next, nlin, nsol};
      ExplainStep st;
      st.model = next.name();
      st.added = best.effect;
      st.residual_rms = (nsol.sse_heldout_axis / std::max(1, nsol.n_heldout)).cwiseSqrt();
      st.total_ratio = totalRatio(st.residual_rms, result.noise_floor);
      st.p_value = best.p_value;
      result.steps.push_back(st);
      ranking = rankCandidates(engine, cur, menu, options, log_cmd, scale_sd);
    }
    result.final_report = makeReport(engine, cur.model, cur.lin, cur.sol);
    result.final_residual = cur.sol.heldout_residual;
  }
  // What is left: the last model's held-out residual against the noise floor.
  if (nf.observable()) {
    const ModelReport& last = result.final_report ? *result.final_report : result.report;
    std::string above;
    double worst = 0.0;
    for (int a = 0; a < 6; ++a) {
      const double ratio = last.residual_rms(a) / std::max(result.noise_floor(a), 1e-12);
      worst = std::max(worst, ratio);
      if (ratio > 1.2) above += std::string(above.empty() ? "" : ", ") + kWrenchAxisNames[a] + " " + fmt(ratio, 3) + "x";
    }
    if (!above.empty()) {
      result.warnings.push_back("the held-out residual of " + last.model + " is above the noise floor (" + above +
                                "): the model misses something" +
                                (options.explain ? " that no candidate explains" : "; try --explain"));
    }
  }
  for (const auto& c : result.candidates) {
    if (c.confounded) {
      result.warnings.push_back(c.effect + " is not recommended: " + c.confound + "; to separate them: " +
                                c.separating_motion);
    }
  }
  if (result.outliers.count > 0) {
    result.warnings.push_back(std::to_string(result.outliers.count) + " glitch" +
                              (result.outliers.count == 1 ? " was" : "es were") +
                              " left out of every fit (isolated spikes; see outliers)");
  }
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return result;
}

}  // namespace ftid::lab
