// `ftid design`: NLopt excitation-trajectory designer (docs/design.md). Parses arguments and calls
// ftid::design; writes traj.yaml and traj.csv beside it.
#include <sys/stat.h>

#include <cmath>
#include <cstdio>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "command.hpp"
#include "ftid/fileio/atomic_file.hpp"
#include "ftid/fileio/yaml_emit.hpp"
#include "ftid/common/default_files.hpp"
#include "ftid/design/designer.hpp"
#include "ftid/design/excitation_metric.hpp"
#include "ftid/effects/model.hpp"
#include "ftid/model/kinematics.hpp"
#include "ftid/trajectory/trajectory_io.hpp"

namespace {

const char* kUsage =
    "usage: ftid design [options]\n"
    "\n"
    "Designs a rest-to-rest Fourier excitation trajectory (paper Eq. 47-49 about q0) that makes "
    "the\n"
    "model's parameters as well determined as possible within the joint limits and the workspace,\n"
    "with NLopt (global stage + local refinement). Writes OUT (YAML: coefficients and everything "
    "to\n"
    "reproduce it) and OUT with .csv (t, q1..q6, qd1..qd6, qdd1..qdd6 at the servo rate).\n"
    "\n"
    "  --model M            model whose regressor is excited (default paper)\n"
    "  --robot URDF         robot (default: the shipped ur10.urdf, docs/operations.md)\n"
    "  --config FILE        limits, floor, keep-out spheres, tool spheres (default: the "
    "shipped\n"
    "                       design.yaml, docs/operations.md)\n"
    "  --joints 4,5,6|all   excited joints, 1-based (default 4,5,6)\n"
    "  --duration S         trajectory duration [s] (default 10)\n"
    "  --periods N          base periods in the duration (default 1; base frequency = N / S)\n"
    "  --harmonics N        Fourier harmonics per joint, >= 2 (default 5)\n"
    "  --rate HZ            servo rate of the CSV: 125 (CB3) or 500 (e-Series) (default 125)\n"
    "  --q0 a,b,c,d,e,f     start/end pose [rad] (default 0,-1.5708,1.5708,-1.5708,-1.5708,0)\n"
    "  --objective cond|dopt|limits  what the optimiser minimises: the condition number, D-optimality,\n"
    "                       or the worst ratio of a predicted standard error to its target (needs\n"
    "                       --limits or --target-std; with --imu-noise and --limits, the prediction\n"
    "                       with the IMU). Default: limits when limits or targets are given, else cond\n"
    "  --seed N             random seed (default 1); same seed and budgets -> same trajectory\n"
    "  --time-budget S      wall-clock budget for the optimisation [s] (default 30)\n"
    "  --global multistart|isres|none   global stage (default multistart)\n"
    "  --local cobyla|slsqp|auglag|none local refinement (default cobyla)\n"
    "  --global-evals N, --local-evals N  evaluation budgets (default: time budget only); with\n"
    "                       these the result does not depend on the machine's speed\n"
    "  --noise fx=..,fy=..,fz=..,tx=..,ty=..,tz=..  sensor noise [N, Nm] for predicted standard\n"
    "                       errors (default 0.05 N, 0.01 Nm)\n"
    "  --nominal mass=..,com_x=..   nominal payload where the metric needs values (default: "
    "paper)\n"
    "  --target-std mass=0.005,com=0.001  search the shortest duration (one period, 0.5 s steps)\n"
    "                       whose predicted standard errors meet the targets (SI; '0.5%' "
    "relative)\n"
    "  --limits mass=0.5%,com=1mm,tilt=0.1deg  search the shortest duration whose predicted worst\n"
    "                       case over noise, 3 predicted standard errors, is within each limit\n"
    "                       (keys as --target-std; units %, mm, cm, m, deg, rad, g, kg, N, Nm;\n"
    "                       docs/design.md \"Limits\")\n"
    "  --fixed-duration     with --limits or --target-std: design at --duration only (no search)\n"
    "                       and say whether it meets them (written either way, exit 0)\n"
    "  --imu-noise acc=A,gyro=W  the sensor's IMU noise [m/s^2, rad/s] (e.g. acc=0.01,gyro=0.002):\n"
    "                       also predict with the IMU's tilt fused (ftid identify --imu on); with\n"
    "                       --limits the search runs for the wrench alone and with the IMU, prints\n"
    "                       both shortest durations and writes the one with the IMU (the\n"
    "                       wrench-alone one if only that meets the limits)\n"
    "  --max-cond X         reject designs whose condition number exceeds X (default 1e4)\n"
    "  --baseline-seeds N   random trajectories for the baseline (default 50; 0 to skip)\n"
    "  --out FILE           output YAML (default traj.yaml)\n"
    "  --quiet              no progress lines\n"
    "\n"
    "Exit: 0 designed and verified, 1 no acceptable trajectory (reason printed), 2 usage error.";

std::map<std::string, double> parseNominal(const std::string& text) {
  std::map<std::string, double> out = ftid::design::defaultNominalParameters();
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    const auto eq = item.find('=');
    if (eq == std::string::npos)
      throw ftid::cli::UsageError("--nominal: expected name=value, got '" + item + "'");
    out[item.substr(0, eq)] = ftid::cli::parseReal(item.substr(eq + 1), "--nominal " + item.substr(0, eq));
  }
  return out;
}

/// The command line that designs the same trajectory again: this run's options, with the evaluation
/// budgets pinned to the counts used so the result does not depend on the machine's speed, and the
/// noise, nominal payload and limits or targets it was designed for (target_arguments, from
/// targetArguments).
std::string reproduceCommand(const ftid::design::DesignOptions& o, const ftid::design::DesignResult& r,
                             const std::string& target_arguments) {
  std::ostringstream s;
  s << "ftid design --model " << o.model << " --joints ";
  for (std::size_t i = 0; i < o.joints.size(); ++i) s << (i ? "," : "") << o.joints[i];
  // The design's own periods: the duration search designs one base period whatever --periods says.
  const long periods = std::lround(r.file.base_frequency_hz * r.file.duration_s);
  s << " --duration " << ftid::yamlNumberText(r.file.duration_s) << " --periods " << periods << " --harmonics "
    << o.harmonics << " --rate " << ftid::yamlNumberText(o.servo_rate_hz) << " --objective "
    << ftid::design::objectiveName(o.objective) << " --seed " << o.seed
    << " --global " << o.global_algorithm << " --local " << o.local_algorithm << " --global-evals "
    << r.global_evals << " --local-evals " << r.local_evals << target_arguments << " (same robot, config and q0)";
  return s.str();
}

void printStd(const std::map<std::string, double>& s,
              const std::map<std::string, double>& targets) {
  for (const auto& [k, v] : s) {
    std::printf("  %-14s %12.4g", k.c_str(), v);
    auto it = targets.find(k);
    if (it != targets.end())
      std::printf("   target %.4g %s", it->second, v <= it->second ? "met" : "MISSED");
    std::printf("\n");
  }
}

void parseImuNoise(const std::string& text, ftid::design::DesignOptions* o) {
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    const auto eq = item.find('=');
    const std::string key = eq == std::string::npos ? item : item.substr(0, eq);
    if (eq == std::string::npos || (key != "acc" && key != "gyro")) {
      throw ftid::cli::UsageError("--imu-noise: expected acc=A,gyro=W, got '" + item + "'");
    }
    const double v = ftid::cli::parseReal(item.substr(eq + 1), "--imu-noise " + key);
    if (!(v > 0.0)) throw ftid::cli::UsageError("--imu-noise " + key + ": must be positive");
    (key == "acc" ? o->imu_acc_std : o->imu_gyro_std) = v;
  }
  if (!(o->imu_acc_std > 0.0) || !(o->imu_gyro_std > 0.0)) {
    throw ftid::cli::UsageError("--imu-noise: give both acc=A and gyro=W");
  }
}

/// The command line's values that are not DesignOptions fields (those are bound directly).
struct DesignArgs {
  std::string config, joints = "4,5,6", objective, noise, nominal, target, out = "traj.yaml";
  std::vector<double> q0;
  std::string limits, imu_noise;
  bool quiet = false;
  bool fixed_duration = false;
};

/// --limits: the shortest duration for the wrench alone and, with --imu-noise, with the IMU.
ftid::design::DesignResult searchLimits(ftid::design::DesignOptions o, const ftid::model::RobotKinematics& kin,
                                        const std::map<std::string, double>& targets, const std::string& limits,
                                        bool* written_with_imu) {
  using namespace ftid;
  const bool imu = o.imu_acc_std > 0.0;
  std::cerr << "design: searching the shortest duration whose predicted worst case (3 standard errors) meets "
            << limits << (imu ? ", for the wrench alone and with the IMU" : "") << " (budget " << o.time_budget_s
            << " s per search)\n";
  design::DesignResult chosen;
  bool found_any = false;
  for (const bool with_imu : imu ? std::vector<bool>{false, true} : std::vector<bool>{false}) {
    o.targets_with_imu = with_imu;
    design::DurationSearchResult s = design::findShortestDuration(o, kin, targets);
    std::printf("duration search, %s (one base period each, %d harmonics):\n", with_imu ? "with the IMU" : "wrench alone",
                o.harmonics);
    for (const auto& t : s.trials) {
      std::printf("  %6.2f s  cond %10.4g  %s\n", t.duration_s, t.condition_number, t.met ? "meets" : "misses");
    }
    if (s.found) {
      std::printf("shortest duration meeting the limits, %s: %.2f s\n", with_imu ? "with the IMU" : "wrench alone",
                  s.best.file.duration_s);
      chosen = std::move(s.best);
      found_any = true;
      *written_with_imu = with_imu;
    } else {
      std::printf("no duration up to 60 s meets the limits %s\n", with_imu ? "with the IMU" : "with the wrench alone");
      if (with_imu || !imu) {
        if (!found_any) {
          throw design::DesignError("no duration up to 60 s meets the limits " + limits +
                                    " within the robot's limits; relax the limits or the motion limits, or lower the noise");
        }
      }
    }
  }
  return chosen;
}

/// Parses the command line into `o` and the returned values, and converts the joints, q0, the
/// objective, the noise and the nominal payload into `o`.
DesignArgs parseDesignArgs(const std::vector<std::string>& argv, ftid::design::DesignOptions& o) {
  using namespace ftid;
  DesignArgs a;
  CLI::App app{"ftid design"};
  app.add_option("--model", o.model);
  app.add_option("--robot", o.robot_path);
  app.add_option("--config", a.config);
  app.add_option("--joints", a.joints);
  app.add_option("--duration", o.duration_s)->transform(cli::real(cli::positive()));
  app.add_option("--periods", o.periods)->transform(cli::integer(1, 1000000));
  app.add_option("--harmonics", o.harmonics)->transform(cli::integer(2, 1000000));
  app.add_option("--rate", o.servo_rate_hz)->transform(cli::real(cli::positive()));
  cli::addReals(app, "--q0", a.q0, 6);
  app.add_option("--objective", a.objective)->transform(cli::oneOf({"cond", "dopt", "limits"}));
  app.add_option("--seed", o.seed)->transform(cli::count());
  app.add_option("--time-budget", o.time_budget_s)->transform(cli::real(cli::positive()));
  app.add_option("--global", o.global_algorithm);
  app.add_option("--local", o.local_algorithm);
  app.add_option("--global-evals", o.global_max_evals)->transform(cli::integer(0, 1000000000000));
  app.add_option("--local-evals", o.local_max_evals)->transform(cli::integer(0, 1000000000000));
  app.add_option("--noise", a.noise);
  app.add_option("--nominal", a.nominal);
  app.add_option("--target-std", a.target);
  app.add_option("--limits", a.limits);
  app.add_option("--imu-noise", a.imu_noise);
  app.add_option("--max-cond", o.max_condition)->transform(cli::real(cli::positive()));
  app.add_option("--baseline-seeds", o.baseline_seeds)->transform(cli::integer(0, 1000000));
  app.add_option("--out", a.out);
  app.add_flag("--quiet", a.quiet);
  app.add_flag("--fixed-duration", a.fixed_duration);
  cli::parse(app, argv);

  if (a.joints == "all") {
    o.joints = {1, 2, 3, 4, 5, 6};
  } else {
    o.joints.clear();
    std::stringstream ss(a.joints);
    std::string item;
    while (std::getline(ss, item, ',')) o.joints.push_back(static_cast<int>(cli::parseInteger(item, "--joints", 1, 6)));
  }
  if (!a.q0.empty()) {
    for (int i = 0; i < 6; ++i) o.q0[i] = a.q0[static_cast<std::size_t>(i)];
  }
  const bool has_targets = !a.limits.empty() || !a.target.empty();
  if (a.objective.empty()) a.objective = has_targets ? "limits" : "cond";
  if (a.objective == "limits" && !has_targets) throw cli::UsageError("--objective limits needs --limits or --target-std");
  if (a.fixed_duration && !has_targets) throw cli::UsageError("--fixed-duration needs --limits or --target-std");
  o.objective = a.objective == "cond"   ? design::Objective::kCondition
                : a.objective == "dopt" ? design::Objective::kDOptimality
                                        : design::Objective::kLimits;
  if (!a.noise.empty()) o.noise_sigma = design::parseNoise(a.noise);
  if (!a.imu_noise.empty()) parseImuNoise(a.imu_noise, &o);
  if (!a.nominal.empty()) o.nominal = parseNominal(a.nominal);
  return a;
}

/// --target-std: the shortest duration (one base period each) whose predicted standard errors
/// meet the targets; prints every trial.
ftid::design::DesignResult searchTargets(const ftid::design::DesignOptions& o, const ftid::model::RobotKinematics& kin,
                                         const std::map<std::string, double>& targets, const std::string& target) {
  using namespace ftid;
  std::cerr << "design: searching the shortest duration meeting the targets (budget "
            << o.time_budget_s << " s in total)\n";
  design::DurationSearchResult s = design::findShortestDuration(o, kin, targets);
  std::printf("duration search (one base period each, %d harmonics):\n", o.harmonics);
  for (const auto& t : s.trials) {
    std::printf("  %6.2f s  cond %10.4g  %s\n", t.duration_s, t.condition_number,
                t.met ? "meets" : "misses");
  }
  if (!s.found) {
    throw design::DesignError(
        "no duration up to 60 s meets the targets " + target +
        " within the limits; relax the targets or the limits, or lower the noise");
  }
  std::printf("shortest duration meeting the targets: %.2f s\n", s.best.file.duration_s);
  return std::move(s.best);
}

/// --limits: the predicted worst case over noise (3 standard errors) of each limited parameter,
/// with the wrench alone and with the IMU, against its limit.
void printWorstCase(const ftid::design::DesignResult& r, const std::map<std::string, double>& targets) {
  using namespace ftid;
  std::printf("predicted worst case over noise (3 standard errors) against the limits:\n");
  for (const auto& target_item : targets) {
    const std::string k = target_item.first;
    const double limit = target_item.second * design::kLimitStandardErrors;
    auto show = [&](const char* label, const std::map<std::string, double>& m) {
      const auto it = m.find(k);
      if (it == m.end()) return;
      const double worst = design::kLimitStandardErrors * it->second;
      std::printf("  %-8s %-12s %12.4g  limit %.4g  %s\n", k.c_str(), label, worst, limit,
                  worst <= limit ? "met" : "MISSED");
    };
    show("wrench", r.predicted_std);
    show("with IMU", r.predicted_std_imu);
  }
}

/// The designed trajectory's figures: the optimiser's runs, the condition number and D-optimality
/// against the baselines, the predicted standard errors (against the targets or the limits), the
/// dense re-check of the constraints, and the files written. (Reads the design block and the
/// metrics with operator[], as it always has: a missing key reads as empty or 0 and is added.)
void printDesign(ftid::design::DesignResult& r, const DesignArgs& a,
                 const std::map<std::string, double>& targets, const std::string& csv) {
  std::printf("designed %.3g s trajectory, %d harmonics, joints %s, model %s\n", r.file.duration_s,
              r.file.harmonics, r.file.design["joints"].c_str(), r.file.design["model"].c_str());
  std::printf("  NLopt global: %s\n  NLopt local:  %s\n  evaluations %ld + %ld in %.1f s\n",
              r.global_result.c_str(), r.local_result.c_str(), r.global_evals, r.local_evals,
              r.elapsed_s);
  std::printf("condition number (column-scaled, %d samples at %g Hz): %.4g\n",
              static_cast<int>(r.file.metrics["samples"]), r.file.servo_rate_hz,
              r.condition_number);
  std::printf("D-optimality -(1/P) log det(M/n): %.4g\n", r.d_optimality);
  if (r.baselines.random_count > 0) {
    std::printf(
        "random feasible Fourier trajectories (median of %d): cond %.4g -> designed is %.1fx "
        "better\n",
        r.baselines.random_count, r.baselines.random_median_condition,
        r.baselines.random_median_condition / r.condition_number);
  }
  if (std::isinf(r.baselines.static_condition)) {
    std::printf(
        "static six-pose method: cannot determine model %s at all (singular: static poses do not "
        "excite its motion-dependent parameters)\n",
        r.file.design["model"].c_str());
  } else if (r.baselines.static_condition > 0.0) {
    std::printf("static six-pose method: cond %.4g -> ratio static/designed %.2f\n",
                r.baselines.static_condition, r.baselines.static_condition / r.condition_number);
  } else if (!r.file.metrics.empty()) {
    std::printf("static six-pose method: no six feasible poses found from q0 (baseline skipped)\n");
  }
  std::printf("predicted standard errors (noise %s):\n", r.file.design["noise"].c_str());
  printStd(r.predicted_std, a.limits.empty() ? targets : std::map<std::string, double>{});
  if (!r.predicted_std_imu.empty()) {
    std::printf("predicted standard errors with the IMU's tilt fused (IMU noise %s):\n", a.imu_noise.c_str());
    printStd(r.predicted_std_imu, a.limits.empty() ? targets : std::map<std::string, double>{});
  }
  if (!a.limits.empty()) printWorstCase(r, targets);
  std::printf("dense re-check (%d samples): %s\n", r.check.samples,
              r.check.ok() ? "all constraints hold" : "VIOLATED");
  std::printf("%s", r.check.table().c_str());
  std::printf("wrote %s and %s\n", a.out.c_str(), csv.c_str());
}

/// --fixed-duration: one design at --duration for the limits or targets (the objective, unless
/// --objective says otherwise); with --imu-noise and --limits, judged with the IMU.
ftid::design::DesignResult designFixedDuration(ftid::design::DesignOptions o, const ftid::model::RobotKinematics& kin,
                                               const std::map<std::string, double>& targets, const DesignArgs& a) {
  using namespace ftid;
  o.targets_with_imu = !a.limits.empty() && o.imu_acc_std > 0.0;
  design::DesignResult r = design::designExcitation(o, kin);
  const auto unmet = design::unmetTargets(o.targets_with_imu ? r.predicted_std_imu : r.predicted_std, targets);
  std::printf("%.2f s %s the %s%s\n", o.duration_s, unmet.empty() ? "meets" : "misses",
              a.limits.empty() ? "targets" : "limits", o.targets_with_imu ? " with the IMU" : "");
  return r;
}

/// The arguments of the reproduce command that are not DesignOptions fields it pins: the noise and
/// the nominal payload when given (the metric and the relative limits depend on them), and the
/// limits or targets of a design made for them.
std::string targetArguments(const DesignArgs& a, bool written_with_imu) {
  std::string s;
  if (!a.noise.empty()) s += " --noise " + a.noise;
  if (!a.nominal.empty()) s += " --nominal " + a.nominal;
  if (!a.limits.empty()) s += " --limits " + a.limits;
  if (!a.target.empty()) s += " --target-std " + a.target;
  // The IMU noise, unless the IMU search met nothing and the wrench-alone design was written: with
  // --fixed-duration it would design for the prediction with the IMU.
  if (!a.imu_noise.empty() && (written_with_imu || a.limits.empty())) s += " --imu-noise " + a.imu_noise;
  if (!a.limits.empty() || !a.target.empty()) s += " --fixed-duration";  // not for --imu-noise alone
  return s;
}

int runDesign(const std::vector<std::string>& argv) {
  using namespace ftid;
  design::DesignOptions o;
  o.robot_path.clear();  // the shipped default, found below
  DesignArgs a = parseDesignArgs(argv, o);
  if (o.servo_rate_hz != 125.0 && o.servo_rate_hz != 500.0) {
    std::cerr << "ftid design: note: --rate " << o.servo_rate_hz
              << " Hz is neither 125 (CB3) nor 500 (e-Series)\n";
  }
  (void)effects::Model::fromName(o.model);  // unknown model: clear error before any work
  checkOutputPath(a.out);                      // and a bad --out too
  checkOutputPath(trajectory::csvPathFor(a.out));

  if (o.robot_path.empty()) o.robot_path = findDefaultFile("ur10.urdf");
  const auto kin = model::RobotKinematics::fromUrdfFile(o.robot_path);
  // Provenance names the shipped default by its name, not by this machine's path to it.
  const bool shipped_config = a.config.empty();
  if (a.config.empty()) a.config = findDefaultFile("design.yaml");
  o.constraints = design::loadDesignConstraints(a.config, kin, o.q0);
  if (!a.quiet) o.progress = &std::cerr;

  design::DesignResult r;
  std::map<std::string, double> targets;
  if (!a.target.empty() && !a.limits.empty()) throw cli::UsageError("--target-std and --limits exclude each other");
  if (!a.limits.empty()) {
    try {
      targets = design::parseLimits(a.limits, o.nominal);
    } catch (const ConfigError& e) {
      throw cli::UsageError(e.what());
    }
  } else if (!a.target.empty()) {
    targets = design::parseTargets(a.target, o.nominal);
  }
  if (!targets.empty()) {
    try {
      design::checkTargetNames(o, kin, targets);
    } catch (const ConfigError& e) {
      throw cli::UsageError(std::string(a.limits.empty() ? "--target-std: " : "--limits: ") + e.what());
    }
  }
  if (o.objective == design::Objective::kLimits) o.limit_targets = targets;
  bool written_with_imu = o.imu_acc_std > 0.0;  // searchLimits says which search's design it returns
  if (a.fixed_duration) {
    r = designFixedDuration(o, kin, targets, a);
  } else if (!a.limits.empty()) {
    r = searchLimits(o, kin, targets, a.limits, &written_with_imu);
  } else if (!a.target.empty()) {
    r = searchTargets(o, kin, targets, a.target);
  } else {
    r = design::designExcitation(o, kin);
  }
  r.file.design["config"] = shipped_config ? "design.yaml (shipped default)" : a.config;
  r.file.design["reproduce"] = reproduceCommand(o, r, targetArguments(a, written_with_imu));
  if (!a.target.empty()) r.file.design["target_std"] = a.target;
  if (!a.limits.empty()) r.file.design["limits"] = a.limits + " (3 predicted standard errors)";
  if (!a.imu_noise.empty()) r.file.design["imu_noise"] = a.imu_noise;

  for (const auto& w : r.warnings) std::cerr << "ftid design: warning: " << w << "\n";
  trajectory::writeTrajectoryFile(a.out, r.file);
  const std::string csv = trajectory::csvPathFor(a.out);
  trajectory::writeTrajectoryCsv(csv, r.file.toTrajectory(), r.file.servo_rate_hz);
  printDesign(r, a, targets, csv);
  return r.check.ok() ? 0 : 1;
}

ftid::cli::Registrar reg{
    {"design", "design an optimal excitation trajectory (NLopt)", kUsage, &runDesign}};

}  // namespace
