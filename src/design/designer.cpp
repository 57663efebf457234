// NLopt excitation-trajectory designer: the sequence of designExcitation (see designer.hpp and
// docs/design.md), the shortest-duration search and the target parsing. Its units:
//   design_problem.cpp    the optimisation problem: sampled motion, KS-aggregated constraints,
//                         the objective, scaling into the feasible set, budgets, progress
//   design_stages.cpp     the NLopt driving: random starts, global stage, local refinement
//   design_baselines.cpp  the random and static six-pose baselines
//   this file             option checks, the dense re-check and repair by amplitude scaling (the
//                         result passes checkTrajectory at a step resolving the highest harmonic
//                         with 200 samples per period, or is rejected), the final figures at the
//                         servo rate, and the design record written to the trajectory file
#include "ftid/design/designer.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ostream>
#include <random>
#include <sstream>
#include <stdexcept>

#include "design_problem.hpp"
#include "design_stages.hpp"
#include "ftid/design/excitation_metric.hpp"
#include "ftid/design/parametrization.hpp"
#include "ftid/effects/model.hpp"

namespace ftid::design {

namespace {

using internal::fmt;
using internal::kInf;
using internal::Problem;

std::string joinInts(const std::vector<int>& v) {
  std::string s;
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? "," : "") + std::to_string(v[i]);
  return s;
}

/// Throws ConfigError for options no design can satisfy: non-positive duration, rate or budget,
/// unknown algorithms, or a start pose q0 that already violates the constraints.
void checkOptions(const DesignOptions& opt, const model::RobotKinematics& kinematics) {
  if (!(opt.duration_s > 0.0)) throw ConfigError("--duration must be positive");
  if (opt.periods < 1) throw ConfigError("periods must be >= 1");
  if (!(opt.servo_rate_hz > 0.0)) throw ConfigError("--rate must be positive");
  if (!(opt.time_budget_s > 0.0)) throw ConfigError("--time-budget must be positive");
  internal::validateAlgorithms(opt);
  if (opt.objective == Objective::kLimits && opt.limit_targets.empty())
    throw ConfigError("the limits objective needs accuracy limits (--limits)");
  if (opt.objective == Objective::kLimits) checkTargetNames(opt, kinematics, opt.limit_targets);
  if (opt.targets_with_imu && !(opt.imu_acc_std > 0.0 && opt.imu_gyro_std > 0.0))
    throw ConfigError("targets with the IMU need the IMU's noise (--imu-noise acc=...,gyro=...)");

  // The start pose itself must satisfy every constraint (else no trajectory can).
  Coefficients zero{};
  const trajectory::FourierTrajectory rest(
      opt.q0, static_cast<double>(opt.periods) / opt.duration_s, std::max(1, opt.harmonics),
      opt.duration_s, zero, zero);
  const CheckReport r = checkTrajectory(rest, kinematics, opt.constraints, opt.duration_s);
  if (!r.ok()) {
    std::string why;
    for (const auto& v : r.violations()) why += "\n  " + v;
    throw ConfigError("the start pose q0 already violates the constraints:" + why);
  }
}

/// The dense, independent re-check of x (checkTrajectory at step dt); a violating x is scaled back
/// by amplitude bisection until the dense check passes (a warning says so), else DesignError.
/// The step dt resolves the highest harmonic with at least 200 samples per period (at most 1 ms).
void recheckAndRepair(const DesignOptions& opt, const model::RobotKinematics& kinematics,
                      const Problem& p, std::vector<double>& x, DesignResult& res) {
  const double w_max = 2.0 * 3.141592653589793 * p.param().baseFrequency() * opt.harmonics;
  const double dt = std::min(1e-3, 2.0 * 3.141592653589793 / w_max / 200.0);
  trajectory::FourierTrajectory traj = p.param().trajectory(x.data());
  res.check = checkTrajectory(traj, kinematics, opt.constraints, dt);
  if (!res.check.ok()) {
    std::string what;
    for (const auto& v : res.check.violations()) what += "; " + v;
    res.warnings.push_back("NLopt's best point failed the dense re-check (" + what.substr(2) +
                           "); its amplitude was scaled back until the dense check passes");
    double lo = 0.0, hi = 1.0;
    for (int it = 0; it < 30; ++it) {
      const double mid = 0.5 * (lo + hi);
      std::vector<double> y(x);
      for (double& v : y) v *= mid;
      (checkTrajectory(p.param().trajectory(y.data()), kinematics, opt.constraints, dt).ok() ? lo
                                                                                             : hi) =
          mid;
    }
    for (double& v : x) v *= lo;
    traj = p.param().trajectory(x.data());
    res.check = checkTrajectory(traj, kinematics, opt.constraints, dt);
    res.repaired = true;
    if (!res.check.ok()) {
      std::string why;
      for (const auto& v : res.check.violations()) why += "\n  " + v;
      throw DesignError(
          "the designed trajectory violates its constraints even after scaling back:" + why);
    }
  }
}

/// A warning when the design moves joint 1, 2 or 3 and keep-out spheres are configured: those
/// spheres are fixed in B (design.yaml, placed for q0) while these joints move the arm's links, so
/// the check is only as good as the links' displacement is small against the clearances. Names each
/// such joint's largest excursion from q0 (from the dense re-check).
void warnMovingLinks(const DesignOptions& opt, DesignResult& res) {
  if (opt.constraints.keep_out.empty()) return;
  std::string moved;
  for (int j : opt.joints) {
    if (j > 3) continue;
    const std::string joint = "joint " + std::to_string(j) + " position ";
    double excursion = 0.0;
    for (const auto& m : res.check.margins) {
      if (m.name.compare(0, joint.size(), joint) == 0) excursion = std::max(excursion, std::abs(m.worst - opt.q0[j - 1]));
    }
    moved += (moved.empty() ? "" : ", ") + std::string("joint ") + std::to_string(j) + " by up to " + fmt(excursion) + " rad";
  }
  if (moved.empty()) return;
  res.warnings.push_back("the design moves " + moved +
                         " from q0; the keep-out spheres are fixed in the base frame (placed for q0) while these "
                         "joints move the arm's links, so check the clearances on the robot at reduced speed first");
}

/// The figures at the servo rate (the samples the identification will see): condition number,
/// D-optimality, predicted standard errors (also with the IMU when its noise is given). Throws
/// DesignError when the condition number exceeds max_condition. Returns the number of samples.
int finalFigures(const DesignOptions& opt, Problem& p, const std::vector<double>& x,
                 DesignResult& res) {
  const int Ks = static_cast<int>(std::lround(opt.duration_s * opt.servo_rate_hz));
  RestToRestParametrization& prm = p.param();
  prm.prepareSampling(std::max(Ks, 2));
  SampledMotion mo;
  prm.sample(x.data(), mo);
  const Eigen::MatrixXd info = p.metric().information(mo, 1.0);
  res.condition_number = ExcitationMetric::conditionNumber(info);
  res.d_optimality = ExcitationMetric::dOptimality(info, static_cast<double>(Ks));
  res.predicted_std = p.metric().predictedStd(info);
  if (opt.imu_acc_std > 0.0 && opt.imu_gyro_std > 0.0) {
    res.predicted_std_imu =
        p.metric().predictedStd(p.metric().informationWithImu(mo, info, opt.imu_acc_std, opt.imu_gyro_std));
  }
  if (!(res.condition_number <= opt.max_condition)) {
    std::string weak;
    for (const auto& wc : p.metric().weakColumns(info, 1e-6))
      weak += (weak.empty() ? "" : ", ") + wc;
    throw DesignError(
        "cannot excite model '" + opt.model + "' within the limits in " + fmt(opt.duration_s) +
        " s: the best feasible trajectory has condition number " + fmt(res.condition_number) +
        " (accepted up to " + fmt(opt.max_condition) + ")" +
        (weak.empty() ? "" : "; poorly determined: " + weak) +
        ". Relax the velocity/acceleration/position limits or the workspace, excite more joints, "
        "or lengthen the duration.");
  }
  return Ks;
}

/// The trajectory file's record: coefficients, limits, and the design's options and figures.
void fillRecord(const DesignOptions& opt, const Problem& p, const std::vector<double>& x, int Ks,
                DesignResult& res) {
  const RestToRestParametrization& prm = p.param();
  auto& f = res.file;
  f.q0 = opt.q0;
  f.base_frequency_hz = prm.baseFrequency();
  f.harmonics = opt.harmonics;
  f.duration_s = opt.duration_s;
  f.joints = opt.joints;
  prm.coefficients(x.data(), f.a, f.b);
  f.servo_rate_hz = opt.servo_rate_hz;
  f.robot = opt.robot_path;
  f.constraints = opt.constraints;
  char seed[32];
  std::snprintf(seed, sizeof seed, "%llu", static_cast<unsigned long long>(opt.seed));
  f.design = {
      {"model", effects::Model::fromName(opt.model).name()},
      {"objective", objectiveName(opt.objective)},
      {"seed", seed},
      {"global_algorithm", opt.global_algorithm},
      {"local_algorithm", opt.local_algorithm},
      {"global_evals", std::to_string(res.global_evals)},
      {"local_evals", std::to_string(res.local_evals)},
      {"time_budget_s", fmt(opt.time_budget_s)},
      {"design_samples", std::to_string(p.param().numSamples())},
      {"constraint_margin", fmt(opt.constraint_margin)},
      {"joints", joinInts(opt.joints)},
      {"periods", std::to_string(opt.periods)},
      {"noise", fmt(opt.noise_sigma[0]) + "," + fmt(opt.noise_sigma[1]) + "," +
                    fmt(opt.noise_sigma[2]) + "," + fmt(opt.noise_sigma[3]) + "," +
                    fmt(opt.noise_sigma[4]) + "," + fmt(opt.noise_sigma[5])},
      {"global_result", res.global_result},
      {"local_result", res.local_result},
      {"repaired", res.repaired ? "true" : "false"}};
  // The `reproduce` command line is the CLI's to write (apps/ftid/cmd_design.cpp): it knows its flags.
  f.metrics = {{"condition_number", res.condition_number},
               {"d_optimality", res.d_optimality},
               {"samples", static_cast<double>(Ks)},
               {"elapsed_s", res.elapsed_s}};
  if (res.baselines.random_count > 0) {
    f.metrics["random_median_condition_number"] = res.baselines.random_median_condition;
    f.metrics["ratio_random_over_designed"] =
        res.baselines.random_median_condition / res.condition_number;
  }
  if (res.baselines.static_condition > 0.0 && std::isfinite(res.baselines.static_condition)) {
    f.metrics["static_six_pose_condition_number"] = res.baselines.static_condition;
    f.metrics["ratio_static_over_designed"] = res.baselines.static_condition / res.condition_number;
  }
  double min_margin = kInf;
  for (const auto& m : res.check.margins) {
    if (m.unit == "m") min_margin = std::min(min_margin, m.margin);
  }
  if (std::isfinite(min_margin)) f.metrics["min_workspace_clearance_m"] = min_margin;
  f.predicted_std = res.predicted_std;
}

}  // namespace

DesignResult designExcitation(const DesignOptions& opt, const model::RobotKinematics& kinematics) {
  checkOptions(opt, kinematics);
  Problem p(opt, kinematics);
  DesignResult res;
  std::mt19937_64 rng(opt.seed);
  const double budget = opt.time_budget_s;

  // ---- starting points: random feasible trajectories (seeded)
  p.setStage("start", budget, 0);
  const std::vector<internal::Start> starts = internal::rankedStarts(p, rng, 32);

  // ---- global stage, then local refinement from the best feasible point
  res.global_result = internal::runGlobalStage(opt, p, starts);
  res.global_evals = p.evals();
  res.local_result = internal::runLocalStage(opt, p);
  res.local_evals = p.evals() - res.global_evals;
  p.printProgress(true);

  if (p.bestX().empty()) {
    throw DesignError("no feasible trajectory was found within the time budget (" + fmt(budget) +
                      " s): increase --time-budget or relax the limits");
  }

  // ---- dense, independent re-check; repair by amplitude scaling if NLopt's point violates it
  std::vector<double> x = p.bestX();
  recheckAndRepair(opt, kinematics, p, x, res);

  // ---- final figures at the servo rate (the samples the identification will see)
  const int Ks = finalFigures(opt, p, x, res);
  warnMovingLinks(opt, res);

  // ---- baselines
  p.param().prepareSampling(std::max(120, 30 * opt.harmonics * opt.periods));
  if (opt.baseline_seeds > 0 || opt.static_baseline) {
    p.setStage("baselines", kInf, 0);
    res.baselines = internal::computeBaselines(opt, p, kinematics);
  }
  res.elapsed_s = p.elapsed();

  // ---- output record
  fillRecord(opt, p, x, Ks, res);
  return res;
}

const char* objectiveName(Objective o) {
  switch (o) {
    case Objective::kCondition:
      return "cond";
    case Objective::kDOptimality:
      return "dopt";
    case Objective::kLimits:
      return "limits";
  }
  return "?";
}

std::map<std::string, double> parseTargets(const std::string& text,
                                           const std::map<std::string, double>& nominal) {
  std::map<std::string, double> out;
  std::stringstream ss(text);
  std::string item;
  const auto nom = nominal.empty() ? defaultNominalParameters() : nominal;
  while (std::getline(ss, item, ',')) {
    const auto eq = item.find('=');
    if (eq == std::string::npos)
      throw ConfigError("--target-std: expected name=value, got '" + item + "'");
    const std::string key = item.substr(0, eq);
    std::string val = item.substr(eq + 1);
    const bool relative = !val.empty() && val.back() == '%';
    if (relative) val.pop_back();
    double v = 0.0;
    try {
      std::size_t used = 0;
      v = std::stod(val, &used);
      if (used != val.size()) throw std::invalid_argument("trailing");
    } catch (const std::exception&) {
      throw ConfigError("--target-std: '" + item + "': value is not a number");
    }
    if (!(v > 0.0)) throw ConfigError("--target-std: '" + item + "': must be positive");
    std::vector<std::string> keys;
    if (key == "com" || key == "f0" || key == "t0") {
      for (const char* a : {"_x", "_y", "_z"}) keys.push_back(key + a);
    } else if (key == "tilt") {
      keys = {"tilt_u", "tilt_v"};
    } else {
      keys = {key};
    }
    for (const auto& k : keys) {
      double target = v;
      if (relative) {
        auto it = nom.find(k);
        if (it == nom.end() || it->second == 0.0) {
          throw ConfigError("--target-std: '" + item +
                            "': a relative target needs a non-zero nominal " + k);
        }
        target = std::abs(it->second) * v / 100.0;
      }
      out[k] = target;
    }
  }
  if (out.empty()) throw ConfigError("--target-std: no targets given");
  return out;
}

void checkTargetNames(const DesignOptions& options, const model::RobotKinematics& kinematics,
                      const std::map<std::string, double>& targets) {
  const ExcitationMetric metric(effects::Model::fromName(options.model), kinematics, options.constraints,
                                options.nominal.empty() ? defaultNominalParameters() : options.nominal,
                                options.noise_sigma);
  // The keys predictedStd gives for this model (the identity stands for any regular information).
  const auto known = metric.predictedStd(Eigen::MatrixXd::Identity(metric.numColumns(), metric.numColumns()));
  std::string unknown;
  for (const auto& target : targets) {
    if (known.count(target.first) == 0) unknown += (unknown.empty() ? "" : ", ") + target.first;
  }
  if (unknown.empty()) return;
  std::string names;
  for (const auto& k : known) names += (names.empty() ? "" : ", ") + k.first;
  throw ConfigError("model '" + options.model + "' has no predicted standard error for " + unknown +
                    " (it predicts: " + names + ")");
}

std::vector<std::string> unmetTargets(const std::map<std::string, double>& predicted,
                                      const std::map<std::string, double>& targets) {
  std::vector<std::string> out;
  for (const auto& [k, v] : targets) {
    auto it = predicted.find(k);
    if (it == predicted.end()) {
      out.push_back(k + " (not a parameter of this model)");
    } else if (!(it->second <= v)) {
      out.push_back(k + " " + fmt(it->second) + " > " + fmt(v));
    }
  }
  return out;
}

DurationSearchResult findShortestDuration(const DesignOptions& options,
                                          const model::RobotKinematics& kinematics,
                                          const std::map<std::string, double>& targets,
                                          double step_s, double min_duration_s,
                                          double max_duration_s) {
  DurationSearchResult out;
  if (!(step_s > 0.0)) throw ConfigError("duration search step must be positive");
  checkTargetNames(options, kinematics, targets);
  auto snap = [&](double d) { return std::max(min_duration_s, std::round(d / step_s) * step_s); };
  // Each design gets an equal share; about 8 designs are typical (doubling + bisection).
  const double share = options.time_budget_s / 8.0;
  auto attempt = [&](double d) -> bool {
    for (const auto& t : out.trials) {
      if (std::abs(t.duration_s - d) < 1e-9) return t.met;
    }
    DesignOptions o = options;
    if (o.objective == Objective::kLimits && o.limit_targets.empty()) o.limit_targets = targets;
    o.duration_s = d;
    o.periods = 1;
    o.time_budget_s = share;
    DurationTrial trial;
    trial.duration_s = d;
    try {
      DesignResult r = designExcitation(o, kinematics);
      trial.condition_number = r.condition_number;
      trial.predicted_std = r.predicted_std;
      trial.predicted_std_imu = r.predicted_std_imu;
      trial.met = unmetTargets(options.targets_with_imu ? r.predicted_std_imu : r.predicted_std, targets).empty();
      if (trial.met && (!out.found || d < out.best.file.duration_s)) {
        out.best = std::move(r);
        out.found = true;
      }
    } catch (const DesignError&) {
      trial.met = false;  // too short to excite the model within the limits
    }
    if (options.progress != nullptr) {
      *options.progress << "design: duration " << fmt(d) << " s -> "
                        << (trial.met ? "meets" : "misses") << " the targets (cond "
                        << fmt(trial.condition_number) << ")\n";
    }
    out.trials.push_back(trial);
    return trial.met;
  };
  double lo = 0.0;  // longest known failing duration
  double hi = snap(options.duration_s);
  while (!attempt(hi)) {
    lo = hi;
    if (hi >= max_duration_s) return out;
    hi = std::min(max_duration_s, snap(hi * 2.0));
  }
  if (lo == 0.0) {
    // Met at the first try: look below, down to min_duration_s.
    double d = snap(hi / 2.0);
    while (d >= min_duration_s && d < hi && attempt(d)) {
      hi = d;
      if (d <= min_duration_s) break;
      d = snap(d / 2.0);
    }
    lo = (d < hi && d >= min_duration_s) ? d : std::max(0.0, hi - step_s);
    if (hi <= min_duration_s) lo = hi;
  }
  while (hi - lo > step_s + 1e-9) {
    const double mid = snap(0.5 * (lo + hi));
    if (mid <= lo || mid >= hi) break;
    (attempt(mid) ? hi : lo) = mid;
  }
  return out;
}

}  // namespace ftid::design
