#pragma once
// The designer's steps around the optimisation problem (private to ftid::design; the problem itself
// is design_problem.hpp, the sequence designExcitation in designer.cpp):
//   design_stages.cpp     the NLopt driving: seeded random feasible starts ranked by objective, the
//                         global stage (multistart COBYLA or GN_ISRES), the local refinement of the
//                         best feasible point, NLopt result codes and exceptions mapped to messages
//   design_baselines.cpp  what the design is compared with: random feasible Fourier trajectories
//                         and the static six-pose method
#include <string>
#include <utility>
#include <vector>

#include "design_problem.hpp"
#include "ftid/design/designer.hpp"

namespace ftid::design::internal {

/// Throws ConfigError when DesignOptions names an unknown global or local algorithm.
void validateAlgorithms(const DesignOptions& opt);

/// A starting point and its objective (kInf if infeasible).
using Start = std::pair<double, std::vector<double>>;

/// `count` random directions from rng scaled into the feasible set and evaluated, sorted by
/// objective (stable: equal objectives keep their draw order). Stops early when the stage's budget
/// is spent.
std::vector<Start> rankedStarts(Problem& p, std::mt19937_64& rng, int count);

/// The global stage from the ranked starts, within half of the remaining time budget. Returns the
/// description recorded as `global_result`; throws DesignError if NLopt rejects the problem.
std::string runGlobalStage(const DesignOptions& opt, Problem& p, const std::vector<Start>& starts);

/// The local refinement of the best feasible point until the end of the time budget. Returns the
/// description recorded as `local_result`; throws DesignError if NLopt rejects the problem.
std::string runLocalStage(const DesignOptions& opt, Problem& p);

/// Baselines at the problem's current design samples (design_baselines.cpp).
BaselineReport computeBaselines(const DesignOptions& opt, Problem& p,
                                const model::RobotKinematics& kin);

}  // namespace ftid::design::internal
