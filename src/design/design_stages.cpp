// The designer's NLopt driving (design_stages.hpp): NLopt's variables are the Fourier coefficients
// in [-1, 1]^n, its objective and its vector inequality constraint g(x) <= 0 (tolerance 1e-9) are
// Problem::evaluate's; SLSQP gets forward-difference gradients (step 1e-6). The stages share one
// Problem, whose best feasible point survives every stage and every stop: a stage ends at its
// evaluation budget, its share of the time budget (BudgetSpent -> nlopt::forced_stop, "best point
// kept") or NLopt's own convergence; only a rejected set-up (invalid arguments, out of memory) is
// fatal.
#include <algorithm>
#include <new>
#include <nlopt.hpp>
#include <stdexcept>

#include "design_stages.hpp"

namespace ftid::design::internal {

namespace {

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

}  // namespace

void validateAlgorithms(const DesignOptions& opt) {
  if (opt.global_algorithm != "multistart" && opt.global_algorithm != "isres" &&
      opt.global_algorithm != "none") {
    throw ConfigError("global algorithm '" + opt.global_algorithm +
                      "' is unknown (multistart, isres, none)");
  }
  if (opt.local_algorithm != "none") (void)localAlgorithm(opt.local_algorithm);
}

std::vector<Start> rankedStarts(Problem& p, std::mt19937_64& rng, int count) {
  std::vector<Start> starts;
  try {
    for (int i = 0; i < count; ++i) {
      std::vector<double> x = p.makeFeasible(randomDirection(rng, p.n()));
      const Evaluation& e = p.evaluate(x.data());
      starts.emplace_back(e.feasible ? e.objective : kInf, x);
    }
  } catch (const BudgetSpent&) {
  }
  std::stable_sort(starts.begin(), starts.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  return starts;
}

std::string runGlobalStage(const DesignOptions& opt, Problem& p, const std::vector<Start>& starts) {
  const int n = p.n();
  const double budget = opt.time_budget_s;
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
    return "GN_ISRES: " + r.message;
  }
  if (opt.global_algorithm == "multistart") {
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
    return "multistart x" + std::to_string(n_starts) + " LN_COBYLA: last run " + msg;
  }
  return "none";
}

std::string runLocalStage(const DesignOptions& opt, Problem& p) {
  const double budget = opt.time_budget_s;
  if (opt.local_algorithm == "none" || p.bestX().empty()) return "none";
  nlopt::opt o(localAlgorithm(opt.local_algorithm), static_cast<unsigned>(p.n()));
  configureLocal(o, opt.local_algorithm);
  o.set_maxtime(std::max(0.1, budget - p.elapsed()) + 1.0);
  p.setStage("local " + opt.local_algorithm, budget, opt.local_max_evals);
  std::vector<double> x = p.bestX();
  const RunOutcome r = runNlopt(o, p, x, true);
  if (r.fatal) throw DesignError("local stage (" + opt.local_algorithm + "): " + r.message);
  return opt.local_algorithm + ": " + r.message;
}

}  // namespace ftid::design::internal

namespace ftid::design {

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

}  // namespace ftid::design
