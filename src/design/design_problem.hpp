#pragma once
// The designer's optimisation problem (private to ftid::design): the NLopt variables x in
// [-1, 1]^n are the rest-to-rest Fourier coefficients of the excited joints (parametrization.hpp);
// `Problem` samples the motion they describe at the design samples and computes
//   - the constraints g(x) <= 0: per excited joint, position above/below q0, |velocity| and
//     |acceleration| against the limits tightened by the margin, then per tool sphere the floor and
//     every keep-out sphere (clearances in units of kWorkspaceScale); each aggregated over the
//     samples by a Kreisselmeier-Steinhauser soft maximum, so max_t g(t) <= KS <= max_t g(t) +
//     ln(K)/kKsRho: KS <= 0 implies every sample satisfies its constraint (conservative);
//   - the objective minimised: log10 of the column-scaled condition number of the information
//     matrix, its D-optimality criterion (excitation_metric.hpp), or log10 of the 16-norm of the
//     ratios predicted std / target (Objective::kLimits); kPenalty for a singular one.
// It also keeps the best feasible point seen, the per-stage time/evaluation budget (BudgetSpent),
// and prints progress. Implementation: design_problem.cpp.
#include <chrono>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "ftid/design/designer.hpp"
#include "ftid/design/excitation_metric.hpp"
#include "ftid/design/parametrization.hpp"

namespace ftid::design::internal {

using Clock = std::chrono::steady_clock;
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kKsRho = 200.0;         // KS aggregation sharpness (normalised constraint units)
constexpr double kWorkspaceScale = 0.1;  // [m] normalisation of workspace clearances
constexpr double kPenalty = 1e3;         // objective value of a degenerate (singular) excitation
constexpr double kLimitNormP = 16.0;     // p of the p-norm soft maximum of the limit ratios

/// printf "%.6g": the designer's one number format in messages, progress and the design record.
std::string fmt(double v);

/// Uniform double in [0, 1) from the top 53 bits of mt19937_64: identical on every platform
/// (std::uniform_real_distribution is implementation-defined).
inline double uniform01(std::mt19937_64& rng) {
  return static_cast<double>(rng() >> 11) * 0x1.0p-53;
}

/// n coefficients uniform in [-1, 1) (a random Fourier trajectory before scaling into the limits).
std::vector<double> randomDirection(std::mt19937_64& rng, int n);

/// Kreisselmeier-Steinhauser soft maximum: max(g) <= KS(g) <= max(g) + ln(n)/rho.
class SoftMax {
 public:
  void add(double g) { values_.push_back(g); }
  void clear() { values_.clear(); }
  double value() const;

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
  Problem(const DesignOptions& opt, const model::RobotKinematics& kin);

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
  double jointScaleLimit(const std::vector<double>& x) const;

  /// Scales x into the feasible set: s x with s = min(s_cap, jointScaleLimit(x)) if that satisfies
  /// every aggregated constraint, else the largest such s found by 30 bisections of [0, s] (the
  /// workspace, or the soft maximum's conservatism: the joints then end within ln(2K)/kKsRho of
  /// their tightened limits).
  std::vector<double> makeFeasible(std::vector<double> x, double s_cap = 1.0);

  /// Full evaluation (objective + constraints) with a one-entry cache; throws BudgetSpent when the
  /// stage's time or evaluation budget is spent.
  const Evaluation& evaluate(const double* x);

  bool evaluateConstraintsOnly(const std::vector<double>& x) {
    const Evaluation e = compute(x.data(), false);
    return e.feasible;
  }

  const std::vector<double>& bestX() const { return best_x_; }
  double bestObjective() const { return best_f_; }
  void offerBest(const std::vector<double>& x) { (void)evaluate(x.data()); }

  /// One progress line (at most one a second unless forced) to DesignOptions::progress.
  void printProgress(bool force);

  /// Information at the design samples (for baselines and final figures).
  Eigen::MatrixXd information(const std::vector<double>& x) const;

 private:
  Evaluation compute(const double* x, bool with_objective);
  /// Objective::kLimits: log10 of the soft maximum over DesignOptions::limit_targets of predicted
  /// std / target (with the IMU's information when targets_with_imu); kPenalty when singular.
  double limitObjective(const Eigen::MatrixXd& info) const;
  /// The best objective in the progress line's units (cond; dopt; worst std / target).
  double progressValue() const;

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

}  // namespace ftid::design::internal
