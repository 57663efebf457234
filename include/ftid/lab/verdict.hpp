#pragma once
// The laboratory's one decision rule (docs/analyze.md, "The verdict: one rule").
//
// A candidate effect E, added to a fitted model M, is RECOMMENDED when
//   1. significance (the one number that decides): the family-wise p-value
//      p_fw = min(1, m * p) is below alpha, where p is the chance, under the estimated noise model,
//      that M+E predicts the held-out blocks at least as much better than M as it does if E were
//      not there (the held-out test, lab_internal.hpp heldOutNullWeights), and m the Bonferroni
//      family (the effects of the menu the data can show, one m per analysis). A significant
//      held-out gain is a fall of the held-out error; the rule still checks that the error falls
//      (min_heldout_reduction, 0 by default: strictly lower) for the tests that are in-sample
//      (change points, the reading's dynamics), so that no step ever raises it;
//   2. identifiability (a constraint that refuses, with the reason): judged by M+E's OWN
//      covariance: the data determine every direction that mixes E's parameters with the payload's
//      (no rank deficiency), and the payload's parameters stay determined in M+E (standard error
//      against the value: mass within 10 %, each centre-of-mass coordinate within 1 cm, tilt within
//      3 degrees);
//   3. physics (a constraint that refuses, with the reason): mass > 0, the inertia about the centre
//      of mass positive definite and within the triangle inequalities (beyond 3 standard errors),
//      a cable's spring constant not negative beyond 2 standard errors.
// Angles are reported wrapped to their principal range (-pi, pi].
//
// Offline code (not real-time).
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "ftid/common/shell_quote.hpp"
#include "ftid/effects/model.hpp"

namespace ftid::lab {

enum class Verdict {
  kRecommended,     ///< significant, held-out error falls, identifiable, physical
  kNotSignificant,  ///< family-wise p-value not below alpha: the gain is within chance
  kNoHeldOutGain,   ///< significant, but the held-out error does not fall (in-sample tests only)
  kRefused,         ///< significant, but not identifiable or not physical (reason given)
  kNothingToAdd,    ///< the data determine none of its parameters beyond the model's
  kSkipped,         ///< could not be tried (signal missing, ...)
};

/// One plain word (or two) for a verdict: "recommended", "not significant", ...
const char* verdictWord(Verdict v);

/// A reason a fitted model is refused, and the motion that would resolve it (may be empty).
struct Refusal {
  std::string reason;
  std::string separating_motion;
};

struct RuleInputs {
  double p_value = 1.0;               ///< the candidate's own p-value (the held-out test, or the in-sample test of a change point or the dynamics)
  int family_size = 1;                ///< m of the Bonferroni correction (one per analysis)
  double family_alpha = 1e-3;         ///< family-wise significance level
  double heldout_reduction = 0.0;     ///< 1 - SSE_ho(M+E) / SSE_ho(M), unclamped
  double min_heldout_reduction = 0.0;  ///< the reduction must exceed it (0: strictly lower)
  int added_params = 0;               ///< rank gained
  std::vector<Refusal> refusals;      ///< identifiability and physics (identifiabilityRefusals, physicsRefusals)
};

struct Decision {
  Verdict verdict = Verdict::kNotSignificant;
  double family_p = 1.0;   ///< min(1, m p): the one number that decides significance
  std::string reason;      ///< why it was not taken, in words ("" when recommended)
  std::string separating_motion;  ///< for a refusal: what motion would resolve it
};

/// The rule. Order: nothing to add, significance, held-out gain, constraints.
Decision decide(const RuleInputs& in);

/// A fitted model as the checks see it: parameter names in column order (the model's linear
/// parameters, then tilt_u, tilt_v, mounting, delay as fitted), values, the model's own covariance,
/// the directions the data do not determine (column-scaled unit vectors, may be empty), and which
/// parameters the candidate added (empty: none).
struct FitView {
  const effects::Model* model = nullptr;
  std::vector<std::string> names;
  Eigen::VectorXd theta;
  Eigen::MatrixXd covariance;
  Eigen::MatrixXd null_space;
  std::vector<bool> added;
  /// The fit's samples, for the physics that depends on them (a payload mass that changes with a
  /// signal must stay positive at every sample); nullptr: not checked.
  const std::vector<effects::SampleContext>* samples = nullptr;
};

/// Identifiability of the added parameters in the richer model itself (its own covariance).
std::vector<Refusal> identifiabilityRefusals(const FitView& f);
/// Physical possibility of the fitted model (mass, inertia about the centre of mass, cable).
std::vector<Refusal> physicsRefusals(const FitView& f);

/// Whether `ftid identify --out` would write this fit's payload: identify's own rule applied to
/// the fit's mass, centre of mass and rigid-body inertia with their standard errors
/// (params::projectInertiaWithinUncertainty, then identify::checkPhysicalValidity: a determined
/// mass, a possible inertia). "" when it would, as estimated or with the inertia projected;
/// otherwise identify's reason for refusing. A model can pass physicsRefusals (possible within
/// 3 standard errors) and still be refused here, when the data do not determine its mass or
/// inertia: the laboratory then gives no advice to write it (docs/analyze.md, "Advice to write
/// parameters"). Not judged here: the cell's plausibility limits (rated payload, sensor range),
/// which identify reads from the cell's configuration, and identify's own fit (with the IMU).
std::string writeRefusal(const FitView& f);

/// Angle wrapped to (-pi, pi].
double wrapAngle(double rad);

using ftid::shellQuote;  ///< ftid/common/shell_quote.hpp

}  // namespace ftid::lab
