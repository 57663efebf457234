// NLopt excitation-trajectory designer: problem set-up, smooth aggregated constraints, global and
// local stages, dense re-check and repair, baselines (see designer.hpp and docs/design.md).
#include "ftid/design/designer.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <new>
#include <nlopt.hpp>
#include <ostream>
#include <random>
#include <sstream>
#include <stdexcept>

#include "ftid/design/excitation_metric.hpp"
#include "ftid/design/parametrization.hpp"
#include "ftid/effects/model.hpp"

namespace ftid::design {

namespace {

using Clock = std::chrono::steady_clock;
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kKsRho = 200.0;         // KS aggregation sharpness (normalised constraint units)
constexpr double kWorkspaceScale = 0.1;  // [m] normalisation of workspace clearances
constexpr double kPenalty = 1e3;         // objective value of a degenerate (singular) excitation

std::string fmt(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

/// Uniform double in [0, 1) from the top 53 bits of mt19937_64: identical on every platform
/// (std::uniform_real_distribution is implementation-defined).
double uniform01(std::mt19937_64& rng) {
  return static_cast<double>(rng() >> 11) * 0x1.0p-53;
}

/// Kreisselmeier-Steinhauser soft maximum: max(g) <= KS(g) <= max(g) + ln(n)/rho.
class SoftMax {
 public:
  void add(double g) { values_.push_back(g); }
  void clear() { values_.clear(); }
  double value() const {
    if (values_.empty()) return -1.0;
    double m = -kInf;
    for (double v : values_) {
      if (std::isnan(v)) return kInf;
      m = std::max(m, v);
    }
    if (!std::isfinite(m)) return m;
    double s = 0.0;
    for (double v : values_) s += std::exp(kKsRho * (v - m));
    return m + std::log(s) / kKsRho;
  }

 private:
  std::vector<double> values_;
};

struct Evaluation {
  double objective = kInf;  // value minimised by NLopt
  double condition = kInf;
  std::vector<double> g;  // constraints, feasible when all <= 0
  bool feasible = false;
};

/// Thrown from callbacks when our own time budget for a stage is spent (NLopt re-throws it).
struct BudgetSpent {};

class Problem {
 public:
  Problem(const DesignOptions& opt, const model::RobotKinematics& kin)
      : opt_(opt),
        param_(opt.q0, opt.joints, opt.harmonics, static_cast<double>(opt.periods) / opt.duration_s,
               opt.duration_s, opt.constraints),
        metric_(effects::Model::fromName(opt.model), kin, opt.constraints,
                opt.nominal.empty() ? defaultNominalParameters() : opt.nominal, opt.noise_sigma),
        start_(Clock::now()) {
    int K = opt.design_samples;
    if (K <= 0) K = std::max(120, 30 * opt.harmonics * opt.periods);
    param_.prepareSampling(K);
    represented_ = opt.duration_s * opt.servo_rate_hz;
    weight_ = represented_ / K;
    // Joint limits tightened by the margin, about q0.
    const auto& c = opt.constraints;
    for (int j : param_.joints()) {
      const int i = j - 1;
      const double m = 1.0 - opt.constraint_margin;
      up_.push_back((c.position_upper[i] - opt.q0[i]) * m);
      lo_.push_back((opt.q0[i] - c.position_lower[i]) * m);
      vel_.push_back(c.velocity[i] * m);
      acc_.push_back(c.acceleration[i] * m);
    }
    num_constraints_ = 4 * static_cast<int>(param_.joints().size()) +
                       static_cast<int>(c.tool.size() * (1 + c.keep_out.size()));
  }

  const RestToRestParametrization& param() const { return param_; }
  RestToRestParametrization& param() { return param_; }
  const ExcitationMetric& metric() const { return metric_; }
  int n() const { return param_.numVariables(); }
  int m() const { return num_constraints_; }
  double represented() const { return represented_; }
  long evals() const { return evals_; }
  double elapsed() const { return std::chrono::duration<double>(Clock::now() - start_).count(); }

  void setStage(std::string name, double deadline_s, long max_evals) {
    stage_ = std::move(name);
    stage_deadline_ = deadline_s;
    stage_max_evals_ = max_evals;
    stage_evals_ = 0;
  }
  long stageEvals() const { return stage_evals_; }

  /// Largest amplitude scale s in [0, s_cap] such that s * x satisfies the joint constraints on
  /// the design samples (closed form: q - q0, qd, qdd are linear in s).
  double jointScaleLimit(const std::vector<double>& x) const {
    SampledMotion mo;
    param_.sample(x.data(), mo);
    double s = kInf;
    const auto& joints = param_.joints();
    for (std::size_t k = 0; k < joints.size(); ++k) {
      const int i = joints[k] - 1;
      for (Eigen::Index t = 0; t < mo.q.cols(); ++t) {
        const double dq = mo.q(i, t) - opt_.q0[i];
        if (dq > 0.0) s = std::min(s, up_[k] / dq);
        if (dq < 0.0) s = std::min(s, lo_[k] / -dq);
        if (mo.qd(i, t) != 0.0) s = std::min(s, vel_[k] / std::abs(mo.qd(i, t)));
        if (mo.qdd(i, t) != 0.0) s = std::min(s, acc_[k] / std::abs(mo.qdd(i, t)));
      }
    }
    return s;
  }

  /// Scales x into the feasible set: joint limits in closed form, workspace by bisection.
  std::vector<double> makeFeasible(std::vector<double> x, double s_cap = 1.0) {
    double s = std::min(s_cap, jointScaleLimit(x));
    if (!std::isfinite(s)) s = 0.0;
    auto scaled = [&](double f) {
      std::vector<double> y(x);
      for (double& v : y) v *= f;
      return y;
    };
    if (!evaluateConstraintsOnly(scaled(s))) {
      double lo = 0.0, hi = s;
      for (int it = 0; it < 30; ++it) {
        const double mid = 0.5 * (lo + hi);
        (evaluateConstraintsOnly(scaled(mid)) ? lo : hi) = mid;
      }
      s = lo;
    }
    return scaled(s);
  }

  /// Full evaluation (objective + constraints) with a one-entry cache.
  const Evaluation& evaluate(const double* x) {
    const auto nn = static_cast<std::size_t>(n());
    if (have_cache_ && std::equal(x, x + nn, cache_x_.begin())) return cache_;
    if (stage_max_evals_ > 0 && stage_evals_ >= stage_max_evals_) throw BudgetSpent{};
    if (elapsed() > stage_deadline_) throw BudgetSpent{};
    cache_x_.assign(x, x + nn);
    cache_ = compute(x, true);
    have_cache_ = true;
    ++evals_;
    ++stage_evals_;
    if (cache_.feasible && cache_.objective < best_f_) {
      best_f_ = cache_.objective;
      best_cond_ = cache_.condition;
      best_x_ = cache_x_;
    }
    printProgress(false);
    return cache_;
  }

  bool evaluateConstraintsOnly(const std::vector<double>& x) {
    const Evaluation e = compute(x.data(), false);
    return e.feasible;
  }

  const std::vector<double>& bestX() const { return best_x_; }
  double bestObjective() const { return best_f_; }
  void offerBest(const std::vector<double>& x) { (void)evaluate(x.data()); }

  void printProgress(bool force) {
    if (opt_.progress == nullptr) return;
    const double now = elapsed();
    if (!force && now - last_print_ < 1.0) return;
    last_print_ = now;
    const double left = std::max(0.0, opt_.time_budget_s - now);
    char buf[256];
    std::snprintf(
        buf, sizeof buf,
        "design [%s] eval %ld | best %s %s | elapsed %.1f s | remaining %.1f s (budget)\n",
        stage_.c_str(), evals_, opt_.objective == Objective::kCondition ? "cond" : "dopt",
        std::isfinite(best_f_)
            ? fmt(opt_.objective == Objective::kCondition ? best_cond_ : best_f_).c_str()
            : "(none feasible yet)",
        now, left);
    *opt_.progress << buf << std::flush;
  }

  /// Information at the design samples (for baselines and final figures).
  Eigen::MatrixXd information(const std::vector<double>& x) const {
    SampledMotion mo;
    param_.sample(x.data(), mo);
    return metric_.information(mo, weight_);
  }

 private:
  Evaluation compute(const double* x, bool with_objective) {
    Evaluation e;
    param_.sample(x, motion_);
    const auto K = motion_.q.cols();
    const auto& c = opt_.constraints;
    SoftMax ks;
    const auto& joints = param_.joints();
    for (std::size_t k = 0; k < joints.size(); ++k) {
      const int i = joints[k] - 1;
      const double q0 = opt_.q0[i];
      ks.clear();
      for (Eigen::Index t = 0; t < K; ++t) ks.add((motion_.q(i, t) - q0) / up_[k] - 1.0);
      e.g.push_back(ks.value());
      ks.clear();
      for (Eigen::Index t = 0; t < K; ++t) ks.add((q0 - motion_.q(i, t)) / lo_[k] - 1.0);
      e.g.push_back(ks.value());
      ks.clear();
      for (Eigen::Index t = 0; t < K; ++t) {
        ks.add(motion_.qd(i, t) / vel_[k] - 1.0);
        ks.add(-motion_.qd(i, t) / vel_[k] - 1.0);
      }
      e.g.push_back(ks.value());
      ks.clear();
      for (Eigen::Index t = 0; t < K; ++t) {
        ks.add(motion_.qdd(i, t) / acc_[k] - 1.0);
        ks.add(-motion_.qdd(i, t) / acc_[k] - 1.0);
      }
      e.g.push_back(ks.value());
    }
    Eigen::MatrixXd info;
    if (with_objective || !c.tool.empty()) {
      info = metric_.information(motion_, weight_, &poses_);
    }
    for (const auto& tool : c.tool) {
      ks.clear();
      for (const auto& X : poses_)
        ks.add((c.floor_z_B + tool.radius - (X * tool.center_S).z()) / kWorkspaceScale);
      e.g.push_back(ks.value());
      for (const auto& ko : c.keep_out) {
        ks.clear();
        for (const auto& X : poses_) {
          ks.add((ko.radius + tool.radius - ((X * tool.center_S) - ko.center_B).norm()) /
                 kWorkspaceScale);
        }
        e.g.push_back(ks.value());
      }
    }
    e.feasible = std::all_of(e.g.begin(), e.g.end(), [](double v) { return v <= 0.0; });
    if (with_objective) {
      e.condition = ExcitationMetric::conditionNumber(info);
      if (opt_.objective == Objective::kCondition) {
        e.objective = std::isfinite(e.condition) ? std::log10(e.condition) : kPenalty;
      } else {
        const double d = ExcitationMetric::dOptimality(info, represented_);
        e.objective = std::isfinite(d) ? d : kPenalty;
      }
    }
    return e;
  }

  const DesignOptions& opt_;
  RestToRestParametrization param_;
  ExcitationMetric metric_;
  Clock::time_point start_;
  double represented_ = 0.0;
  double weight_ = 1.0;
  std::vector<double> up_, lo_, vel_, acc_;
  int num_constraints_ = 0;
  SampledMotion motion_;
  std::vector<Eigen::Isometry3d> poses_;
  bool have_cache_ = false;
  std::vector<double> cache_x_;
  Evaluation cache_;
  long evals_ = 0;
  std::string stage_ = "setup";
  double stage_deadline_ = kInf;
  long stage_max_evals_ = 0;
  long stage_evals_ = 0;
  double last_print_ = -kInf;
  std::vector<double> best_x_;
  double best_f_ = kInf;
  double best_cond_ = kInf;
};

// ------------------------------------------------------------------ NLopt glue

struct CallbackData {
  Problem* problem;
};

/// Forward-difference gradient of the objective and the constraints (for LD_SLSQP).
void finiteDifferences(Problem& p, const double* x, double* grad_f, double* grad_g) {
  const int n = p.n(), m = p.m();
  const Evaluation base = p.evaluate(x);
  std::vector<double> xh(x, x + n);
  for (int k = 0; k < n; ++k) {
    const double h = 1e-6;
    xh[static_cast<std::size_t>(k)] = x[k] + h;
    const Evaluation e = p.evaluate(xh.data());
    if (grad_f != nullptr) grad_f[k] = (e.objective - base.objective) / h;
    if (grad_g != nullptr) {
      for (int i = 0; i < m; ++i) {
        grad_g[i * n + k] =
            (e.g[static_cast<std::size_t>(i)] - base.g[static_cast<std::size_t>(i)]) / h;
      }
    }
    xh[static_cast<std::size_t>(k)] = x[k];
  }
  (void)p.evaluate(x);  // restore the cache to x
}

double objectiveCallback(unsigned /*n*/, const double* x, double* grad, void* data) {
  Problem& p = *static_cast<CallbackData*>(data)->problem;
  try {
    if (grad != nullptr) finiteDifferences(p, x, grad, nullptr);
    return p.evaluate(x).objective;
  } catch (const BudgetSpent&) {
    throw nlopt::forced_stop();
  }
}

void constraintCallback(unsigned m, double* result, unsigned /*n*/, const double* x, double* grad,
                        void* data) {
  Problem& p = *static_cast<CallbackData*>(data)->problem;
  try {
    if (grad != nullptr) finiteDifferences(p, x, nullptr, grad);
    const Evaluation& e = p.evaluate(x);
    for (unsigned i = 0; i < m; ++i) result[i] = e.g[i];
  } catch (const BudgetSpent&) {
    throw nlopt::forced_stop();
  }
}

struct RunOutcome {
  std::string message;
  bool fatal = false;
};

/// Runs one NLopt optimisation, mapping result codes and exceptions to messages.
RunOutcome runNlopt(nlopt::opt& o, Problem& p, std::vector<double>& x, bool budget_is_ours) {
  CallbackData data{&p};
  RunOutcome out;
  try {
    o.set_lower_bounds(std::vector<double>(static_cast<std::size_t>(p.n()), -1.0));
    o.set_upper_bounds(std::vector<double>(static_cast<std::size_t>(p.n()), 1.0));
    o.set_min_objective(objectiveCallback, &data);
    if (p.m() > 0) {
      o.add_inequality_mconstraint(constraintCallback, &data,
                                   std::vector<double>(static_cast<std::size_t>(p.m()), 1e-9));
    }
    double f = 0.0;
    const nlopt::result r = o.optimize(x, f);
    out.message = describeNloptResult(static_cast<int>(r));
  } catch (const nlopt::forced_stop&) {
    out.message = budget_is_ours ? "stopped at its time/evaluation budget (best point kept)"
                                 : describeNloptResult(static_cast<int>(nlopt::FORCED_STOP));
  } catch (const nlopt::roundoff_limited&) {
    out.message =
        describeNloptResult(static_cast<int>(nlopt::ROUNDOFF_LIMITED)) + " (best point kept)";
  } catch (const std::invalid_argument& e) {
    out.message = describeNloptResult(static_cast<int>(nlopt::INVALID_ARGS)) + ": " + e.what();
    out.fatal = true;
  } catch (const std::bad_alloc&) {
    out.message = describeNloptResult(static_cast<int>(nlopt::OUT_OF_MEMORY));
    out.fatal = true;
  } catch (const std::runtime_error& e) {
    // nlopt::opt::mythrow maps NLOPT_FAILURE to std::runtime_error.
    out.message = describeNloptResult(static_cast<int>(nlopt::FAILURE)) + ": " + e.what() +
                  " (best point kept)";
  }
  return out;
}

nlopt::algorithm localAlgorithm(const std::string& name) {
  if (name == "cobyla") return nlopt::LN_COBYLA;
  if (name == "slsqp") return nlopt::LD_SLSQP;
  if (name == "auglag") return nlopt::LN_AUGLAG;
  throw ConfigError("local algorithm '" + name + "' is unknown (cobyla, slsqp, auglag, none)");
}

void configureLocal(nlopt::opt& o, const std::string& name) {
  if (name == "auglag") {
    nlopt::opt sub(nlopt::LN_SBPLX, o.get_dimension());
    sub.set_xtol_rel(1e-6);
    sub.set_ftol_rel(1e-9);
    sub.set_maxeval(2000);
    o.set_local_optimizer(sub);
  }
  o.set_xtol_rel(1e-7);
  o.set_ftol_rel(1e-10);
}

// ------------------------------------------------------------------ baselines

std::vector<double> randomDirection(std::mt19937_64& rng, int n) {
  std::vector<double> x(static_cast<std::size_t>(n));
  for (double& v : x) v = 2.0 * uniform01(rng) - 1.0;
  return x;
}

BaselineReport computeBaselines(const DesignOptions& opt, Problem& p,
                                const model::RobotKinematics& kin) {
  BaselineReport b;
  // Random feasible Fourier trajectories of the same duration and harmonics.
  std::vector<double> conds;
  for (int i = 0; i < opt.baseline_seeds; ++i) {
    std::mt19937_64 rng(opt.seed * 1000003ULL + 7919ULL * static_cast<std::uint64_t>(i) + 17ULL);
    const std::vector<double> x = p.makeFeasible(randomDirection(rng, p.n()));
    conds.push_back(ExcitationMetric::conditionNumber(p.information(x)));
  }
  if (!conds.empty()) {
    std::sort(conds.begin(), conds.end());
    const std::size_t h = conds.size() / 2;
    b.random_median_condition = conds.size() % 2 ? conds[h] : 0.5 * (conds[h - 1] + conds[h]);
    b.random_count = static_cast<int>(conds.size());
  }
  if (!opt.static_baseline) return b;
  // Static six-pose method: wrist (joints 4-6) offsets from q0 in eighth turns, feasible poses,
  // one pose per gravity direction +-x, +-y, +-z in S (the closest feasible one).
  model::RobotKinematics k = kin;
  k.setSensorMount(opt.constraints.R_FS, opt.constraints.p_FS_F);
  const auto& c = opt.constraints;
  const double step = 0.7853981633974483;
  Vec3 dirs[6] = {Vec3::UnitX(),  -Vec3::UnitX(), Vec3::UnitY(),
                  -Vec3::UnitY(), Vec3::UnitZ(),  -Vec3::UnitZ()};
  double best_score[6] = {-2, -2, -2, -2, -2, -2};
  JointVector best_pose[6];
  for (int a = -4; a <= 4; ++a) {
    for (int bb = -4; bb <= 4; ++bb) {
      for (int cc = -4; cc <= 4; ++cc) {
        JointVector q = opt.q0;
        q[3] += a * step;
        q[4] += bb * step;
        q[5] += cc * step;
        if (((q - c.position_lower).array() < 0.0).any() ||
            ((c.position_upper - q).array() < 0.0).any())
          continue;
        const auto sm = k.computeSensorMotion(q, JointVector::Zero(), JointVector::Zero());
        bool ok = true;
        for (const auto& tool : c.tool) {
          const Vec3 p_B = sm.p_BS_B + sm.R_BS * tool.center_S;
          if (p_B.z() - tool.radius < c.floor_z_B) ok = false;
          for (const auto& ko : c.keep_out) {
            if ((p_B - ko.center_B).norm() < ko.radius + tool.radius) ok = false;
          }
        }
        if (!ok) continue;
        const Vec3 g_dir = (sm.R_BS.transpose() * Vec3(0.0, 0.0, -1.0));
        // prefer small moves: tiny penalty on the offset size
        const double cost = 1e-3 * (std::abs(a) + std::abs(bb) + std::abs(cc));
        for (int d = 0; d < 6; ++d) {
          const double score = g_dir.dot(dirs[d]) - cost;
          if (score > best_score[d]) {
            best_score[d] = score;
            best_pose[d] = q;
          }
        }
      }
    }
  }
  std::vector<JointVector> qs, zeros;
  for (int d = 0; d < 6; ++d) {
    if (best_score[d] > 0.7) qs.push_back(best_pose[d]);
  }
  b.static_poses = qs;
  if (qs.size() == 6) {
    zeros.assign(qs.size(), JointVector::Zero());
    const Eigen::MatrixXd info = p.metric().information(qs, zeros, zeros, p.represented() / 6.0);
    b.static_condition = ExcitationMetric::conditionNumber(info);
    b.static_std = p.metric().predictedStd(info);
  }
  return b;
}

std::string joinInts(const std::vector<int>& v) {
  std::string s;
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? "," : "") + std::to_string(v[i]);
  return s;
}

}  // namespace

std::string describeNloptResult(int code) {
  switch (code) {
    case nlopt::SUCCESS:
      return "SUCCESS: generic success";
    case nlopt::STOPVAL_REACHED:
      return "STOPVAL_REACHED: the objective reached the requested stop value";
    case nlopt::FTOL_REACHED:
      return "FTOL_REACHED: the objective changed less than the tolerance (converged)";
    case nlopt::XTOL_REACHED:
      return "XTOL_REACHED: the coefficients changed less than the tolerance (converged)";
    case nlopt::MAXEVAL_REACHED:
      return "MAXEVAL_REACHED: evaluation budget used up";
    case nlopt::MAXTIME_REACHED:
      return "MAXTIME_REACHED: time budget used up";
    case nlopt::FAILURE:
      return "FAILURE: NLopt reported a generic failure";
    case nlopt::INVALID_ARGS:
      return "INVALID_ARGS: NLopt rejected the problem set-up (bounds, dimension or algorithm)";
    case nlopt::OUT_OF_MEMORY:
      return "OUT_OF_MEMORY: NLopt ran out of memory";
    case nlopt::ROUNDOFF_LIMITED:
      return "ROUNDOFF_LIMITED: round-off errors limited progress";
    case nlopt::FORCED_STOP:
      return "FORCED_STOP: the optimisation was stopped by the caller";
    default:
      return "unknown NLopt result code " + std::to_string(code);
  }
}

DesignResult designExcitation(const DesignOptions& opt, const model::RobotKinematics& kinematics) {
  if (!(opt.duration_s > 0.0)) throw ConfigError("--duration must be positive");
  if (opt.periods < 1) throw ConfigError("periods must be >= 1");
  if (!(opt.servo_rate_hz > 0.0)) throw ConfigError("--rate must be positive");
  if (!(opt.time_budget_s > 0.0)) throw ConfigError("--time-budget must be positive");
  if (opt.global_algorithm != "multistart" && opt.global_algorithm != "isres" &&
      opt.global_algorithm != "none") {
    throw ConfigError("global algorithm '" + opt.global_algorithm +
                      "' is unknown (multistart, isres, none)");
  }
  if (opt.local_algorithm != "none") (void)localAlgorithm(opt.local_algorithm);

  // The start pose itself must satisfy every constraint (else no trajectory can).
  {
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

  Problem p(opt, kinematics);
  const int n = p.n();
  DesignResult res;
  std::mt19937_64 rng(opt.seed);
  const double budget = opt.time_budget_s;

  // ---- starting points: random feasible trajectories (seeded)
  p.setStage("start", budget, 0);
  const int n_random = 32;
  std::vector<std::pair<double, std::vector<double>>> starts;
  try {
    for (int i = 0; i < n_random; ++i) {
      std::vector<double> x = p.makeFeasible(randomDirection(rng, n));
      const Evaluation& e = p.evaluate(x.data());
      starts.emplace_back(e.feasible ? e.objective : kInf, x);
    }
  } catch (const BudgetSpent&) {
  }
  std::stable_sort(starts.begin(), starts.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });

  // ---- global stage
  const double global_deadline = p.elapsed() + 0.5 * std::max(0.0, budget - p.elapsed());
  if (opt.global_algorithm == "isres" && !starts.empty()) {
    nlopt::srand(opt.seed);
    nlopt::opt o(nlopt::GN_ISRES, static_cast<unsigned>(n));
    if (opt.global_max_evals > 0) o.set_maxeval(static_cast<int>(opt.global_max_evals));
    o.set_maxtime(std::max(0.1, global_deadline - p.elapsed()) +
                  1.0);  // backstop; our own check is first
    p.setStage("global isres", global_deadline, opt.global_max_evals);
    std::vector<double> x = starts.front().second;
    const RunOutcome r = runNlopt(o, p, x, true);
    if (r.fatal) throw DesignError("global stage (GN_ISRES): " + r.message);
    res.global_result = "GN_ISRES: " + r.message;
  } else if (opt.global_algorithm == "multistart") {
    // Short COBYLA runs from the best few random starts; evaluation budget split evenly.
    const int n_starts = std::min<int>(4, static_cast<int>(starts.size()));
    std::string msg;
    for (int s = 0; s < n_starts; ++s) {
      const double share_deadline = p.elapsed() + (global_deadline - p.elapsed()) / (n_starts - s);
      long max_evals = opt.global_max_evals > 0 ? opt.global_max_evals / n_starts : 0;
      nlopt::opt o(nlopt::LN_COBYLA, static_cast<unsigned>(n));
      configureLocal(o, "cobyla");
      o.set_xtol_rel(1e-4);
      p.setStage("global multistart " + std::to_string(s + 1) + "/" + std::to_string(n_starts),
                 share_deadline, max_evals);
      std::vector<double> x = starts[static_cast<std::size_t>(s)].second;
      const RunOutcome r = runNlopt(o, p, x, true);
      if (r.fatal) throw DesignError("global stage (multistart LN_COBYLA): " + r.message);
      msg = r.message;
    }
    res.global_result = "multistart x" + std::to_string(n_starts) + " LN_COBYLA: last run " + msg;
  } else {
    res.global_result = "none";
  }
  res.global_evals = p.evals();

  // ---- local refinement from the best feasible point
  if (opt.local_algorithm != "none" && !p.bestX().empty()) {
    nlopt::opt o(localAlgorithm(opt.local_algorithm), static_cast<unsigned>(n));
    configureLocal(o, opt.local_algorithm);
    o.set_maxtime(std::max(0.1, budget - p.elapsed()) + 1.0);
    p.setStage("local " + opt.local_algorithm, budget, opt.local_max_evals);
    std::vector<double> x = p.bestX();
    const RunOutcome r = runNlopt(o, p, x, true);
    if (r.fatal) throw DesignError("local stage (" + opt.local_algorithm + "): " + r.message);
    res.local_result = opt.local_algorithm + ": " + r.message;
  } else {
    res.local_result = "none";
  }
  res.local_evals = p.evals() - res.global_evals;
  p.printProgress(true);

  if (p.bestX().empty()) {
    throw DesignError("no feasible trajectory was found within the time budget (" + fmt(budget) +
                      " s): increase --time-budget or relax the limits");
  }

  // ---- dense, independent re-check; repair by amplitude scaling if NLopt's point violates it
  std::vector<double> x = p.bestX();
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

  // ---- final figures at the servo rate (the samples the identification will see)
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

  // ---- baselines
  prm.prepareSampling(std::max(120, 30 * opt.harmonics * opt.periods));
  if (opt.baseline_seeds > 0 || opt.static_baseline) {
    p.setStage("baselines", kInf, 0);
    res.baselines = computeBaselines(opt, p, kinematics);
  }
  res.elapsed_s = p.elapsed();

  // ---- output record
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
      {"objective", opt.objective == Objective::kCondition ? "cond" : "dopt"},
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
  return res;
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
  auto snap = [&](double d) { return std::max(min_duration_s, std::round(d / step_s) * step_s); };
  // Each design gets an equal share; about 8 designs are typical (doubling + bisection).
  const double share = options.time_budget_s / 8.0;
  auto attempt = [&](double d) -> bool {
    for (const auto& t : out.trials) {
      if (std::abs(t.duration_s - d) < 1e-9) return t.met;
    }
    DesignOptions o = options;
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
